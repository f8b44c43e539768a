"""Surface-current Method of Moments: the mixed-potential EFIE on flat horizontal metal
(plates, panels) with Rao-Wilton-Glisson (RWG) basis functions, Galerkin testing, in free
space or over infinite perfect ground (image theory), a delta-gap feed, and the far field.

Written here rather than taken from ``bempp-cl``: bempp offers no half-space kernel (PEC
image or Sommerfeld), which every solve over ground needs (how the two compared on the blade
in free space: docs/surface-engine.md). Everything below is numpy/scipy, vectorised over
triangle pairs (the fast solve's two innermost loops are compiled: ``_compiled.py``):

* Matrix: Z = jw mu/(4 pi) <f_m, A f_n> - j/(4 pi w eps) <div f_m, Phi div f_n> with the
  kernel G = exp(-jkR)/R (minus its image over PEC). Per triangle pair the integrals reduce
  to a few moments (the scalar, the first moments on either side and the cross moment of G
  over the pair); Z is then gathers of those with the RWG coefficients (each basis lives on
  two triangles), so nothing is looped in Python per element.
* Distant pairs: 3-point rules (degree 2) on both triangles. Near pairs (centroids closer
  than ``near_factor`` times the larger triangle, images included): 7-point outer rule
  (Dunavant, degree 5; on 16 sub-triangles for close pairs); the inner 1/R and rho'/R
  integrals in closed form (Wilton et al. 1984, IEEE TAP 32, 276; no library provides them
  for numpy arrays), the smooth rest (exp(-jkR) - 1)/R by the 7-point rule.
* Only horizontal triangles (every structure we model is flat and level): currents are
  horizontal, so a PEC image is the same current reversed at -z, for both potentials.
* Designs symmetric about both axes are solved in the driven symmetry class only
  (:class:`MirrorSymmetry`): exact, a quarter of the fill.
* Gain = 4 pi U / P_in with P_in = 1/2 Re(V I*) at the gap: a lossless model must radiate
  what it takes in (mean gain 2 over the upper hemisphere over PEC, 1 over the sphere in
  free space), which the tests check (no calibration).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from .halfspace import C0, EPS0, MU0, ReflectedKernels, charge_image, fresnel, soil_permittivity

ETA0 = MU0 * C0

# Barycentric quadrature on a triangle (weights sum to 1; multiply by the area).
_Q3 = (np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]]), np.full(3, 1 / 3))
_a1, _b1, _a2, _b2 = 0.059715871789770, 0.470142064105115, 0.797426985353087, 0.101286507323456
_Q7 = (np.array([[1 / 3, 1 / 3, 1 / 3],
                 [_a1, _b1, _b1], [_b1, _a1, _b1], [_b1, _b1, _a1],
                 [_a2, _b2, _b2], [_b2, _a2, _b2], [_b2, _b2, _a2]]),
       np.array([0.225] + [0.132394152788506] * 3 + [0.125939180544827] * 3))


@dataclass
class TriMesh:
    """Flat horizontal triangles: ``nodes`` [P, 3] (m), ``tris`` [T, 3] node indices, and the
    delta-gap feed: ``feed_edges`` (node pairs) each driven with ``feed_volts`` V/m x length."""

    nodes: np.ndarray
    tris: np.ndarray
    feed_edges: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), int))
    feed_volts: float = 1.0

    def __post_init__(self) -> None:
        self.nodes = np.asarray(self.nodes, dtype=float)
        self.tris = np.asarray(self.tris, dtype=np.int64)
        z = self.nodes[self.tris, 2]
        if np.ptp(z, axis=1).max(initial=0.0) > 1e-9:
            raise ValueError("surface engine: every triangle must be horizontal (flat, level metal only)")
        if np.any(self.areas <= 1e-12):
            raise ValueError("surface engine: degenerate (zero-area) triangle in the mesh")

    @property
    def areas(self) -> np.ndarray:
        p = self.nodes[self.tris]
        a, b = p[:, 1, :2] - p[:, 0, :2], p[:, 2, :2] - p[:, 0, :2]
        return 0.5 * np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])

    @property
    def centroids(self) -> np.ndarray:
        return self.nodes[self.tris].mean(axis=1)

    @property
    def sizes(self) -> np.ndarray:
        """Longest edge of each triangle (m)."""
        p = self.nodes[self.tris]
        return np.max(np.linalg.norm(p - np.roll(p, 1, axis=1), axis=2), axis=1)


@dataclass
class Rwg:
    """RWG basis on a mesh: edge n joins triangles ``plus[n]`` and ``minus[n]`` with free
    vertices (local indices) ``plus_free[n]``, ``minus_free[n]``; ``length[n]`` (m)."""

    edges: np.ndarray
    plus: np.ndarray
    minus: np.ndarray
    plus_free: np.ndarray
    minus_free: np.ndarray
    length: np.ndarray
    feed: np.ndarray  # indices of the driven edges

    @property
    def n(self) -> int:
        return len(self.length)


def rwg_basis(mesh: TriMesh) -> Rwg:
    """Every interior edge shared by exactly two triangles is one unknown."""
    t = mesh.tris
    local = np.array([[1, 2], [2, 0], [0, 1]])  # edge opposite local vertex 0, 1, 2
    e = np.sort(t[:, local], axis=2).reshape(-1, 2)
    tri = np.repeat(np.arange(len(t)), 3)
    free = np.tile(np.arange(3), len(t))
    keys, inv, counts = np.unique(e, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    if np.any(counts > 2):
        raise ValueError(f"surface engine: {int(np.sum(counts > 2))} edges shared by more than two triangles")
    shared = np.flatnonzero(counts == 2)
    order = np.argsort(inv, kind="stable")
    first = np.searchsorted(inv[order], shared)
    a, b = order[first], order[first + 1]
    edges = keys[shared]
    length = np.linalg.norm(mesh.nodes[edges[:, 0]] - mesh.nodes[edges[:, 1]], axis=1)
    feed = np.zeros(0, int)
    if len(mesh.feed_edges):
        fe = np.sort(np.asarray(mesh.feed_edges, int), axis=1)
        lookup = {tuple(k): i for i, k in enumerate(edges)}
        missing = [tuple(k) for k in fe if tuple(k) not in lookup]
        if missing:
            raise ValueError(f"surface engine: feed edge(s) {missing[:3]} are not interior edges of the mesh")
        feed = np.array([lookup[tuple(k)] for k in fe])
    return Rwg(edges, tri[a], tri[b], free[a], free[b], length, feed)


def _coefficients(mesh: TriMesh, rwg: Rwg) -> tuple[sp.csr_matrix, list[sp.csr_matrix]]:
    """f_n = c (r - v) on each of its two triangles: C1[n, t] = c = +-l/(2A) and
    Cv[k][n, t] = c v_k (x, y of the free vertex), as sparse N x T matrices."""
    area = mesh.areas
    rows = np.concatenate([np.arange(rwg.n)] * 2)
    tris = np.concatenate([rwg.plus, rwg.minus])
    sign = np.concatenate([np.ones(rwg.n), -np.ones(rwg.n)])
    c = sign * np.concatenate([rwg.length] * 2) / (2 * area[tris])
    v = mesh.nodes[mesh.tris[tris, np.concatenate([rwg.plus_free, rwg.minus_free])]]
    shape = (rwg.n, len(mesh.tris))
    c1 = sp.csr_matrix((c, (rows, tris)), shape=shape)
    cv = [sp.csr_matrix((c * v[:, k], (rows, tris)), shape=shape) for k in range(2)]
    return c1, cv


def _points(mesh: TriMesh, rule: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature points [T, Q, 3] and weights [T, Q] (area included)."""
    bary, w = rule
    p = np.einsum("qk,tkd->tqd", bary, mesh.nodes[mesh.tris])
    p[..., 2] = mesh.nodes[mesh.tris[:, 0], 2][:, None]  # exactly the triangle's level: a self pair's
    return p, w[None, :] * mesh.areas[:, None]  # coincident points must be at R = 0, not 1e-17


def _smooth(r: np.ndarray, k: float) -> np.ndarray:
    """(exp(-jkR) - 1)/R without cancellation at small kR (its limit at R = 0 is -jk)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        out = (-2.0 * np.sin(0.5 * k * r) ** 2 - 1j * np.sin(k * r)) / r
    return np.where(r > 1e-12, out, -1j * k)


def _kernel(r: np.ndarray, k: float) -> np.ndarray:
    """exp(-jkR)/R, with 0 where R ~ 0 (a self pair's coincident points: the near-pair
    correction subtracts exactly this rule, so the value there never reaches Z; a value
    of 1e17 there would, by cancellation, wipe out the self term)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(r > 1e-9, np.exp(-1j * k * r) / r, 0.0)


def _product_rule(po: np.ndarray, wo: np.ndarray, ps: np.ndarray, ws: np.ndarray, zs: np.ndarray,
                  k: float) -> np.ndarray:
    """Moments [6, ...] of G by the product of two point rules, for triangle pairs laid out
    on any broadcastable leading shape (every pair of a block, or a list of pairs):
    points ``po`` [..., Qo, 3] / ``ps`` [..., Qs, 3], weights ``wo``/``ws`` (area included),
    source level ``zs`` [...] (negated for an image). Returns S0 = sum w w' G, the
    observation first moments Sx, Sy, Srr = sum w w' G (rho . rho'), and the source first
    moments Sx', Sy'. The dense fill and the near-pair correction both use this, so the
    correction subtracts exactly what the fill put in."""
    d = po[..., :, None, :2] - ps[..., None, :, :2]
    dz = po[..., :, None, 2] - zs[..., None, None]
    r = np.sqrt(np.einsum("...k,...k->...", d, d) + dz ** 2)
    return _moments(_kernel(r, k) * wo[..., :, None] * ws[..., None, :], po, ps)


def _moments(g: np.ndarray, po: np.ndarray, ps: np.ndarray) -> np.ndarray:
    """The six pair moments [6, ...] of weighted kernel values ``g`` [..., Qo, Qs]."""
    so = np.einsum("...i,...ik->k...", g.sum(axis=-1), po[..., :2])
    ss = np.einsum("...j,...jk->k...", g.sum(axis=-2), ps[..., :2])
    srr = np.einsum("...ik,...ik->...", np.einsum("...ij,...jk->...ik", g, ps[..., :2]), po[..., :2])
    return np.stack([g.sum(axis=(-1, -2)), so[0], so[1], srr, ss[0], ss[1]])


def _reflected_rule(po: np.ndarray, wo: np.ndarray, ps: np.ndarray, ws: np.ndarray, zs: np.ndarray,
                    kernels: ReflectedKernels) -> tuple[np.ndarray, np.ndarray]:
    """The soil's smooth reflected kernels by a product rule (shapes as ``_product_rule``):
    the six moments of S(R_TE) (vector potential) and S0 of S(R_q - K_q) (scalar)."""
    d = po[..., :, None, :2] - ps[..., None, :, :2]
    rho = np.sqrt(np.einsum("...k,...k->...", d, d))
    zeta = po[..., :, None, 2] + zs[..., None, None]
    ga, gq = kernels.lookup(rho, zeta)
    w = wo[..., :, None] * ws[..., None, :]
    return _moments(ga * w, po, ps), (gq * w).sum(axis=(-1, -2))


def _block_moments(po: np.ndarray, wo: np.ndarray, ps: np.ndarray, ws: np.ndarray, zs: np.ndarray, k: float,
                   weights: tuple | None, kernels: ReflectedKernels | None) -> tuple[np.ndarray, np.ndarray]:
    """The fill's 3-point moments of a block, every kernel summed before the moments are
    taken (one set of moments, not one per kernel): the six of the vector potential's
    kernel (direct + image weight x image + soil's S(R_TE)) and S0 of the scalar
    potential's (direct + its image weight x image + S(R_q - K_q)). The same sums as
    ``_product_rule`` and ``_reflected_rule`` term by term, which the near-pair corrections
    subtract."""
    d = po[..., :, None, :2] - ps[..., None, :, :2]
    rho2 = np.einsum("...k,...k->...", d, d)
    zo = po[..., :, None, 2]
    w = wo[..., :, None] * ws[..., None, :]
    g_dir = _kernel(np.sqrt(rho2 + (zo - zs[..., None, None]) ** 2), k) * w
    g_a, g_q = g_dir, g_dir
    if weights is not None:
        zeta = zo + zs[..., None, None]
        g_img = _kernel(np.sqrt(rho2 + zeta ** 2), k) * w
        g_a = g_a + weights[0] * g_img if weights[0] != 0 else g_a
        g_q = g_q + weights[1] * g_img
        if kernels is not None:
            ga, gq = kernels.lookup(np.sqrt(rho2), zeta)
            g_a = g_a + ga * w
            g_q = g_q + gq * w
    return _moments(g_a, po, ps), g_q.sum(axis=(-1, -2))


def potential_integrals(rho: np.ndarray, d: np.ndarray, verts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form integrals over flat triangles of 1/R and (rho' - rho)/R (Wilton et al.
    1984), for observation points with in-plane position ``rho`` [..., 2] at height ``d``
    [...] above the plane of triangles ``verts`` [..., 3, 2] (any orientation).

    Returns (I [...], J [..., 2]): I = int 1/R dS', J = int (rho' - rho)/R dS'."""
    v = verts
    orient = np.sign((v[..., 1, 0] - v[..., 0, 0]) * (v[..., 2, 1] - v[..., 0, 1])
                     - (v[..., 1, 1] - v[..., 0, 1]) * (v[..., 2, 0] - v[..., 0, 0]))
    ad = np.abs(d)
    total_i = np.zeros(np.broadcast_shapes(rho.shape[:-1], d.shape), dtype=float)
    total_j = np.zeros(total_i.shape + (2,))
    for a, b in ((0, 1), (1, 2), (2, 0)):
        pa, pb = v[..., a, :], v[..., b, :]
        edge = pb - pa
        ell = np.linalg.norm(edge, axis=-1)
        lhat = edge / ell[..., None]
        uhat = orient[..., None] * np.stack([lhat[..., 1], -lhat[..., 0]], axis=-1)  # outward in-plane normal
        ra, rb = pa - rho, pb - rho
        t0 = np.einsum("...k,...k->...", ra, uhat)
        lm = np.einsum("...k,...k->...", ra, lhat)
        lp = np.einsum("...k,...k->...", rb, lhat)
        r0sq = t0 ** 2 + d ** 2
        rm = np.sqrt(lm ** 2 + r0sq)
        rp = np.sqrt(lp ** 2 + r0sq)
        with np.errstate(divide="ignore", invalid="ignore"):
            # R + l, written as R0^2 / (R - l) where l < 0 so it never cancels
            fp = np.where(lp >= 0, rp + lp, r0sq / (rp - lp))
            fm = np.where(lm >= 0, rm + lm, r0sq / (rm - lm))
            log = np.where(r0sq > 1e-24, np.log(fp) - np.log(fm), 0.0)
            atn = np.where(ad > 0, np.arctan2(t0 * lp, r0sq + ad * rp) - np.arctan2(t0 * lm, r0sq + ad * rm), 0.0)
        total_i += t0 * log - ad * atn
        total_j += 0.5 * uhat * (r0sq * log + lp * rp - lm * rm)[..., None]
    return total_i, total_j


@dataclass
class Problem:
    """A mesh ready to solve: basis, coefficients, and the near-pair lists. ``soil`` is
    (eps_r, sigma S/m) for ``ground="soil"`` (see ``halfspace.py``)."""

    mesh: TriMesh
    rwg: Rwg
    ground: str  # "pec" | "free" | "soil"
    near_factor: float = 2.5
    soil: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.ground not in ("pec", "free", "soil"):
            raise ValueError(f"surface engine: ground must be 'pec', 'soil' or 'free', got {self.ground!r}")
        if self.ground == "soil" and self.soil is None:
            raise ValueError("surface engine: ground 'soil' needs soil=(eps_r, sigma)")
        if self.ground != "free" and np.any(self.mesh.nodes[:, 2] <= 0):
            raise ValueError(f"surface engine: over {self.ground} every triangle must be above z = 0")
        self.c1, self.cv = _coefficients(self.mesh, self.rwg)
        cen, size = self.mesh.centroids, self.mesh.sizes
        self.near = [self._near_pairs(cen, size, img) for img in ((False,) if self.ground == "free" else (False, True))]

    def _near_pairs(self, cen: np.ndarray, size: np.ndarray, image: bool) -> np.ndarray:
        src = cen * np.array([1, 1, -1]) if image else cen
        radius = self.near_factor * size.max()
        tree = cKDTree(src)
        pairs = tree.sparse_distance_matrix(cKDTree(cen), radius, output_type="coo_matrix")
        s, o = pairs.row, pairs.col
        dist = np.linalg.norm(cen[o] - src[s], axis=1)
        keep = dist < self.near_factor * np.maximum(size[o], size[s])
        if not image:  # a triangle with itself: distance 0, dropped by the sparse matrix
            self_pairs = np.arange(len(cen))
            return np.unique(np.concatenate([np.stack([o[keep], s[keep]], 1), np.stack([self_pairs] * 2, 1)]), axis=0)
        return np.stack([o[keep], s[keep]], 1)

    @property
    def n(self) -> int:
        return self.rwg.n

    def image_weights(self, freq_hz: float, soil: tuple[float, float] | None = None
                      ) -> tuple[float | complex, float | complex] | None:
        """Weights (vector, scalar potential) of the image kernel exp(-jkR')/R': the
        reversed current over PEC (-1, -1); over soil (``soil``, default the problem's) only
        the quasi-static charge image (0, K_q), the rest being the tabulated reflected
        kernels; None in free space."""
        if self.ground == "pec":
            return -1.0, -1.0
        if self.ground == "soil":
            return 0.0, charge_image(soil_permittivity(*(soil or self.soil), freq_hz))
        return None

    def reflected_kernels(self, freq_hz: float, reach: float = 0.0,
                          soil: tuple[float, float] | None = None) -> ReflectedKernels | None:
        """The soil's (``soil``, default the problem's) smooth reflected kernels for this mesh's
        height sums, or None; tabulated to the mesh's diagonal plus ``reach`` (m; the fast
        solve's grid extends past the metal)."""
        if self.ground != "soil":
            return None
        return self.reflected_kernels_many(freq_hz, [soil or self.soil], reach)[0]

    def reflected_kernels_many(self, freq_hz: float, soils: list[tuple[float, float]],
                               reach: float = 0.0) -> list[ReflectedKernels]:
        """:meth:`reflected_kernels` of several soils, built together (and kept)."""
        levels = np.unique(np.round(self.mesh.nodes[:, 2], 9))
        zetas = (levels[:, None] + levels[None, :]).ravel()
        xy = self.mesh.nodes[:, :2]
        rho_max = float(np.hypot(*(xy.max(axis=0) - xy.min(axis=0)))) + 0.1 + reach
        return ReflectedKernels.cached_many(freq_hz, soils, zetas, rho_max)


def _subdivided(rule: tuple[np.ndarray, np.ndarray], level: int) -> tuple[np.ndarray, np.ndarray]:
    """``rule`` on each of the 4**level congruent sub-triangles of the reference triangle."""
    bary, w = rule
    tris = [np.eye(3)]
    for _ in range(level):
        nxt = []
        for t in tris:
            m01, m12, m20 = (t[0] + t[1]) / 2, (t[1] + t[2]) / 2, (t[2] + t[0]) / 2
            nxt += [np.array([t[0], m01, m20]), np.array([m01, t[1], m12]), np.array([m20, m12, t[2]]),
                    np.array([m12, m20, m01])]
        tris = nxt
    return (np.concatenate([bary @ t for t in tris]), np.tile(w, len(tris)) / len(tris))


_Q7_TOUCHING = _subdivided(_Q7, 2)  # 112 points: the outer rule where the inner integral has a log edge
CLOSE_FACTOR = 1.0  # pairs whose centroids are closer than this times the larger triangle use it


def _near_moments(mesh: TriMesh, pairs: np.ndarray, k: float, image: bool) -> np.ndarray:
    """Accurate moments [6, n_pairs] of G (direct or image) for near pairs (obs, src).

    Close pairs (centroids nearer than ``CLOSE_FACTOR`` times the larger triangle: the same,
    touching or nearly touching triangles) see an inner integral with a logarithmic edge
    singularity, which the 7-point outer rule integrates poorly on skewed triangles (Z lost
    its symmetry by up to 4 % on a Triangle mesh): their outer rule is the 7-point rule on
    16 sub-triangles."""
    out = np.empty((6, len(pairs)), dtype=complex)
    cen, size = mesh.centroids, mesh.sizes
    src = cen[pairs[:, 1]] * (np.array([1, 1, -1]) if image else 1)
    gap = np.linalg.norm(cen[pairs[:, 0]] - src, axis=1)
    close = gap < CLOSE_FACTOR * np.maximum(size[pairs[:, 0]], size[pairs[:, 1]])
    for sel, rule in ((~close, _Q7), (close, _Q7_TOUCHING)):
        if sel.any():
            out[:, sel] = _near_moments_rule(mesh, pairs[sel], k, image, rule)
    return out


def _near_moments_rule(mesh: TriMesh, pairs: np.ndarray, k: float, image: bool,
                       outer: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    sing, r, wo, ws, rho, ps = near_geometry(mesh, pairs, image, outer)
    return sing + smooth_moments(_smooth(r, k) * ws[:, None, :], wo, rho, ps)


def near_geometry(mesh: TriMesh, pairs: np.ndarray, image: bool, outer: tuple[np.ndarray, np.ndarray]) -> tuple:
    """The frequency-independent part of near pairs' accurate moments: the six moments [6, n]
    of the closed-form 1/R integrals, and the point geometry the smooth part is integrated
    on (distances r [n, Qo, 7], outer weights [n, Qo], inner weights [n, 7], outer and inner
    in-plane points [n, Qo, 2], [n, 7, 2])."""
    o, s = pairs[:, 0], pairs[:, 1]
    bary, w = outer
    po = np.einsum("qk,tkd->tqd", bary, mesh.nodes[mesh.tris[o]])
    po[..., 2] = mesh.nodes[mesh.tris[o, 0], 2][:, None]
    wo = w[None, :] * mesh.areas[o][:, None]
    ps, ws = _points(mesh, _Q7)
    ps, ws = ps[s], ws[s]
    zs = mesh.nodes[mesh.tris[s, 0], 2] * (-1 if image else 1)
    verts = mesh.nodes[mesh.tris[s]][..., :2]  # [n, 3, 2]
    rho = po[..., :2]
    d = po[..., 2] - zs[:, None]
    i_sing, j_sing = potential_integrals(rho, d, verts[:, None])  # [n, Qo], [n, Qo, 2]
    diff = po[:, :, None, :2] - ps[:, None, :, :2]
    r = np.sqrt(np.einsum("...k,...k->...", diff, diff) + d[..., None] ** 2)  # [n, Qo, 7]
    i1 = rho * i_sing[..., None] + j_sing
    sing = np.stack([np.einsum("ni,ni->n", wo, i_sing), *np.einsum("ni,nik->kn", wo * i_sing, rho),
                     np.einsum("ni,nik,nik->n", wo, rho, i1), *np.einsum("ni,nik->kn", wo, i1)])
    return sing, r, wo, ws, rho, ps[..., :2]


def smooth_moments(gs: np.ndarray, wo: np.ndarray, rho: np.ndarray, ps: np.ndarray) -> np.ndarray:
    """The six moments [6, n] of a smooth kernel given at the near pairs' points, times the
    inner weights (``gs`` [n, Qo, 7]), by the outer rule."""
    i0 = gs.sum(axis=2)
    i1 = gs @ ps  # int rho' G, [n, Qo, 2]
    wi0 = wo * i0
    wi1 = wo[..., None] * i1
    return np.stack([wi0.sum(axis=1), *(wi0[..., None] * rho).sum(axis=1).T, (rho * wi1).sum(axis=(1, 2)),
                     *wi1.sum(axis=1).T])


def _far_rule_pairs(mesh: TriMesh, pairs: np.ndarray, k: float, image: bool) -> np.ndarray:
    """The 3-point product-rule moments [6, n_pairs] of the same pairs (to be replaced)."""
    o, s = pairs[:, 0], pairs[:, 1]
    p, w = _points(mesh, _Q3)
    zs = mesh.nodes[mesh.tris[s, 0], 2] * (-1 if image else 1)
    return _product_rule(p[o], w[o], p[s], w[s], zs, k)


def _reflected_near(mesh: TriMesh, pairs: np.ndarray, kernels: ReflectedKernels) -> tuple[np.ndarray, np.ndarray]:
    """Near pairs' soil-reflected moments by 7 x 7 points minus the fill's 3 x 3 (the kernels
    are smooth, but vary on the scale of the soil wavelength, about a plate cell)."""
    o, s = pairs[:, 0], pairs[:, 1]
    zs = mesh.nodes[mesh.tris[s, 0], 2]
    (p7, w7), (p3, w3) = _points(mesh, _Q7), _points(mesh, _Q3)
    acc_a, acc_q = _reflected_rule(p7[o], w7[o], p7[s], w7[s], zs, kernels)
    far_a, far_q = _reflected_rule(p3[o], w3[o], p3[s], w3[s], zs, kernels)
    return acc_a - far_a, acc_q - far_q


def near_groups(prob: Problem, k: float, obs: np.ndarray):
    """(image, pairs, accurate moments [6, n]) of the near pairs whose observation triangle is
    in ``obs`` (a mask), in chunks: direct, then image."""
    for img, pairs in zip((False, True), prob.near):
        pairs = pairs[obs[pairs[:, 0]]]
        for start in range(0, len(pairs), 20000):
            pr = pairs[start:start + 20000]
            yield img, pr, _near_moments(prob.mesh, pr, k, img)


def _near_corrections(prob: Problem, k: float, obs: np.ndarray | None, weights: tuple | None,
                      kernels: ReflectedKernels | None, groups=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(pairs [n, 2], vector-potential corrections [6, n], scalar corrections [n]): accurate
    minus fill moments of the near pairs whose observation triangle is in ``obs`` (a mask):
    direct, image (with its ``weights``) and, over soil, the reflected kernels. ``groups``
    gives the accurate moments another way (the fast solve's series), as :func:`near_groups`."""
    all_pairs, all_a, all_q = [], [], []
    for img, pr, accurate in (near_groups(prob, k, obs) if groups is None else groups):
        wa, wq = weights if img else (1.0, 1.0)
        diff = accurate - _far_rule_pairs(prob.mesh, pr, k, img)
        all_pairs.append(pr)
        all_a.append(wa * diff)
        all_q.append(wq * diff[0])
        if img and kernels is not None:
            ca, cq = _reflected_near(prob.mesh, pr, kernels)
            all_pairs.append(pr)
            all_a.append(ca)
            all_q.append(cq)
    if not all_pairs:
        return np.zeros((0, 2), int), np.zeros((6, 0), complex), np.zeros(0, complex)
    return np.concatenate(all_pairs), np.concatenate(all_a, axis=1), np.concatenate(all_q)


def impedance_matrix(prob: Problem, freq_hz: float, rows: np.ndarray | None = None, block: int = 96) -> np.ndarray:
    """The Galerkin EFIE matrix (ohm) at one frequency: all N x N, or only the ``rows``
    (testing functions) given, against every basis function. One piece: the block loop shares
    its gathered moments between the vector and scalar parts (split, each block is gathered twice).

    With f_n = c (r - v) on each of its triangles, (r - va).(r' - vb) expands into the pair
    moments, and Z = C1 X1 + Cx X2 + Cy X3 where the X are [T, N] products of the moment
    matrices with the coefficients: each basis has two triangles, so every product is two
    column (or row) gathers, not a matrix product. Only the triangles of ``rows`` are
    observation triangles, so a quarter of the rows costs a quarter of the fill."""
    mesh, k = prob.mesh, 2 * np.pi * freq_hz / C0
    omega = 2 * np.pi * freq_hz
    c_a = 1j * omega * MU0 / (4 * np.pi)
    c_phi = -1j / (4 * np.pi * omega * EPS0)
    t = len(mesh.tris)
    rwg = prob.rwg
    rows = np.arange(prob.n) if rows is None else np.asarray(rows)
    tri = (rwg.plus, rwg.minus)
    needed = np.unique(np.concatenate([rwg.plus[rows], rwg.minus[rows]]))
    slot = -np.ones(t, int)
    slot[needed] = np.arange(len(needed))
    q3 = _points(mesh, _Q3)
    zt = mesh.nodes[mesh.tris[:, 0], 2]
    area = mesh.areas
    coef = [sgn * rwg.length / (2 * area[tr]) for sgn, tr in ((1.0, rwg.plus), (-1.0, rwg.minus))]
    free = [mesh.nodes[mesh.tris[tr, fr], :2] for tr, fr in ((rwg.plus, rwg.plus_free), (rwg.minus, rwg.minus_free))]
    weights, kernels = prob.image_weights(freq_hz), prob.reflected_kernels(freq_hz)
    pairs, corr, corr_q = _near_corrections(prob, k, slot >= 0, weights, kernels)
    order = np.argsort(slot[pairs[:, 0]], kind="stable")
    pairs, corr, corr_q = pairs[order], corr[:, order], corr_q[order]
    bounds = np.searchsorted(slot[pairs[:, 0]], np.arange(0, len(needed) + block, block))
    x1 = np.empty((len(needed), prob.n), dtype=complex)
    x2 = np.empty_like(x1)
    x3 = np.empty_like(x1)

    def right(m: np.ndarray, weight: int | None = None) -> np.ndarray:
        """m @ C^T for C = C1 (weight None) or Cx/Cy (weight 0/1): two column gathers."""
        out = 0
        for s in (0, 1):
            c = coef[s] if weight is None else coef[s] * free[s][:, weight]
            out = out + m[:, tri[s]] * c
        return out

    for b, start in enumerate(range(0, len(needed), block)):
        sel = needed[start:start + block]
        obs = (q3[0][sel], q3[1][sel])
        mo, s0_q = _block_moments(obs[0][:, None], obs[1][:, None], q3[0][None], q3[1][None], zt[None], k,
                                  weights, kernels)
        lo, hi = bounds[b], bounds[b + 1]
        at = (slot[pairs[lo:hi, 0]] - start, pairs[lo:hi, 1])
        for i in range(6):  # near pairs: the accurate values replace the 3-point ones
            np.add.at(mo[i], at, corr[i, lo:hi])
        np.add.at(s0_q, at, corr_q[lo:hi])
        s0, sx, sy, srr, sxs, sys_ = mo
        out = slice(start, start + len(sel))
        x1[out] = c_a * (right(srr) - right(sx, 0) - right(sy, 1)) + 4.0 * c_phi * right(s0_q)  # div f = 2c
        x2[out] = c_a * (right(s0, 0) - right(sxs))
        x3[out] = c_a * (right(s0, 1) - right(sys_))
    z = np.zeros((len(rows), prob.n), dtype=complex)
    for s in (0, 1):
        c = coef[s][rows, None]
        at = slot[tri[s][rows]]
        z += c * x1[at] + (c * free[s][rows, 0:1]) * x2[at] + (c * free[s][rows, 1:2]) * x3[at]
    return z


@dataclass
class MirrorSymmetry:
    """The x-directed feed's symmetry class on a mesh symmetric about x = 0 and y = 0.

    Mirroring the structure maps each RWG function to +-1 times another; a current driven
    along x is odd under x -> -x (as a vector field: the mirror image of +x current is -x
    current) and even under y -> -y. Such currents are J = U a with one unknown per orbit
    of basis functions; the Galerkin system reduces exactly to Z[reps] U a = V[reps]
    (Z commutes with the mirrors), a quarter of the rows to fill and 1/64 of the LU."""

    reps: np.ndarray  # one representative basis per orbit that survives
    u: sp.csr_matrix  # N x n_reps: the symmetric-class function of each orbit

    @classmethod
    def of(cls, mesh: TriMesh, rwg: Rwg) -> "MirrorSymmetry | None":
        """The reduction, or None when the mesh is not symmetric about both axes."""
        key = {tuple(k): i for i, k in enumerate(np.round(mesh.nodes, 9))}
        edge_of = {tuple(e): i for i, e in enumerate(rwg.edges)}
        tri_of = {tuple(sorted(t)): i for i, t in enumerate(mesh.tris)}
        images = []
        for m in (np.array([-1.0, 1.0, 1.0]), np.array([1.0, -1.0, 1.0])):
            node = [key.get(tuple(k)) for k in np.round(mesh.nodes * m, 9)]
            if any(i is None for i in node):
                return None
            node = np.asarray(node)
            img = [edge_of.get(tuple(sorted(node[e]))) for e in rwg.edges]
            if any(i is None for i in img):
                return None
            img = np.asarray(img)
            plus_img = np.array([tri_of.get(tuple(sorted(node[mesh.tris[p]])), -1) for p in rwg.plus])
            sign = np.where(plus_img == rwg.plus[img], 1.0, -1.0)
            images.append((img, sign))
        (ix, sx), (iy, sy) = images
        group = [(np.arange(rwg.n), np.ones(rwg.n), 1.0), (ix, sx, -1.0), (iy, sy, 1.0),
                 (ix[iy], sy * sx[iy], -1.0)]  # identity, x -> -x, y -> -y, both; with the class characters
        seen = np.zeros(rwg.n, bool)
        reps, rows, cols, vals = [], [], [], []
        for n in range(rwg.n):
            if seen[n]:
                continue
            coeff: dict[int, float] = {}
            for idx, sgn, chi in group:
                seen[idx[n]] = True
                coeff[int(idx[n])] = coeff.get(int(idx[n]), 0.0) + chi * sgn[n]
            coeff = {i: c for i, c in coeff.items() if abs(c) > 1e-9}
            if not coeff:
                continue  # this orbit carries no current of the driven class
            o = len(reps)
            reps.append(n)
            for i, c in coeff.items():
                rows.append(i)
                cols.append(o)
                vals.append(c)
        u = sp.csr_matrix((vals, (rows, cols)), shape=(rwg.n, len(reps)))
        return cls(np.asarray(reps), u)


@dataclass
class Solution:
    """Basis currents (A/m across each edge) at one frequency, the input current and power."""

    freq_hz: float
    currents: np.ndarray
    input_current: complex
    volts: float

    @property
    def input_impedance(self) -> complex:
        return self.volts / self.input_current

    @property
    def input_power(self) -> float:
        return 0.5 * float(np.real(self.volts * np.conj(self.input_current)))


def feed_signs(prob: Problem, direction: tuple[float, float] = (1.0, 0.0)) -> np.ndarray:
    """+-1 per feed edge so every driven edge pushes current along ``direction`` (the
    basis runs from its plus to its minus triangle; edge orientation is arbitrary)."""
    cen = prob.mesh.centroids[:, :2]
    run = cen[prob.rwg.minus[prob.rwg.feed]] - cen[prob.rwg.plus[prob.rwg.feed]]
    return np.where(run @ np.asarray(direction) >= 0, 1.0, -1.0)


def solve(prob: Problem, freq_hz: float, symmetry: MirrorSymmetry | None = None) -> Solution:
    """Currents for a 1 V delta gap across the feed edges (in parallel); with ``symmetry``
    the reduced system of the driven symmetry class (the same currents, ~4x less fill)."""
    import scipy.linalg

    if len(prob.rwg.feed) == 0:
        raise ValueError("surface engine: the mesh has no feed edges")
    sign = feed_signs(prob)
    v = np.zeros(prob.n, dtype=complex)
    v[prob.rwg.feed] = sign * prob.rwg.length[prob.rwg.feed] * prob.mesh.feed_volts
    if symmetry is None:
        z = impedance_matrix(prob, freq_hz)
        i = scipy.linalg.solve(z, v, overwrite_a=True, check_finite=False)
    else:
        zr = np.asarray((symmetry.u.T @ impedance_matrix(prob, freq_hz, symmetry.reps).T).T)
        a = scipy.linalg.solve(zr, v[symmetry.reps], overwrite_a=True, check_finite=False)
        i = symmetry.u @ a
    i_in = complex(np.sum(sign * prob.rwg.length[prob.rwg.feed] * i[prob.rwg.feed]))
    return Solution(freq_hz, i, i_in, prob.mesh.feed_volts)


def gain_pattern(prob: Problem, sol: Solution, theta_deg: np.ndarray, phi_deg: np.ndarray,
                 mirrored_currents: bool = False) -> np.ndarray:
    """Linear power gain G(theta, phi) = 4 pi U / P_in on the grid (theta rows, phi columns).

    ``mirrored_currents``: the currents are in the x-driven mirror class (solved with
    :class:`MirrorSymmetry`: J_x even and J_y odd in both x and y), so the four images of a
    first-quadrant point sum to 4 J_x cos(k x s_x) cos(k y s_y) and -4 J_y sin(k x s_x)
    sin(k y s_y): the same far field from a quarter of the points and half the exponentials."""
    mesh, k = prob.mesh, 2 * np.pi * sol.freq_hz / C0
    pts, w = _points(mesh, _Q7)
    alpha = prob.c1.T @ sol.currents  # J = alpha rho + beta on each triangle
    beta = np.stack([-(prob.cv[0].T @ sol.currents), -(prob.cv[1].T @ sol.currents)], axis=-1)
    jw = (alpha[:, None, None] * pts[..., :2] + beta[:, None, :]) * w[..., None]  # [T, Q, 2]
    jw = jw.reshape(-1, 2)
    p = pts.reshape(-1, 3)
    if mirrored_currents:
        first = (p[:, 0] > 0) & (p[:, 1] > 0)  # every triangle lies in one quadrant (meshes are mirrored)
        p, jw = p[first], jw[first]
    from ._compiled import current_moments

    levels, level = np.unique(np.round(p[:, 2], 9), return_inverse=True)  # flat metal: a few heights
    th, ph = np.meshgrid(np.radians(theta_deg), np.radians(phi_deg), indexing="ij")
    th, ph = th.ravel(), ph.ravel()
    # exp(jk s.r) = exp(jk (x sx + y sy)) exp(jk z cz): one horizontal moment per metal level
    moment = current_moments(p, np.ascontiguousarray(jw), level.astype(np.int64), len(levels), k,
                             np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), mirrored_currents)
    up = np.exp(1j * k * np.outer(np.cos(th), levels))  # [D, n_levels]
    direct = np.einsum("dl,dlc->dc", up, moment)
    mirrored = np.einsum("dl,dlc->dc", up.conj(), moment) if prob.ground != "free" else np.zeros_like(direct)
    # theta and phi parts of the horizontal current moment; the image reflects them by R_v, R_h
    if prob.ground == "soil":
        r_v, r_h = fresnel(np.cos(th), soil_permittivity(*prob.soil, sol.freq_hz))
        r_v, r_h = r_v[:, None], r_h[:, None]
    else:
        r_v, r_h = (1.0, -1.0) if prob.ground == "pec" else (0.0, 0.0)
    along = direct - r_v * mirrored
    across = direct + r_h * mirrored
    nth = np.cos(th) * (along[:, 0] * np.cos(ph) + along[:, 1] * np.sin(ph))
    nph = -across[:, 0] * np.sin(ph) + across[:, 1] * np.cos(ph)
    u = k ** 2 * ETA0 * (np.abs(nth) ** 2 + np.abs(nph) ** 2) / (32 * np.pi ** 2)
    return (4 * np.pi * u / sol.input_power).reshape(len(theta_deg), len(phi_deg))
