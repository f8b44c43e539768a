"""Surface engine: the fast solve (precorrected FFT + GMRES) against the dense reference, in
one process, on the same designs and frequencies.

    .venv/bin/python benchmarks/bench_surface.py [--cases square-10@0.5 sawtooth-20-16@0.5]
        [--freqs 55:97:2] [--workers 2] [--json out.json]

Each case (a preset at a mesh spacing, the sheet 5 mm above MRO soil) is solved through the
engine (``SurfaceSolver``, no cache) with ``--method dense`` (the baseline) and then with
``--method fast``. Printed per case: unknowns, the mean time per frequency of each (the fast
one's per-design set-up, paid once per worker process, is amortised over the frequencies and
also shown on its own), their ratio; the largest over frequencies of the rms gain difference
above 10 deg elevation; and the FoM of each (every LST, and in the paper's 2 h LST bins) with
their difference. Never fails on a time; the machine is noisy, so read the ratio.
"""
from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from groundplane.design import Design, Soil
from groundplane.fom import FomSettings, figure_of_merit
from groundplane.options import parse_freqs
from groundplane.shapes import PRESETS
from solvers.engines.surface import SurfaceSettings, SurfaceSolver


def solve(preset: str, spacing: float, method: str, freqs: np.ndarray, workers: int):
    settings = SurfaceSettings(spacing=spacing, method=method)
    t0 = time.perf_counter()
    beam = SurfaceSolver(settings, workers=workers, use_cache=False).solve(Design(PRESETS[preset], Soil()), freqs)
    return beam, time.perf_counter() - t0


def foms(beam) -> tuple[float, float]:
    res = figure_of_merit(beam, FomSettings(lst_bin_hours=0.0))
    return res.lst_averaged_fom_mk, res.in_lst_bins(2.0).lst_averaged_fom_mk


def run(case: str, freqs: np.ndarray, workers: int) -> dict:
    preset, spacing = case.split("@")
    dense, t_dense = solve(preset, float(spacing), "dense", freqs, workers)
    fast, t_fast = solve(preset, float(spacing), "fast", freqs, workers)
    up = fast.theta_deg <= 80.0  # above 10 deg elevation
    rms = np.sqrt(np.mean((10 * np.log10(fast.gain[:, up] / dense.gain[:, up])) ** 2, axis=(1, 2)))
    sec_d = np.asarray(dense.meta["seconds_per_frequency"])
    sec_f = np.asarray(fast.meta["seconds_per_frequency"])
    # a worker's first frequency builds the design's series, assembly and grid
    first = np.sort(sec_f)[-min(workers or 1, len(sec_f)):]
    (fd, fd2), (ff, ff2) = foms(dense), foms(fast)
    row = {"case": case, "unknowns": fast.meta["n_unknowns"], "freqs": len(freqs),
           "dense_s_per_freq": float(sec_d.mean()), "fast_s_per_freq": float(sec_f.mean()),
           "fast_first_s": float(first.mean()), "ratio": float(sec_d.mean() / sec_f.mean()),
           "wall_dense_s": t_dense, "wall_fast_s": t_fast,
           "gain_rms_db_max": float(rms.max()), "fom_dense_mk": fd, "fom_fast_mk": ff,
           "fom_2h_dense_mk": fd2, "fom_2h_fast_mk": ff2,
           "fom_diff_pct": 100 * (ff / fd - 1), "fom_2h_diff_pct": 100 * (ff2 / fd2 - 1),
           "gmres_iterations": [int(x) for x in fast.meta["gmres_iterations"]]}
    print(f"| {case} | {row['unknowns']} | {row['dense_s_per_freq']:.1f} | {row['fast_s_per_freq']:.1f} "
          f"(first {row['fast_first_s']:.1f}) | {row['ratio']:.1f}x | {row['gain_rms_db_max']:.1e} | "
          f"{fd:.1f} / {ff:.1f} ({row['fom_diff_pct']:+.2f} %) | {fd2:.1f} / {ff2:.1f} ({row['fom_2h_diff_pct']:+.2f} %) "
          f"| {min(row['gmres_iterations'])}-{max(row['gmres_iterations'])} |", flush=True)
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=["square-10@0.5", "sawtooth-20-16@0.5"])
    ap.add_argument("--freqs", type=parse_freqs, default=parse_freqs("55:97:2"))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", help="also write the rows here")
    args = ap.parse_args()
    freqs = np.asarray(args.freqs, float)
    print(f"{len(freqs)} frequencies {freqs[0]:g}-{freqs[-1]:g} MHz, {args.workers} worker process(es), "
          "sheet 5 mm above MRO soil; times per frequency in a worker (s)")
    print("| case | unknowns | dense (s) | fast (s) | dense / fast | gain rms diff (dB, max over f) | "
          "FoM dense / fast (mK) | FoM 2 h bins dense / fast (mK) | GMRES iterations |")
    print("|---|---|---|---|---|---|---|---|---|")
    rows = [run(c, freqs, args.workers) for c in args.cases]
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"argv": sys.argv, "rows": rows}, fh, indent=1)


if __name__ == "__main__":
    main()
