"""Horizontal currents in air over a lossy half-space (soil): the reflected parts of the
mixed-potential Green's functions by Sommerfeld integrals, and the Fresnel far field.

For sources and observers in air (z, z' > 0) over soil of complex relative permittivity
eps = eps_r - j sigma / (w eps0) (mu = mu0; time convention exp(jwt)), with kz_i =
sqrt(k_i^2 - krho^2), Im kz_i <= 0 (Michalski & Zheng 1990, IEEE TAP 38, 335, formulation C,
written out for one interface):

    G_A^xx = mu0/(4 pi) [exp(-jkR)/R + S(R_TE)],  G_phi = 1/(4 pi eps0) [exp(-jkR)/R + S(R_q)],
    S(F)   = int_0^inf F(krho) exp(-j kz0 zeta) J0(krho rho) krho / (j kz0) dkrho,  zeta = z + z',
    R_TE   = (kz0 - kz2) / (kz0 + kz2),
    R_q    = R_TE + 2 kz0^2 (1 - eps) / ((kz0 + kz2)(eps kz0 + kz2)).

Only the xx term of A and the scalar potential are needed: every current is horizontal and
is tested against horizontal functions. As krho -> inf, R_TE -> 0 and R_q -> K_q =
(1 - eps)/(1 + eps), the quasi-static charge image; S(K_q) is exactly K_q exp(-jkR')/R'
(Sommerfeld's identity), which the engine integrates like a PEC image (closed-form near
terms) with weight K_q. What is left, S(R_TE) and S(R_q - K_q), is smooth (bounded at
rho = 0; it varies on the scale of the soil wavelength) and is tabulated here in rho for each
distinct zeta (a flat design has at most three: plate-plate, plate-blade, blade-blade).
Checks: infinite conductivity gives the PEC image (R_TE = R_q = -1); the tests compare
these integrals with scipy's adaptive quadrature and a strip dipole over soil with NEC-2's
Sommerfeld ground.

The integrals are taken along the real krho axis (no Python library evaluates Sommerfeld
integrals; this is the textbook real-axis scheme, vectorised): soil loss keeps its branch
point and the surface-wave pole off the axis, and the air branch point's 1/kz0 is removed
by substitution (krho = k0 sin t below k0, k0 cosh u just above), so Gauss-Legendre panels
integrate a smooth function everywhere; the panels are narrow enough to resolve J0 at the
largest rho tabulated. Far field: the direct wave plus its Fresnel reflection (R_v for the
theta component, R_h for phi), the same reflection-coefficient far field as NEC-2's.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass

import numpy as np
from scipy.constants import c as C0
from scipy.constants import epsilon_0 as EPS0
from scipy.constants import mu_0 as MU0
from scipy.interpolate import CubicSpline
from scipy.special import j0

__all__ = ["C0", "EPS0", "MU0", "ReflectedKernels", "charge_image", "fresnel", "reflected_integrals", "reflection",
           "soil_permittivity"]


def soil_permittivity(eps_r: float, sigma: float, freq_hz: float) -> complex:
    """Complex relative permittivity eps_r - j sigma/(w eps0) (exp(jwt) convention)."""
    return complex(eps_r, -sigma / (2 * np.pi * freq_hz * EPS0))


def _kz(k2: complex | np.ndarray, krho: np.ndarray) -> np.ndarray:
    """sqrt(k^2 - krho^2) on the proper sheet (Im <= 0)."""
    kz = np.sqrt(k2 - krho.astype(complex) ** 2)
    return np.where(kz.imag > 0, -kz, kz)


def reflection(krho: np.ndarray, k0: float, eps: complex) -> tuple[np.ndarray, np.ndarray]:
    """(R_TE, R_q) at ``krho``, written without cancellation at large krho."""
    kz0, kz2 = _kz(k0 ** 2, krho), _kz(eps * k0 ** 2, krho)
    rte = k0 ** 2 * (1 - eps) / (kz0 + kz2) ** 2  # (kz0 - kz2)/(kz0 + kz2), as (kz0^2 - kz2^2)/(kz0 + kz2)^2
    rq = rte + 2 * kz0 ** 2 * (1 - eps) / ((kz0 + kz2) * (eps * kz0 + kz2))
    return rte, rq


def charge_image(eps: complex) -> complex:
    """K_q = (1 - eps)/(1 + eps): R_q as krho -> inf (the electrostatic image weight)."""
    return (1 - eps) / (1 + eps)


def _gauss_panels(edges: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(order)
    a, b = edges[:-1, None], edges[1:, None]
    return ((a + b) / 2 + (b - a) / 2 * x).ravel(), ((b - a) / 2 * w).ravel()


TAIL_RHO = 2.0  # m: the spectral tail beyond K_SPLIT is integrated for rho up to this only


def _split_point(k0: float, eps: complex) -> float:
    """Where the spectral integral's tail starts: beyond it R_TE and R_q - K_q have decayed
    like (k_soil / krho)^2, so the tail adds an endpoint term ~ K^-2.5 / rho at rho >= TAIL_RHO:
    below 1e-6 of the table's largest value at 40-100 MHz on MRO soil (test_pfft); at smaller
    rho it is integrated in full."""
    return max(150.0 * k0, 10.0 * abs(np.sqrt(eps)) * k0)


def spectral_nodes(k0: float, eps: complex, zeta: float, rho_max: float,
                   order: int = 8, k_stop: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
    """Nodes krho and weights w (krho/(j kz0) dkrho included) of the real-axis rule for S(.)
    at height sum ``zeta`` out to ``rho_max``: the integrand is exp(-krho zeta)-small beyond
    the last node (40 e-folds, at least 60 k0), and an 8-point panel spans at most one period
    of J0(krho rho_max) (agrees with panels 4x narrower to 1e-10 at rho 10-44 m). Nodes stop
    at ``k_stop`` (see :func:`tail_nodes`)."""
    width = _panel_width(k0, rho_max)
    # below k0: krho = k0 sin t, krho dkrho/(j kz0) = -j krho dt
    n1 = max(8, int(np.ceil(k0 / width)))
    t, wt = _gauss_panels(np.linspace(0.0, np.pi / 2, n1 + 1), order)
    kr1, w1 = k0 * np.sin(t), -1j * k0 * np.sin(t) * wt
    # just above k0: krho = k0 cosh u, krho dkrho/(j kz0) = krho du
    u_end = np.arccosh(1.5)
    n2 = max(8, int(np.ceil(0.5 * k0 / width)))
    u, wu = _gauss_panels(np.linspace(0.0, u_end, n2 + 1), order)
    kr2, w2 = k0 * np.cosh(u), k0 * np.cosh(u) * wu
    # the rest, straight: panels of the J0 width, wider where exp(-krho zeta) has killed it
    kr3, wk = _gauss_panels(_straight_edges(k0, eps, zeta, width, k_stop), order)
    w3 = kr3 / (1j * _kz(k0 ** 2, kr3)) * wk
    return np.concatenate([kr1, kr2, kr3]), np.concatenate([w1, w2, w3])


def _spectral_end(k0: float, eps: complex, zeta: float) -> float:
    """Where the spectral rule stops: 40 e-folds of exp(-krho zeta), past the soil's branch
    point and pole (4 k_soil). (A floor of 60 k0 here cost the blade's height sums, 1-2 m,
    2-5x the nodes for a tail below 1e-17 of the kernels.)"""
    return max(40.0 / zeta, 4.0 * abs(np.sqrt(eps)) * k0)


def tail_nodes(k0: float, eps: complex, zeta: float, k_from: float, rho_max: float,
               order: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """The rule from ``k_from`` to the end, with panels that resolve J0 only out to
    ``rho_max`` (the tail matters at small rho only: its J0 would need panels as narrow as
    the body's at the plate's far side, most of the nodes for a 1 cm height sum)."""
    k_end = _spectral_end(k0, eps, zeta)
    if k_end <= k_from:
        return np.zeros(0), np.zeros(0, complex)
    width = 2 * np.pi / max(rho_max, 1e-3)
    edges = np.arange(k_from, k_end + width, width)
    kr, wk = _gauss_panels(edges, order)
    return kr, kr / (1j * _kz(k0 ** 2, kr)) * wk


def _integrate(rho: np.ndarray, kr: np.ndarray, w: np.ndarray, k0: float, eps: list[complex], zeta: float,
               chunk: int) -> np.ndarray:
    """[n_rho, 4 x n_soils]: Re, Im of S(R_TE) and of S(R_q - K_q) for each soil ``eps``, one
    J0 matrix for all of them (the J0 evaluations are the cost; the soils only weight them)."""
    cols = []
    for e in eps:
        rte, rq = reflection(kr, k0, e)
        decay = np.exp(-1j * _kz(k0 ** 2, kr) * zeta) * w
        fa, fq = rte * decay, (rq - charge_image(e)) * decay
        cols += [fa.real, fa.imag, fq.real, fq.imag]
    f = np.stack(cols, axis=1)
    out = np.zeros((len(rho), f.shape[1]))
    for s in range(0, len(rho), chunk):
        out[s:s + chunk] = j0(np.outer(rho[s:s + chunk], kr)) @ f
    return out


def reflected_integrals(rho: np.ndarray, k0: float, eps: complex, zeta: float,
                        rho_max: float | None = None, chunk: int = 64,
                        split: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """(S(R_TE), S(R_q - K_q)) at each ``rho`` (1/m; multiply by mu0/4pi and 1/(4 pi eps0)).

    ``split``: the spectral tail beyond :func:`_split_point` is added only where rho <=
    TAIL_RHO (its panels then resolve J0 to TAIL_RHO, not to ``rho_max``): 10-30x fewer
    J0 evaluations for the plate's 1 cm height sum; ``split=False`` is the reference."""
    return reflected_integrals_many(rho, k0, [eps], zeta, rho_max, chunk, split)[0]


def reflected_integrals_many(rho: np.ndarray, k0: float, eps: list[complex], zeta: float,
                             rho_max: float | None = None, chunk: int = 64,
                             split: bool = True) -> list[tuple[np.ndarray, np.ndarray]]:
    """:func:`reflected_integrals` for several soils at once, on one rule: its nodes reach as
    far as the soil that needs the most (the others' extra nodes add below 1e-17)."""
    rho = np.asarray(rho, dtype=float)
    rho_max = float(rho.max()) if rho_max is None else rho_max
    far = max(eps, key=lambda e: abs(np.sqrt(e)))  # the end and split grow with |sqrt(eps)|
    k_split = _split_point(k0, far) if split and rho_max > TAIL_RHO else np.inf
    kr, w = spectral_nodes(k0, far, zeta, rho_max, k_stop=k_split)
    out = _integrate(rho, kr, w, k0, eps, zeta, chunk)
    if np.isfinite(k_split):  # the tail starts where the body's last panel ends
        body_end = _straight_edges(k0, far, zeta, _panel_width(k0, rho_max), k_split)[-1]
        kr_t, w_t = tail_nodes(k0, far, zeta, float(body_end), TAIL_RHO)
    if np.isfinite(k_split) and len(kr_t):
        near = rho <= TAIL_RHO
        out[near] += _integrate(rho[near], kr_t, w_t, k0, eps, zeta, chunk)
    return [(out[:, 4 * i] + 1j * out[:, 4 * i + 1], out[:, 4 * i + 2] + 1j * out[:, 4 * i + 3])
            for i in range(len(eps))]


def _panel_width(k0: float, rho_max: float) -> float:
    """An 8-point panel spans at most one period of J0(krho rho_max) (and a tenth of k0)."""
    return min(2 * np.pi / max(rho_max, 1e-3), 0.1 * k0)


def _straight_edges(k0: float, eps: complex, zeta: float, width: float, k_stop: float = np.inf) -> np.ndarray:
    """Panel edges of the straight part of :func:`spectral_nodes`, from 1.5 k0 to its end."""
    return np.arange(1.5 * k0, min(_spectral_end(k0, eps, zeta), k_stop) + width, width)


@dataclass
class ReflectedKernels:
    """The smooth reflected kernels S(R_TE) and S(R_q - K_q) of one frequency, tabulated in
    rho for each height sum zeta, looked up by linear interpolation on a fine uniform grid
    (resampled from an accurate cubic spline: the fill looks up ~1e8 points per frequency)."""

    k0: float
    eps: complex
    zetas: np.ndarray
    step: float
    tables: np.ndarray  # [n_zeta, 2, n_rho] complex

    @classmethod
    def build(cls, freq_hz: float, eps_r: float, sigma: float, zetas: np.ndarray,
              rho_max: float) -> "ReflectedKernels":
        return cls.build_many(freq_hz, [(eps_r, sigma)], zetas, rho_max)[0]

    @classmethod
    def build_many(cls, freq_hz: float, soils: list[tuple[float, float]], zetas: np.ndarray,
                   rho_max: float) -> list["ReflectedKernels"]:
        """The kernels of each soil (eps_r, sigma S/m) at one frequency; soils that sample rho
        alike (most do: the step is capped at 5 cm) share one J0 matrix per height sum."""
        k0 = 2 * np.pi * freq_hz / C0
        zetas = np.unique(np.round(np.asarray(zetas, dtype=float), 9))
        eps = [soil_permittivity(e, s, freq_hz) for e, s in soils]
        steps = [min(0.25 / (abs(np.sqrt(e)) * k0), 0.05) for e in eps]  # ~ soil wavelength / 25
        out: list[ReflectedKernels | None] = [None] * len(soils)
        for coarse_step in sorted(set(steps)):
            group = [i for i, st in enumerate(steps) if st == coarse_step]
            fine = coarse_step / 8
            n = int(np.ceil(rho_max / fine)) + 2
            tables = np.empty((len(group), len(zetas), 2, n), dtype=complex)
            grid = np.arange(n) * fine
            for iz, zeta in enumerate(zetas):
                near = np.arange(0.0, 6 * zeta, min(zeta, coarse_step) / 4)
                coarse = np.unique(np.concatenate([near, np.arange(0.0, grid[-1] + coarse_step, coarse_step)]))
                values = reflected_integrals_many(coarse, k0, [eps[i] for i in group], float(zeta))
                for g, (a, q) in enumerate(values):
                    for j, vals in enumerate((a, q)):
                        tables[g, iz, j] = CubicSpline(coarse, vals)(grid)
            for g, i in enumerate(group):
                out[i] = cls(k0, eps[i], zetas, fine, tables[g])
        return out  # type: ignore[return-value]

    @classmethod
    def cached(cls, freq_hz: float, eps_r: float, sigma: float, zetas: np.ndarray,
               rho_max: float) -> "ReflectedKernels":
        """:meth:`cached_many` of one soil."""
        return cls.cached_many(freq_hz, [(eps_r, sigma)], zetas, rho_max)[0]

    @classmethod
    def cached_many(cls, freq_hz: float, soils: list[tuple[float, float]], zetas: np.ndarray,
                    rho_max: float) -> list["ReflectedKernels"]:
        """:meth:`build_many`, tabulated out to ``rho_max`` rounded up to TABLE_BUCKET_M and kept
        (in this process and on disk under the cache folder): the tables depend on the soil,
        the frequency and the metal's heights, not on the plate's outline, so every design of
        a search (and every worker) shares them. A damaged file is built again."""
        rho_max = TABLE_BUCKET_M * np.ceil(max(rho_max, 1e-3) / TABLE_BUCKET_M)
        zetas = np.unique(np.round(np.asarray(zetas, dtype=float), 9))
        idents = [json.dumps([TABLE_VERSION, round(freq_hz, 3), float(e), float(s), zetas.tolist(), float(rho_max)])
                  for e, s in soils]
        keys = [hashlib.sha256(ident.encode()).hexdigest()[:32] for ident in idents]
        folder = _table_dir()
        found: list[ReflectedKernels | None] = []
        for key, ident in zip(keys, idents):
            if key not in _TABLES and folder is not None and (k := _read_tables(folder / f"{key}.npz", ident)):
                _remember(key, k)
            found.append(_TABLES.get(key))
        missing = [i for i, k in enumerate(found) if k is None]
        if missing:
            for i, kernels in zip(missing, cls.build_many(freq_hz, [soils[i] for i in missing], zetas, rho_max)):
                found[i] = kernels
                _remember(keys[i], kernels)
                if folder is not None:
                    _write_tables(folder / f"{keys[i]}.npz", idents[i], kernels)
        return found  # type: ignore[return-value]

    def lookup(self, rho: np.ndarray, zeta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(S(R_TE), S(R_q - K_q)) at horizontal distances ``rho`` and height sums ``zeta``
        (broadcastable; every zeta must be one the kernels were built for)."""
        which = np.searchsorted(0.5 * (self.zetas[1:] + self.zetas[:-1]), zeta)  # the nearest table
        if np.abs(self.zetas[which] - zeta).max() > 1e-8:
            raise ValueError("surface engine: a height sum with no reflected-kernel table")
        x = rho / self.step
        i = np.minimum(x.astype(np.int64), self.tables.shape[2] - 2)
        f = x - i
        t = self.tables
        a = t[which, 0, i] * (1 - f) + t[which, 0, i + 1] * f
        q = t[which, 1, i] * (1 - f) + t[which, 1, i + 1] * f
        return a, q


def fresnel(cos_theta: np.ndarray, eps: complex) -> tuple[np.ndarray, np.ndarray]:
    """(R_v, R_h): plane-wave reflection of the theta (TM) and phi (TE) components for
    elevation angle theta from zenith; R_v -> 1 and R_h -> -1 over a perfect conductor."""
    c = np.asarray(cos_theta, dtype=float)
    root = np.sqrt(eps - (1 - c ** 2) + 0j)
    return (eps * c - root) / (eps * c + root), (c - root) / (c + root)


TABLE_BUCKET_M = 8.0  # tables reach a multiple of this: designs of similar size share them
TABLE_VERSION = 1  # bump when :meth:`ReflectedKernels.build` changes: old files are then not read
TABLES_IN_MEMORY = 64  # one frequency and soil each (~0.5 MB): a worker's band on a few soils
_TABLES: dict[str, ReflectedKernels] = {}


def _remember(key: str, kernels: ReflectedKernels) -> None:
    if len(_TABLES) >= TABLES_IN_MEMORY and key not in _TABLES:
        _TABLES.pop(next(iter(_TABLES)))
    _TABLES[key] = kernels


def _table_dir():
    """Where tables are kept on disk (``<cache>/sommerfeld``), or None when it cannot be made."""
    from groundplane.sky import cache_dir

    d = cache_dir() / "sommerfeld"
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return d


def _read_tables(path, ident: str) -> ReflectedKernels | None:
    """The kernels stored at ``path`` for ``ident``, or None (absent, damaged or another's)."""
    try:
        with np.load(path, allow_pickle=False) as z:
            if str(z["ident"]) != ident:
                return None
            return ReflectedKernels(float(z["k0"]), complex(z["eps"]), np.array(z["zetas"]), float(z["step"]),
                                    np.array(z["tables"]))
    except Exception:  # noqa: BLE001 - absent or any damage: build it again
        return None


def _write_tables(path, ident: str, kernels: ReflectedKernels) -> None:
    from groundplane.errors import GroundplaneError
    from groundplane.files import atomic_path

    try:
        with atomic_path(path, suffix=".tmp.npz") as tmp:
            np.savez(tmp, ident=ident, k0=kernels.k0, eps=kernels.eps, zetas=kernels.zetas, step=kernels.step,
                     tables=kernels.tables)
    except (GroundplaneError, OSError):  # a cache we cannot write: the tables are built again next time
        pass
