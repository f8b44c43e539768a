"""The surface engine's Sommerfeld reflected kernels against empymod (layered-earth EM,
Apache-2.0), an independent code: its recursive reflection coefficients (Hunziker et al. 2015,
eqs 64-65), integrated by scipy's adaptive quadrature along a contour off the real axis, against
the engine's real-axis rule (``halfspace.reflected_integrals``), over what the engine uses: the
plate, plate-blade and blade-blade height sums, 1 cm to 60 m apart, 40-100 MHz, the five soils of
the ``soil`` set. Bound (docs/surface-engine.md): 1e-4 of max(1, |S|) per kernel.

empymod's own Hankel transforms are not used: for lossless air in the wave regime (k rho ~ 1-100)
they did not converge (its wavenumber-domain free-space field 30-60 % off its own closed form, the
reflected field over a near-perfect conductor 7-100 % off the image's; docs/surface-engine.md)."""
import numpy as np
import pytest

empymod_kernel = pytest.importorskip("empymod.kernel")

from optimise.scenarios import SOIL_CORNERS  # noqa: E402
from solvers.engines.surface.halfspace import C0, EPS0, MU0, reflected_integrals, reflection, soil_permittivity  # noqa: E402

SOILS = (*SOIL_CORNERS, (3.5, 0.02))  # the soil set: its four corners and MRO
PLATE, BLADE = 0.005, 1.04  # the sheet's and the blade's heights (m)
ZETAS = {"plate-plate": 2 * PLATE, "plate-blade": PLATE + BLADE, "blade-blade": 2 * BLADE}


def empymod_reflections(kr: np.ndarray, freq_hz: float, soil: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """(R_TE, R_TM) seen from the air over the soil, by empymod's recursive reflection routine
    (air over soil; depth convention z down, the interface at 0)."""
    w = 2 * np.pi * freq_hz
    eta = np.array([[1j * w * EPS0, soil[1] + 1j * w * EPS0 * soil[0]]])  # sigma + i w eps per layer
    zeta = np.array([[1j * w * MU0, 1j * w * MU0]])
    kr = np.atleast_1d(np.asarray(kr, complex))
    gam = np.sqrt(kr[None, None, None, :] ** 2 + (zeta * eta)[:, None, :, None])  # Gamma = i kz on Re >= 0
    depth = np.array([-np.inf, 0.0])
    rte, _ = empymod_kernel.reflections(depth, zeta, gam, 0, 0)
    rtm, _ = empymod_kernel.reflections(depth, eta, gam, 0, 0)
    return rte[0, 0, 0], rtm[0, 0, 0]


def empymod_kernels(kr, freq_hz, soil) -> tuple[np.ndarray, np.ndarray]:
    """The engine's two spectral factors from empymod's coefficients: R_TE, and the scalar
    potential's R_q = (k0^2 R_TE + kz0^2 R_TM) / krho^2 (Michalski & Zheng's formulation C)."""
    k0 = 2 * np.pi * freq_hz / C0
    kr = np.atleast_1d(np.asarray(kr, complex))
    rte, rtm = empymod_reflections(kr, freq_hz, soil)
    kz0 = np.sqrt(k0 ** 2 - kr ** 2)
    kz0 = np.where(kz0.imag > 0, -kz0, kz0)
    return rte, (k0 ** 2 * rte + kz0 ** 2 * rtm) / kr ** 2


def test_empymod_reflection_coefficients_are_the_engines():
    for freq in (40e6, 70e6, 100e6):
        k0 = 2 * np.pi * freq / C0
        kr = np.concatenate([np.linspace(0.01, 0.99, 40) * k0, np.linspace(1.01, 60, 200) * k0])
        for soil in SOILS:
            a, q = empymod_kernels(kr, freq, soil)
            b, r = reflection(kr, k0, soil_permittivity(*soil, freq))
            assert np.abs(a - b).max() < 1e-9 and np.abs(q - r).max() < 1e-9  # empymod loses digits near k0


def _sommerfeld(rho: float, zeta: float, freq_hz: float, soil) -> tuple[complex, complex]:
    """S(R_TE), S(R_q - K_q) from empymod's coefficients, by the adaptive contour quadrature of
    test_rwg (a semi-ellipse into the first quadrant, clear of both branch points, then the real axis)."""
    from .test_rwg import _contour_reference

    k0 = 2 * np.pi * freq_hz / C0
    return _contour_reference(rho, zeta, k0, soil_permittivity(*soil, freq_hz),
                              spectral=lambda kr: empymod_kernels(kr, freq_hz, soil))


# (height sum, distances): the plate's own interactions to 20 m (beyond it the adaptive reference
# does not resolve J0 over the 6000 /m its 1 cm height sum needs), the blade's to 60 m
CASES = [(ZETAS["plate-plate"], (0.01, 0.3, 3.0, 20.0)),
         (ZETAS["plate-blade"], (0.01, 1.0, 10.0, 60.0)),
         (ZETAS["blade-blade"], (0.01, 1.0, 10.0, 60.0))]


@pytest.mark.parametrize("freq", [40e6, 70e6, 100e6])
@pytest.mark.parametrize("soil", SOILS)
def test_reflected_kernels_against_empymod(freq, soil):
    k0 = 2 * np.pi * freq / C0
    eps = soil_permittivity(*soil, freq)
    for zeta, rhos in CASES:
        a, q = reflected_integrals(np.array(rhos), k0, eps, zeta, rho_max=60.0)
        for i, rho in enumerate(rhos):
            ref_a, ref_q = _sommerfeld(rho, zeta, freq, soil)
            assert abs(a[i] - ref_a) < 1e-4 * max(1.0, abs(ref_a)), (rho, zeta, a[i], ref_a)
            assert abs(q[i] - ref_q) < 1e-4 * max(1.0, abs(ref_q)), (rho, zeta, q[i], ref_q)


if __name__ == "__main__":  # the worst errors over every case (docs/fdtd.md): python -m tests.solvers...test_kernels_empymod
    worst: dict[str, tuple] = {}
    for freq in (40e6, 70e6, 100e6):
        for soil in SOILS:
            k0, eps = 2 * np.pi * freq / C0, soil_permittivity(*soil, freq)
            for zeta, rhos in CASES:
                got = reflected_integrals(np.array(rhos), k0, eps, zeta, rho_max=60.0)
                for i, rho in enumerate(rhos):
                    for name, value, ref in zip(("S(R_TE)", "S(R_q - K_q)"), (g[i] for g in got),
                                                _sommerfeld(rho, zeta, freq, soil)):
                        err = abs(value - ref) / max(1.0, abs(ref))
                        if err > worst.get(name, (0.0,))[0]:
                            worst[name] = (err, freq / 1e6, soil, zeta, rho)
    for name, (err, f, soil, zeta, rho) in worst.items():
        print(f"{name}: worst {err:.2e} of max(1, |S|) at {f:g} MHz, soil {soil}, height sum {zeta:g} m, {rho:g} m apart")
