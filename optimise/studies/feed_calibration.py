"""Absolute-gain calibration of the NEC-2 blade feed: mean gain over PEC vs blade mesh,
and whether the PEC calibration carries over to soil."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from groundplane.design import Design, InfinitePEC, Soil
from groundplane.shapes import PRESETS
from solvers.engines.nec import NecSettings

from ..provenance import write_md
from . import study
from ._common import (
    machine,
    solve,
)


def feed_calibration(out: Path, command: str) -> None:
    """Mean gain over PEC (truth: 2) of NEC's raw output vs blade mesh, and whether the
    PEC-derived calibration carries over to soil: square-10 zenith gain with the default
    blade (calibrated) against a 24 x 18 blade (raw and calibrated)."""
    out.mkdir(parents=True, exist_ok=True)
    lines = [
        "# Absolute-gain calibration of the NEC-2 blade feed",
        "",
        f"Command: `{command}`.",
        f"Machine: {machine()}.",
        "",
        "## Blade over infinite PEC, 75 MHz, no calibration (lossless: the mean gain over the upper hemisphere must be 2)",
        "",
        "| blade cells | segments | mean gain | gain error (dB) |",
        "|---|---|---|---|",
    ]
    pec = Design(None, InfinitePEC())
    for cells in ((8, 6), (12, 10), (16, 12), (24, 18)):
        mesh = NecSettings(blade_cells=cells, gain_calibration="none")
        beam, _ = solve(pec, mesh, [75.0])
        w = beam.solid_angle_weights()
        mean = float((beam.gain[0] * w).sum() / w.sum())
        lines.append(f"| {cells[0]} x {cells[1]} | {beam.meta['n_segments']} | {mean:.4f} | {10 * np.log10(mean / 2):+.3f} |")
        write_md(out / "feed_calibration.md", "\n".join(lines) + "\n", "study feed-calibration", command)
    lines += [
        "",
        "## Does the PEC calibration carry over to soil? `square-10`, 0.5 m mesh, zenith gain (dBi)",
        "",
        "| MHz | 12 x 10 blade, calibrated (default) | 24 x 18 blade, calibrated | 24 x 18 blade, raw |",
        "|---|---|---|---|",
    ]
    freqs = [50.0, 75.0, 100.0]
    soil = Design(PRESETS["square-10"], Soil())
    cols = []
    for cells, cal in (((12, 10), "pec"), ((24, 18), "pec"), ((24, 18), "none")):
        beam, _ = solve(soil, NecSettings(blade_cells=cells, gain_calibration=cal), freqs)
        cols.append(10 * np.log10(beam.gain[:, 0, 0]))
    for i, f in enumerate(freqs):
        lines.append(f"| {f:g} | {cols[0][i]:.3f} | {cols[1][i]:.3f} | {cols[2][i]:.3f} |")
    diff = np.max(np.abs(cols[0] - cols[1]))
    lines += ["", f"Largest difference between the calibrated 12 x 10 and 24 x 18 blades: {diff:.3f} dB."]
    write_md(out / "feed_calibration.md", "\n".join(lines) + "\n", "study feed-calibration", command)


@study("feed-calibration", "NEC-2 feed: mean gain over PEC vs blade mesh; does the PEC calibration carry to soil")
def _run(out: Path, settings, command: str, **extra) -> None:
    feed_calibration(out, command, **extra)
