"""NEC-2 solve speed: where the time per frequency goes, and whole candidates.

    .venv/bin/python benchmarks/bench_nec.py [--candidate sawtooth-20-16] [--spacings 0.5 0.35]
    .venv/bin/python benchmarks/bench_nec.py --full 0.5 0.35      # 61 frequencies per spacing

Per frequency (75 MHz, one process, one thread): matrix fill + LU, far field and the
blade-over-PEC calibration, for the model as it was (the whole structure, far field at
1 degree, calibration solved with every candidate) and as it is now (half the structure
plus NEC's 180-degree rotation, far field every 3 degrees splined to 1, calibration
solved once per blade and frequency and cached). Both run here, one after the other, so
the printed ratio survives a noisy machine. ``--full`` solves all 61 frequencies (40-100
MHz) of the candidate on 2 processes into a fresh cache (cold calibration included) and
prints the wall time. Never fails on a time.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from groundplane.design import Design, Soil
from groundplane.shapes import PRESETS


def breakdown_child(name: str, spacing: float, fast: bool) -> dict:
    """One frequency in this process (no healpy here, so PyNEC may load)."""
    from solvers.engines.nec import NecSettings, build_model
    from solvers.engines.nec.engine import calibration_factor, context
    from solvers.engines.nec.mesh import pec_reference_model
    from solvers.engines.patterns import to_one_degree

    settings = NecSettings(spacing=spacing, rotational_symmetry=fast, far_field_step=3 if fast else 1)
    design = Design(PRESETS[name], Soil())
    model = build_model(design, settings)
    step = settings.far_field_step
    t0 = time.perf_counter()
    c = context(model, 75.0)
    c.xq_card(0)  # fill + LU + solve, no pattern
    t1 = time.perf_counter()
    n = 90 // step + 1
    c.rp_card(0, n, n, 0, 0, 0, 0, 0.0, 0.0, float(step), float(step), 0, 0)
    g = 10 ** (np.asarray(c.get_radiation_pattern(0).get_gain()) / 10)
    if step > 1:
        to_one_degree(g, step, quadrant=True)
    t2 = time.perf_counter()
    calibration_factor(pec_reference_model(design, settings), 75.0, step)  # what a cold cache pays
    t3 = time.perf_counter()
    return {"segments": model.n_segments, "sections": model.sections, "fill_lu": t1 - t0,
            "far_field": t2 - t1, "calibration": t3 - t2}


def breakdown(name: str, spacing: float, fast: bool) -> dict:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, __file__, "--child", name, str(spacing), str(int(fast))],
                         env=env, check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def full_candidate(name: str, spacing: float) -> tuple[float, dict]:
    """Wall time of a 61-frequency solve on 2 processes into a fresh cache."""
    from solvers.engines.nec import NecSettings, NecSolver

    with tempfile.TemporaryDirectory() as tmp:
        os.environ["GROUNDPLANE_CACHE"] = tmp
        t0 = time.perf_counter()
        beam = NecSolver(NecSettings(spacing=spacing), workers=2, progress=True).solve(
            Design(PRESETS[name], Soil()), np.arange(40.0, 101.0))
        return time.perf_counter() - t0, beam.meta


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--candidate", default="sawtooth-20-16", choices=list(PRESETS))
    p.add_argument("--spacings", type=float, nargs="*", default=[0.5, 0.35])
    p.add_argument("--full", type=float, nargs="*", metavar="SPACING",
                   help="also solve 61 frequencies at these spacings (minutes each)")
    p.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.child:
        name, sp, fast = a.child
        print(json.dumps(breakdown_child(name, float(sp), fast == "1")))
        return
    print(f"{a.candidate}, one frequency (75 MHz), 1 process, 1 thread; seconds")
    print(f"{'spacing':>8} {'model':>6} {'segments':>9} {'fill+LU':>8} {'far field':>9} {'calib.':>7} "
          f"{'total':>7} {'first cand.':>11} {'later':>7}")
    for sp in a.spacings:
        rows = {}
        for fast in (False, True):
            r = breakdown(a.candidate, sp, fast)
            first = r["fill_lu"] + r["far_field"] + r["calibration"]
            later = r["fill_lu"] + r["far_field"] + (0.0 if fast else r["calibration"])
            rows[fast] = (first, later)
            print(f"{sp:8.2f} {'now' if fast else 'before':>6} {r['segments']:9d} {r['fill_lu']:8.1f} "
                  f"{r['far_field']:9.2f} {r['calibration']:7.2f} {first:7.1f} {first:11.1f} {later:7.1f}")
        print(f"{'':8} speed-up per frequency, later candidates: {rows[False][1] / rows[True][1]:.2f}x")
    for sp in a.full or []:
        wall, meta = full_candidate(a.candidate, sp)
        per = np.asarray(meta["seconds_per_frequency"])
        print(f"{a.candidate} at {sp:g} m, {meta['n_segments']} segments, 61 frequencies on 2 processes: "
              f"{wall / 60:.1f} min wall (per frequency {per.min():.1f}-{per.max():.1f} s in a worker)")


if __name__ == "__main__":
    main()
