"""NEC-2 solve speed: seconds per frequency vs number of segments (square-10 at several
mesh spacings, one frequency), and per-candidate estimates for square-10 and
sawtooth-20-16 at the default mesh. Baseline in the same process: the blade alone over
infinite PEC, so the printed ratios survive a noisy machine. Never fails on a time.

    .venv/bin/python benchmarks/bench_nec.py [--spacings 1.0 0.7 0.5] [--full]

--full solves all 61 frequencies of both candidates (minutes to tens of minutes).
--profile splits one frequency of sawtooth-20-16 at the default mesh into matrix fill + LU
and far field, with 1 and 2 OpenMP threads (is a thread worth a frequency process?).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

import numpy as np

from groundplane.design import Design, InfinitePEC, Soil
from groundplane.shapes import PRESETS
from solvers.engines.nec import NecSettings, NecSolver, build_model
from solvers.engines.nec.engine import context


def timed(design: Design, mesh: NecSettings, freqs, workers: int = 1) -> tuple[float, int]:
    t0 = time.perf_counter()
    NecSolver(mesh, workers=workers, progress=False, use_cache=False).solve(design, freqs)
    return time.perf_counter() - t0, build_model(design, mesh).n_segments


def profile_child() -> None:
    """One frequency in this process (no healpy here, so PyNEC may load): fill + LU, pattern."""
    model = build_model(Design(PRESETS["sawtooth-20-16"], Soil()), NecSettings())
    t0 = time.perf_counter()
    c = context(model, 75.0)
    c.xq_card(0)  # fill + LU + solve, no pattern
    t1 = time.perf_counter()
    c.rp_card(0, 91, 91, 0, 0, 0, 0, 0.0, 0.0, 1.0, 1.0, 0, 0)
    c.get_radiation_pattern(0).get_gain()
    t2 = time.perf_counter()
    print(f"{os.environ.get('OMP_NUM_THREADS')} thread(s), {model.n_segments} segments: fill + LU {t1 - t0:.1f} s, "
          f"far field phi 0-90 {t2 - t1:.1f} s")


def profile() -> None:
    for threads in ("1", "2"):
        env = {**os.environ, "OMP_NUM_THREADS": threads, "OPENBLAS_NUM_THREADS": threads}
        subprocess.run([sys.executable, __file__, "--profile-child"], env=env, check=True)


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--spacings", type=float, nargs="+", default=[1.0, 0.7, 0.5])
    p.add_argument("--full", action="store_true")
    p.add_argument("--profile", action="store_true")
    p.add_argument("--profile-child", action="store_true", help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.profile_child:
        return profile_child()
    if a.profile:
        return profile()
    base, nseg = timed(Design(None, InfinitePEC()), NecSettings(), [75.0])
    print(f"baseline: blade over PEC, {nseg} segments, 1 frequency, 1 process: {base:.2f} s (incl. process start)")
    print(f"{'candidate':>16} {'spacing':>8} {'segments':>9} {'s/freq':>8} {'x baseline':>10}")
    for sp in a.spacings:
        t, n = timed(Design(PRESETS["square-10"], Soil()), NecSettings(spacing=sp), [75.0])
        print(f"{'square-10':>16} {sp:8.2f} {n:9d} {t:8.2f} {t / base:10.1f}")
    for name in ("square-10", "sawtooth-20-16"):
        d = Design(PRESETS[name], Soil())
        if a.full:
            t, n = timed(d, NecSettings(), np.arange(40.0, 101.0), workers=2)
            print(f"{name}: 61 frequencies, 2 processes, {n} segments: {t / 60:.1f} min")
        else:
            t, n = timed(d, NecSettings(), [75.0])
            print(f"{name}: {n} segments, {t:.1f} s per frequency (1 process) -> ~{61 * t / 2 / 60:.1f} min "
                  f"for 61 frequencies on 2 processes")


if __name__ == "__main__":
    main()
