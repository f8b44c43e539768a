"""Would numba's ``fastmath`` pay for the fast solve's compiled loops
(``solvers/engines/surface/_compiled.py``)? Both variants are recompiled here from the loops' Python
source and run in this one process: one design on the five soils of the
``soil`` set, in-process (``workers=0``), the beam cache off, the Sommerfeld tables of every soil
and frequency filled before either clock starts (the first run had paid for them: 1.64x baseline
first, 1.02x the other way round); ``--fastmath-first`` swaps the order, to see it does not matter.

    .venv/bin/python benchmarks/bench_fastmath.py [--design sawtooth-20-16] [--mesh 0.7]
        [--freqs 55:97:4] [--fastmath-first] [-o results/bench/bench_fastmath.txt]

Prints both wall times and their ratio, the largest rms gain difference above 10 deg elevation and
each soil's FoM both ways (every 1 deg of LST and in 2 h bins). Never fails on a time.

Measured (``results/bench/bench_fastmath.txt``, 2026-12-03, beside a running search): 1.03x on the
whole candidate (1.02x the other way round), though a loop alone looked 1.6-2x in separate processes
under the same load; the package keeps its loops without fastmath (its complex products would lose
their NaN/inf handling for 3 %).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
SOILS = [(3.5, 0.02), (2.5, 0.005), (2.5, 0.05), (5.0, 0.005), (5.0, 0.05)]
LOOPS = ("_add_moments", "rule_moments", "reflected_rule_moments", "grid_pair_moments", "scatter_values")


def compiled(fastmath: bool) -> None:
    """Put the loops into ``_compiled``'s namespace compiled with or without fastmath (the helper
    first: numba binds a callee when its caller compiles)."""
    from solvers.engines.surface import _compiled

    for name in LOOPS:
        f = getattr(_compiled, name)
        setattr(_compiled, name, numba.njit(nogil=True, fastmath=fastmath)(getattr(f, "py_func", f)))


def run(plane, mesh: float, freqs, fastmath: bool):
    from groundplane.design import Design, Soil
    from solvers.engines.surface import SurfaceSettings, SurfaceSolver

    compiled(fastmath)
    solver = SurfaceSolver(SurfaceSettings(spacing=mesh), workers=0, use_cache=False)
    solver.solve_many([Design(plane, Soil(*SOILS[0]))], freqs[:1])  # compile outside the clock
    t0 = time.perf_counter()
    beams = solver.solve_many([Design(plane, Soil(*s)) for s in SOILS], freqs)
    return time.perf_counter() - t0, beams


def fill_tables(plane, mesh: float, freqs) -> None:
    """The soils' Sommerfeld tables at every frequency (kept in memory and on disk), built here."""
    from groundplane.design import Design, Soil
    from solvers.engines.surface import SurfaceSettings, pfft
    from solvers.engines.surface.mesh import build_mesh

    settings = SurfaceSettings(spacing=mesh)
    prob = pfft.problem_of(build_mesh(Design(plane, Soil(*SOILS[0])), settings), "soil", settings.near_factor,
                           SOILS[0])
    reach = pfft.FAR_REACH_CELLS * pfft.grid_spacing(prob)
    for f in freqs:
        prob.reflected_kernels_many(f * 1e6, SOILS, reach)


def main() -> None:
    from bench_surface import foms, print_and_write, rms_db

    from groundplane.options import parse_freqs
    from groundplane.shapes import PRESETS, from_file

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--design", default="sawtooth-20-16")
    ap.add_argument("--mesh", type=float, default=0.7)
    ap.add_argument("--freqs", default="55:97:4")  # >= 10 in the fit band: the FoM needs them
    ap.add_argument("--fastmath-first", action="store_true")
    ap.add_argument("-o", "--out")
    args = ap.parse_args()
    plane = from_file(args.design) if args.design.endswith(".json") else PRESETS[args.design]
    freqs = parse_freqs(args.freqs)
    fill_tables(plane, args.mesh, freqs)
    runs = {}
    for fastmath in ((True, False) if args.fastmath_first else (False, True)):
        runs[fastmath] = run(plane, args.mesh, freqs, fastmath=fastmath)
        print(f"{'fastmath' if fastmath else 'baseline (compiled loops without fastmath)'}: {runs[fastmath][0]:.1f} s",
              flush=True)
    (t_base, base), (t_fast, fast) = runs[False], runs[True]
    order = "fastmath first" if args.fastmath_first else "baseline first"
    lines = [f"{args.design} at {args.mesh:g} m, {len(freqs)} frequencies ({args.freqs}), the 5 soils, one process, "
             f"{order}:",
             f"  baseline (loops without fastmath): {t_base:.1f} s; fastmath: {t_fast:.1f} s (**{t_base / t_fast:.2f}x**)",
             "", "| soil (eps_r, sigma) | largest rms dB above 10 deg | FoM every 1 deg base / fastmath (mK) | "
             "FoM 2 h base / fastmath (mK) |", "|---|---|---|---|"]
    for s, a, b in zip(SOILS, base, fast):
        fa, fb = foms(a), foms(b)
        lines.append(f"| {s[0]:g}, {s[1]:g} | {np.max(rms_db(a, b)):.1e} | {fa[0]:.4f} / {fb[0]:.4f} | "
                     f"{fa[1]:.4f} / {fb[1]:.4f} |")
    text = "\n".join(lines)
    print_and_write(text, args.out)


if __name__ == "__main__":
    main()
