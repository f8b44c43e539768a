"""Surface-engine (RWG) solve speed: where the time per frequency goes, with and without
the mirror-symmetry reduction, on the blade over PEC, a plate above PEC and a plate on soil.

    .venv/bin/python benchmarks/bench_surface.py [--cases blade blade-24x20 square-10@0.5 square-10@0.5/soil] [--freq 75]

For each case, one frequency in this process with one BLAS thread: mesh and basis, the
full N x N fill, its LU solve and the far field (the baseline), then the reduced solve of
the driven symmetry class (what the engine does for designs symmetric about both axes).
Both run here one after the other and the ratio is printed; the currents of the two are
compared too (they must agree to rounding). Never fails on a time.
"""
from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy.linalg  # noqa: E402

from groundplane.design import Design, InfinitePEC, Soil  # noqa: E402
from groundplane.shapes import PRESETS  # noqa: E402
from solvers.engines.surface.mesh import SurfaceSettings, build_mesh  # noqa: E402
from solvers.engines.surface.rwg import (  # noqa: E402
    MirrorSymmetry,
    Problem,
    feed_signs,
    gain_pattern,
    impedance_matrix,
    rwg_basis,
    solve,
)


def case(name: str) -> tuple[Design, SurfaceSettings]:
    """'blade', 'blade-24x20' (panel cells), 'PRESET@SPACING' (a plate 5 cm above PEC) or
    'PRESET@SPACING/soil' (a sheet 5 mm above MRO soil)."""
    if name.startswith("blade"):
        cells = tuple(int(c) for c in name.split("-")[1].split("x")) if "-" in name else (12, 10)
        return Design(None, InfinitePEC()), SurfaceSettings(blade_cells=cells, plate_height=0.05)
    name, _, ground = name.partition("/")
    preset, spacing = name.split("@")
    if ground == "soil":
        return Design(PRESETS[preset], Soil()), SurfaceSettings(spacing=float(spacing), plate_height=0.005)
    return Design(PRESETS[preset], InfinitePEC()), SurfaceSettings(spacing=float(spacing), plate_height=0.05)


def run(name: str, freq_mhz: float) -> None:
    design, settings = case(name)
    t0 = time.perf_counter()
    mesh = build_mesh(design, settings)
    soil = (design.ground.eps_r, design.ground.sigma) if isinstance(design.ground, Soil) else None
    prob = Problem(mesh, rwg_basis(mesh), design.ground_kind, settings.near_factor, soil)
    sym = MirrorSymmetry.of(mesh, prob.rwg)
    t_mesh = time.perf_counter() - t0
    f = freq_mhz * 1e6
    t0 = time.perf_counter()
    z = impedance_matrix(prob, f)
    t_fill = time.perf_counter() - t0
    v = np.zeros(prob.n, complex)
    v[prob.rwg.feed] = feed_signs(prob) * prob.rwg.length[prob.rwg.feed]
    t0 = time.perf_counter()
    i_full = scipy.linalg.solve(z, v, check_finite=False)
    t_lu = time.perf_counter() - t0
    del z
    t0 = time.perf_counter()
    sol = solve(prob, f, sym)
    t_sym = time.perf_counter() - t0
    t0 = time.perf_counter()
    gain_pattern(prob, sol, np.arange(0.0, 91.0, 3.0), np.arange(0.0, 91.0, 3.0))
    t_ff = time.perf_counter() - t0
    diff = np.abs(sol.currents - i_full).max() / np.abs(i_full).max()
    full = t_fill + t_lu
    print(f"| {name} | {len(mesh.tris)} | {prob.n} | {len(sym.reps) if sym else '-'} | {t_mesh:.2f} | {t_fill:.1f} | "
          f"{t_lu:.1f} | {t_sym:.1f} ({full / t_sym:.1f}x) | {t_ff:.2f} | {diff:.0e} |", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=["blade", "blade-24x20", "square-10@0.5", "square-10@0.5/soil"])
    ap.add_argument("--freq", type=float, default=75.0)
    args = ap.parse_args()
    print(f"one frequency ({args.freq:g} MHz), one process, one BLAS thread")
    print("| case | triangles | unknowns | reduced unknowns | mesh (s) | full fill (s) | full LU (s) | "
          "reduced fill + LU (s, ratio) | far field (s) | current difference |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in args.cases:
        run(name, args.freq)


if __name__ == "__main__":
    main()
