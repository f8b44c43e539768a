"""Worker processes kept from one solve to the next (``workers.shared_pool``) against a pool spawned
for every solve (``workers.KEEP_POOL = False``: the engines' behaviour before 2026-12-04), on a
search's sequence of candidates in this one process: each candidate a new geometry (a square whose
side moves by a few cm, so nothing is cached) on the five soils of the `soil` set, solved together
(``solve_many``) on 2 workers, beam cache off. The two modes alternate candidate by candidate, so
a machine shared with other work loads both alike; the ratio is the mean time of a fresh-pool
candidate over a kept-pool one.

    .venv/bin/python benchmarks/bench_shared_pool.py [--candidates 6] [--mesh 1.0] [--freqs 55:97:3]
        [-o results/bench/bench_shared_pool.txt]

Also prints the largest rms gain difference (dB, above 10 deg elevation) between the two modes' beams
of the first candidate, solved both ways. Never fails on a time.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

SOILS = [(2.5, 0.005), (2.5, 0.05), (5.0, 0.005), (5.0, 0.05), (3.5, 0.02)]  # the `soil` set


def candidate(side: float, mesh: float, freqs, keep: bool):
    """(seconds, beams) of one square on the five soils, with the pool kept or spawned afresh."""
    from groundplane.design import Design, Soil
    from groundplane.shapes import Square
    from solvers.engines import workers
    from solvers.engines.surface import SurfaceSettings, SurfaceSolver

    workers.KEEP_POOL = keep
    solver = SurfaceSolver(SurfaceSettings(spacing=mesh), workers=2, use_cache=False, progress=False)
    designs = [Design(Square(side), Soil(eps_r=e, sigma=s)) for e, s in SOILS]
    t0 = time.perf_counter()
    beams = solver.solve_many(designs, freqs)
    return time.perf_counter() - t0, beams


def main() -> None:
    from bench_surface import print_and_write, rms_db

    from groundplane.options import parse_freqs
    from solvers.engines.workers import discard_shared_pool

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--candidates", type=int, default=6, help="candidates per mode")
    ap.add_argument("--mesh", type=float, default=1.0)
    ap.add_argument("--side", type=float, default=10.0, help="the first square's side (m)")
    ap.add_argument("--freqs", default="55:97:3")
    ap.add_argument("-o", "--out")
    args = ap.parse_args()
    freqs = parse_freqs(args.freqs)
    candidate(args.side - 1.0, args.mesh, freqs, True)  # numba's compiled loops and the Sommerfeld tables, once
    times: dict[bool, list[float]] = {False: [], True: []}
    first: dict[bool, list] = {}
    for i in range(args.candidates):
        for keep in ((False, True) if i % 2 == 0 else (True, False)):
            side = args.side + 0.03 * (2 * i + keep)  # every candidate its own geometry
            secs, beams = candidate(side if i else args.side, args.mesh, freqs, keep)
            times[keep].append(secs)
            if i == 0:
                first[keep] = beams
            print(f"candidate {i + 1} {'kept' if keep else 'fresh'} pool: {secs:.1f} s", file=sys.stderr)
    discard_shared_pool()
    fresh, kept = np.mean(times[False]), np.mean(times[True])
    drift = max(float(np.max(rms_db(a, b))) for a, b in zip(first[False], first[True]))
    lines = [f"square {args.side:g} m (+3 cm a candidate) at {args.mesh:g} m, five soils together, {len(freqs)} "
             f"frequencies ({args.freqs}), 2 workers, beam cache off; modes alternating, {args.candidates} each", "",
             "| pool | mean per candidate (s) | each (s) |", "|---|---|---|",
             f"| spawned for every solve | {fresh:.2f} | {' '.join(f'{t:.1f}' for t in times[False])} |",
             f"| kept from solve to solve | {kept:.2f} | {' '.join(f'{t:.1f}' for t in times[True])} |", "",
             f"ratio fresh / kept: {fresh / kept:.3f}x ({fresh - kept:+.2f} s a candidate)",
             f"largest rms gain difference between the modes' beams (first candidate, above 10 deg): {drift:.2e} dB"]
    print_and_write("\n".join(lines), args.out)


if __name__ == "__main__":
    main()
