"""Speed of FoM scoring: the cached-sky matrix product vs a straightforward per-LST
reference integration (groundplane.reference), both run here, in this process.

    .venv/bin/python benchmarks/bench_fom.py

Prints the time to score a 61-frequency, 1-degree beam over 360 LSTs with the horizon
sky cache warm, the ratio against the reference integration run over all 360 LSTs (a few
minutes; ``--quick`` times 6 LSTs and says it scaled them), and the wall time of a whole
warm ``groundplane fom BEAM --json`` command (median of 5) on the shipped EDGES-format
FEKO table, against a bare ``python -c pass`` start. Never fails on a time.
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from groundplane.beam import Beam
from groundplane.fom import FomSettings, antenna_temperature, figure_of_merit, sky_for
from groundplane.reference import reference_antenna_temperature
from groundplane.sky import _MEMORY, lst_grid


def synthetic_beam() -> Beam:
    """A chromatic dipole-like beam: 61 frequencies 40-100 MHz, theta 0-90, phi 0-359."""
    f = np.arange(40.0, 101.0)
    th, ph = np.radians(np.arange(91.0)), np.radians(np.arange(360.0))
    t, p = np.meshgrid(th, ph, indexing="ij")
    width = 1.0 + 0.003 * np.sin(2 * np.pi * f / 17.0)
    g = np.cos(t)[None] ** (2 * width[:, None, None]) * (1 - 0.3 * np.sin(t)[None] ** 2 * np.cos(p)[None] ** 2)
    return Beam(f, np.arange(91.0), np.arange(360.0), 7 * g)


def command_wall(cmd: list[str], n: int = 5) -> float:
    """Median wall time of ``cmd`` over ``n`` runs (after one warm-up run)."""
    subprocess.run(cmd, check=True, capture_output=True)
    runs = []
    for _ in range(n):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        runs.append(time.perf_counter() - t0)
    return statistics.median(runs)


def cli_timing() -> None:
    exe = str(Path(sys.executable).with_name("groundplane"))
    beam = Path(__file__).resolve().parents[1] / "examples" / "edges_highband_feko.npz"
    bare = command_wall([sys.executable, "-c", "pass"])
    warm = command_wall([exe, "fom", str(beam), "--fit-band", "90", "190", "--json"])
    print(f"warm `groundplane fom {beam.name} --fit-band 90 190 --json` (median of 5): {warm:.2f} s "
          f"[target <= 0.5 s]; bare interpreter start {bare:.2f} s ({warm / bare:.1f}x)")


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--quick", action="store_true", help="time the reference on 6 LSTs and scale to 360")
    a = p.parse_args()
    cli_timing()
    beam = synthetic_beam()
    s = FomSettings()
    t0 = time.perf_counter()
    sky_for(beam, s, progress=False)  # builds or loads the disk cache
    print(f"horizon sky (build or disk load): {time.perf_counter() - t0:.2f} s")
    _MEMORY.clear()
    t0 = time.perf_counter()
    figure_of_merit(beam, s)
    cold_mem = time.perf_counter() - t0
    runs = []
    for _ in range(5):
        t0 = time.perf_counter()
        r = figure_of_merit(beam, s)
        runs.append(time.perf_counter() - t0)
    fast = float(np.median(runs))
    print(f"fast FoM, disk cache warm (loads the 47 MB sky): {cold_mem:.3f} s")
    print(f"fast FoM, in-memory sky (median of 5): {fast:.3f} s  "
          f"LST-averaged FoM {r.lst_averaged_mk:.2f} mK")
    n_ref = 6 if a.quick else 360
    t0 = time.perf_counter()
    t_ref = reference_antenna_temperature(beam, s, lst_grid(360)[:: 360 // n_ref][:n_ref])
    ref = (time.perf_counter() - t0) / n_ref * 360
    how = f"timed on {n_ref} LSTs and scaled to 360" if a.quick else "all 360 LSTs"
    print(f"reference per-LST integration ({how}): {ref:.1f} s")
    if not a.quick:
        t_fast = antenna_temperature(beam, s)
        print(f"largest |T_ant fast - reference| / T_ant: {np.max(np.abs(t_fast - t_ref) / t_ref):.1e}")
    print(f"speed-up of the fast path: {ref / fast:.0f}x (disk-warm: {ref / cold_mem:.0f}x)")


if __name__ == "__main__":
    main()
