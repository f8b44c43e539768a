"""GMRES started from the design's currents at the worker's previous frequency (the first soil of
each frequency; ``pfft.WARM_START_ACROSS_FREQUENCIES``) against starting it from zero, on the same
designs in this one process (``workers=0``, beam cache off, one BLAS thread). Order: one run from
zero that fills the Sommerfeld tables (its time printed, not compared), then ``--repeats`` pairs of
warm and from-zero runs; the ratio is the fastest from-zero run over the fastest warm one (a machine
shared with other work moves single runs by 20-30 %).

    .venv/bin/python benchmarks/bench_warm_frequencies.py [--designs square-10@1.0 CROSS.json@1.0]
        [--freqs 55:97:1] [-o results/bench/bench_warm_frequencies.txt]

Prints per design the wall times and their ratio, mean GMRES iterations, the largest rms gain
difference above 10 deg elevation over frequencies, and the FoM both ways (every 1 deg of LST and in
2 h bins). Never fails on a time.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))


def run(plane, mesh: float, freqs, warm: bool):
    from groundplane.design import Design, Soil
    from solvers.engines.surface import SurfaceSettings, SurfaceSolver, pfft

    pfft.WARM_START_ACROSS_FREQUENCIES = warm
    solver = SurfaceSolver(SurfaceSettings(spacing=mesh), workers=0, use_cache=False)
    t0 = time.perf_counter()
    beam = solver.solve(Design(plane, Soil()), freqs)
    return time.perf_counter() - t0, beam


def main() -> None:
    from bench_surface import foms, print_and_write, rms_db
    from threadpoolctl import threadpool_limits

    from groundplane.options import parse_freqs
    from groundplane.shapes import PRESETS, from_file

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", nargs="+", default=["square-10@1.0", "results/pareto/budget-200/best.json@1.0"])
    ap.add_argument("--freqs", default="55:97:1")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("-o", "--out")
    args = ap.parse_args()
    freqs = parse_freqs(args.freqs)
    lines = [f"{len(freqs)} frequencies ({args.freqs}), MRO soil, one process on one BLAS thread, beam cache off; "
             f"ratio = the fastest of {args.repeats} from-zero runs over the fastest of {args.repeats} warm ones, after a "
             "run that fills the Sommerfeld tables", "",
             "| design | table-filling run (s) | from zero (s) | warm from the previous frequency (s) | ratio | "
             "GMRES iterations zero / warm | largest rms dB above 10 deg | FoM 1 deg zero / warm (mK) | "
             "FoM 2 h zero / warm (mK) |", "|---|---|---|---|---|---|---|---|---|"]
    with threadpool_limits(1):
        for spec in args.designs:
            name, mesh = spec.rsplit("@", 1)
            plane = from_file(name) if name.endswith(".json") else PRESETS[name]
            t_fill, _ = run(plane, float(mesh), freqs, warm=False)
            t_warm, t_zero = [], []
            for _ in range(args.repeats):
                t, warm = run(plane, float(mesh), freqs, warm=True)
                t_warm.append(t)
                t, zero = run(plane, float(mesh), freqs, warm=False)
                t_zero.append(t)
            iz, iw = (np.asarray(b.meta["gmres_iterations"]).mean() for b in (zero, warm))
            fz, fw = foms(zero), foms(warm)
            lines.append(f"| {os.path.basename(name)} at {float(mesh):g} m | {t_fill:.1f} | "
                         f"{' / '.join(f'{t:.1f}' for t in t_zero)} | {' / '.join(f'{t:.1f}' for t in t_warm)} | "
                         f"**{min(t_zero) / min(t_warm):.2f}x** | {iz:.1f} / {iw:.1f} | {np.max(rms_db(zero, warm)):.1e} | "
                         f"{fz[0]:.3f} / {fw[0]:.3f} | {fz[1]:.3f} / {fw[1]:.3f} |")
            print(lines[-1], flush=True)
    print_and_write("\n".join(lines), args.out)


if __name__ == "__main__":
    main()
