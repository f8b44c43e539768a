"""Speed of FoM scoring: the cached-sky matrix product vs a straightforward per-LST
reference integration (groundplane.reference), both run here, in this process.

    .venv/bin/python benchmarks/bench_fom.py

Prints the time to score a 61-frequency, 1-degree beam over 360 LSTs with the horizon
sky cache warm (target <= 0.3 s), and the ratio against the reference integration
(timed on a few LSTs and scaled to 360). Never fails on a time.
"""
from __future__ import annotations

import time

import numpy as np

from groundplane.beam import Beam
from groundplane.fom import FomSettings, figure_of_merit, sky_for
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


def main() -> None:
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
    print(f"fast FoM, in-memory sky (median of 5): {fast:.3f} s   [target <= 0.3 s]  "
          f"LST-averaged FoM {r.lst_averaged_fom_mk:.2f} mK")
    n_ref = 6
    t0 = time.perf_counter()
    reference_antenna_temperature(beam, s, lst_grid(360)[:: 360 // n_ref][:n_ref])
    ref = (time.perf_counter() - t0) / n_ref * 360
    print(f"reference per-LST integration, scaled to 360 LSTs: {ref:.1f} s")
    print(f"speed-up of the fast path: {ref / fast:.0f}x (disk-warm: {ref / cold_mem:.0f}x)")


if __name__ == "__main__":
    main()
