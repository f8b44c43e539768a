"""Ground loss (SPEC section 2): the share of the antenna's input power the soil absorbs,
L(nu) = 1 - (1/4 pi) int over the upper hemisphere of G dOmega, computed by
:meth:`Beam.ground_loss`. EDGES corrects its spectra by a modelled loss; a plane's loss and its
change with the soil are what a FoM at one soil cannot see. Here: the loss of a beam or the note
why it has none, its largest value over a band, and the two-column table the EDGES pipeline
reads (frequency in MHz, loss as a fraction; ``#`` header lines).
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .beam import Beam
from .errors import GroundLossUndefined
from .files import atomic_path

__all__ = ["loss_or_note", "largest_in_band", "write_loss_table", "spread_across"]


def loss_or_note(beam: Beam) -> tuple[np.ndarray | None, str | None]:
    """(loss per frequency, None), or (None, why the beam has none)."""
    try:
        return beam.ground_loss(), None
    except GroundLossUndefined as exc:
        return None, str(exc)


def largest_in_band(freqs_mhz: np.ndarray, loss: np.ndarray, band: tuple[float, float]) -> float:
    """The largest loss at the frequencies within ``band`` (MHz; all of them when none is)."""
    f = np.asarray(freqs_mhz, dtype=float)
    inside = (f >= band[0] - 1e-9) & (f <= band[1] + 1e-9)
    return float(np.max(np.asarray(loss)[inside] if inside.any() else loss))


def spread_across(losses: list[np.ndarray]) -> np.ndarray:
    """Per frequency, the largest minus the smallest loss of several beams (soils, say): the
    calibration risk of a loss that moves with the ground."""
    stack = np.vstack([np.asarray(x, dtype=float) for x in losses])
    return stack.max(axis=0) - stack.min(axis=0)


def write_loss_table(path: str | os.PathLike, beam: Beam, command: str = "") -> Path:
    """The EDGES-pipeline ground-loss table of ``beam``: '#' header lines (what it is, the
    beam, the command), then one line per frequency: MHz and the loss as a fraction.
    Raises :class:`GroundLossUndefined` for a beam with no ground loss (nothing written)."""
    loss = beam.ground_loss()
    head = ["ground loss L = 1 - (1/4 pi) int over the upper hemisphere of G dOmega: the fraction of the antenna's "
            "input power absorbed by the ground (EDGES applies 1 - L to its spectra)",
            f"beam: {beam.meta.get('source', 'beam')}"]
    if beam.meta.get("cache_key"):
        head.append(f"solver cache key: {beam.meta['cache_key']}")
    if command:
        head.append(f"written by: {command}")
    head.append("columns: frequency (MHz), ground loss (fraction)")
    lines = [f"# {h}" for h in head] + [f"{f:.6f} {x:.9e}" for f, x in zip(beam.freqs_mhz, loss)]
    path = Path(path)
    with atomic_path(path, suffix=".tmp" + (path.suffix or ".txt")) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return path
