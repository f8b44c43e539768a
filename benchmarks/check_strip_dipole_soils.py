"""The surface engine against NEC-2's Sommerfeld ground on a strip dipole over each soil of the
``soil`` scenario set: input impedance and the E/H-plane gain, at 2 / 5 / 50 cm above the soil and
55 / 75 / 97 MHz. The element-level check behind the dry-corner reading of
``results/engine_dry/README.md``: do the two engines agree on the soil itself, where their plates
part? (The test suite checks MRO and one dry case; this prints the whole table.)

    .venv/bin/python benchmarks/check_strip_dipole_soils.py [-o results/engine_dry/strip_dipole_soils.txt]

NEC runs in its own spawned process (it cannot share one with numba/healpy). Never fails.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "tests" / "solvers" / "engines" / "surface"))
SOILS = [(3.5, 0.02), (2.5, 0.005), (2.5, 0.05), (5.0, 0.005), (5.0, 0.05)]
HEIGHTS = (0.5, 0.05, 0.02)
FREQS = (55.0, 75.0, 97.0)


def nec_cases(cases: list) -> list:
    """Every case's NEC-2 impedance and gain (run in the engine's process)."""
    import PyNEC  # noqa: F401  (first: its library needs static TLS that the test module's imports would take)
    from test_rwg import STRIP_WIDTH, _nec_dipole_over

    return [_nec_dipole_over(h, STRIP_WIDTH / 4, "soil", soil, f) for soil, h, f in cases]


def main() -> None:
    from bench_surface import print_and_write
    from test_rwg import STRIP_LENGTH, STRIP_WIDTH

    from solvers.engines.nec.engine import engine_call
    from solvers.engines.surface.dense import solve
    from solvers.engines.surface.farfield import gain_pattern
    from solvers.engines.surface.grid import TriMesh
    from solvers.engines.surface.mesh import strip_dipole_mesh
    from solvers.engines.surface.operators import Problem
    from solvers.engines.surface.space import rwg_basis

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--out")
    args = ap.parse_args()
    cases = [(s, h, f) for s in SOILS for h in HEIGHTS for f in FREQS]
    nec = engine_call(nec_cases, cases)
    lines = [f"strip dipole {STRIP_LENGTH} m x {STRIP_WIDTH * 100:g} cm (NEC: a wire of radius width/4), dense surface "
             "solve vs NEC-2 Sommerfeld ground; gain every 3 deg from zenith in the E and H planes", "",
             "| soil (eps_r, sigma) | height (m) | MHz | Z surface (ohm) | Z NEC-2 (ohm) | largest gain difference / peak |",
             "|---|---|---|---|---|---|"]
    worst = {}
    for (soil, h, f), (z_nec, g_nec) in zip(cases, nec):
        strip = strip_dipole_mesh(STRIP_LENGTH, STRIP_WIDTH, 80)
        mesh = TriMesh(strip.nodes + np.array([0.0, 0.0, h]), strip.tris, strip.feed_edges)
        prob = Problem(mesh, rwg_basis(mesh), "soil", soil=soil)
        sol = solve(prob, f * 1e6)
        g = gain_pattern(prob, sol, np.arange(0.0, 91.0, 3.0), np.array([0.0, 90.0]))
        d = float(np.abs(g - g_nec).max() / g_nec.max())
        worst[soil] = max(worst.get(soil, 0.0), d)
        z = sol.input_impedance
        lines.append(f"| {soil[0]:g}, {soil[1]:g} | {h:g} | {f:g} | {z.real:.1f} {z.imag:+.1f}j | "
                     f"{z_nec.real:.1f} {z_nec.imag:+.1f}j | {d:.4f} |")
    lines += ["", "largest gain difference / peak per soil: "
              + "; ".join(f"{s[0]:g}/{s[1]:g}: {v:.4f}" for s, v in worst.items())]
    print_and_write("\n".join(lines), args.out)


if __name__ == "__main__":
    main()
