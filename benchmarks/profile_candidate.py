"""Where one search candidate's time goes: a design solved on the five soils of the ``soil``
scenario set at the search level, in this process (``workers=0``, so cProfile sees every call),
the beam cache cold, the Sommerfeld tables cold (``--warm-tables``: a first solve fills them,
as a search's first design does, and the profile is of a second; ``--cold-model`` then drops the
design's model too, so the profile sees its build as a search's every new candidate pays it). One BLAS thread, as in a search's
workers: two OpenBLAS threads beside other work spin, and had made SuperLU look like 84 % of a
candidate (2026-12-02) when on one thread it is a few per cent.

    .venv/bin/python benchmarks/profile_candidate.py [--design sawtooth-20-16] [--mesh 0.7]
        [--freqs 55:97:3] [--warm-tables [--cold-model]] [--top 30] [-o results/bench/profile_candidate.txt]

Prints the wall time, the share of each phase (the functions named in PHASES, cumulative) and
the top functions by own time. Never fails on a time.
"""
from __future__ import annotations

import argparse
import cProfile
import io
import os
import pstats
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOILS = [(3.5, 0.02), (2.5, 0.005), (2.5, 0.05), (5.0, 0.005), (5.0, 0.05)]
# phase -> (file name, function name): the cumulative time of each, summed over the ones named
PHASES = {
    "design model (basis, grid, near lists, stencils)": (("pfft.py", "fast_model"),),
    "near series (the design's near moments in k)": (("pfft.py", "__init__@NearSeries"),),
    "near matrices' sparsity (StaticAssembly)": (("pfft.py", "__init__@StaticAssembly"),),
    "Sommerfeld tables (every soil, one J0 matrix)": (("operators.py", "reflected_kernels_many"),),
    "soil-independent terms of a frequency": (("pfft.py", "frequency_terms"),),
    "a soil's operator (reflected tables, moments, CSR)": (("pfft.py", "__init__@FastOperator"),),
    "near-matrix LU (preconditioner)": (("linsolve.py", "splu"),),
    # one name per function: "_isolve" and "iterative.py" both named scipy's gmres and counted it twice
    # (the profiles committed before 2026-12-03 evening read GMRES 45 % where it was 22 %)
    "GMRES": (("_isolve/iterative.py", "gmres"),),
    "far field": (("farfield.py", "gain_pattern"),),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--design", default="sawtooth-20-16")
    ap.add_argument("--mesh", type=float, default=0.7)
    ap.add_argument("--freqs", default="55:97:3")
    ap.add_argument("--warm-tables", action="store_true")
    ap.add_argument("--cold-model", action="store_true",
                    help="with --warm-tables: build the design's model again in the profiled run")
    ap.add_argument("--soils", type=int, default=5, choices=range(1, 6),
                    help="the first N soils of the set (1: MRO alone, the one-soil solve of bench_surface.py)")
    ap.add_argument("--top", type=int, default=30)
    ap.add_argument("-o", "--out")
    ap.add_argument("--stats", help="also write cProfile's raw statistics here (for pstats: callers, callees)")
    args = ap.parse_args()
    os.environ["GROUNDPLANE_CACHE"] = tempfile.mkdtemp(prefix="gp-profile-")
    sys.path.insert(0, str(ROOT))
    from groundplane.design import Design, Soil
    from groundplane.options import parse_freqs
    from groundplane.shapes import PRESETS, from_file
    from solvers.engines.surface import SurfaceSettings, SurfaceSolver

    plane = from_file(args.design) if args.design.endswith(".json") else PRESETS[args.design]
    freqs = parse_freqs(args.freqs)
    designs = [Design(plane, Soil(*s)) for s in SOILS[:args.soils]]

    def solver():
        return SurfaceSolver(SurfaceSettings(spacing=args.mesh), workers=0, use_cache=False)

    if args.warm_tables:
        solver().solve_many(designs, freqs[:1])  # the tables of the first frequency's soils land on disk
        if args.cold_model:
            from solvers.engines.surface import pfft

            pfft._CACHE.clear()  # the design's model (basis, grid, series, sparsity) is built again, as per candidate
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)  # as the solver's worker processes do
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    solver().solve_many(designs, freqs)
    prof.disable()
    wall = time.perf_counter() - t0
    if args.stats:
        prof.dump_stats(args.stats)
    stats = pstats.Stats(prof)
    lines = [f"{args.design} at {args.mesh:g} m, {len(freqs)} frequencies ({args.freqs}), {args.soils} soil(s) together, one "
             f"process, beam cache cold, Sommerfeld tables {'warm' if args.warm_tables else 'cold'}, "
             f"design model {'warm' if args.warm_tables and not args.cold_model else 'cold'}: {wall:.1f} s",
             "", "phase (cumulative, the outermost call of the functions named):"]
    inits = {c: _line_of("solvers.engines.surface.pfft", c) for c in ("FastOperator", "NearSeries", "StaticAssembly")}
    for phase, names in PHASES.items():
        t = 0.0
        for file, name in names:
            for (f, line, fn), (cc, nc, tt, ct, callers) in stats.stats.items():
                if name.startswith("__init__@"):
                    hit = f.endswith(file) and fn == "__init__" and line == inits[name.split("@")[1]]
                else:
                    hit = file in f and fn == name
                t += ct if hit else 0.0
        lines.append(f"  {phase:54s} {t:8.1f} s  {100 * t / wall:5.1f} %")
    buf = io.StringIO()
    pstats.Stats(prof, stream=buf).sort_stats("tottime").print_stats(args.top)
    lines += ["", "top functions by own time:", buf.getvalue()]
    text = "\n".join(lines)
    print(text)
    if args.out:
        Path(args.out).write_text(text)


def _line_of(module: str, cls: str) -> int:
    """The first line of ``cls.__init__`` in ``module`` (cProfile names methods by line)."""
    import importlib

    return getattr(importlib.import_module(module), cls).__init__.__code__.co_firstlineno


if __name__ == "__main__":
    main()
