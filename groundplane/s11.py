"""The antenna's input impedance and reflection coefficient from a solved beam: what a team
matching a receiver to the antenna wants next to its beam. Our engines record the feed's input
impedance per frequency (``meta.input_impedance_re`` / ``_im``, ohm); the EDGES FEKO table's
headers carry it too. S11 = (Z - Z0) / (Z + Z0); written as a Touchstone v1 one-port file
(``.s1p``: ``# MHz S RI R Z0``, one line per frequency), the format RF tools (scikit-rf,
Keysight ADS, QUCS) read.
"""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from .beam import Beam
from .errors import UserInputError
from .files import atomic_path

__all__ = ["input_impedance", "reflection", "write_touchstone"]


def input_impedance(beam: Beam) -> np.ndarray | None:
    """The input impedance (ohm) at each of the beam's frequencies, or None when the beam does
    not carry one (an export without it, a beam from an older engine)."""
    re, im = beam.meta.get("input_impedance_re"), beam.meta.get("input_impedance_im")
    if not isinstance(re, list) or not isinstance(im, list) or len(re) != beam.freqs_mhz.size or len(im) != len(re):
        return None
    try:
        z = np.asarray(re, dtype=float) + 1j * np.asarray(im, dtype=float)
    except (TypeError, ValueError):
        return None
    return z if np.all(np.isfinite(z)) else None


def reflection(z: np.ndarray, z0: float = 50.0) -> np.ndarray:
    """S11 = (Z - Z0) / (Z + Z0) against a real reference impedance ``z0`` (ohm)."""
    if not (math.isfinite(z0) and z0 > 0):
        raise UserInputError(f"--z0 {z0:g}: the reference impedance must be a positive number of ohm")
    return (z - z0) / (z + z0)


def write_touchstone(path: str | os.PathLike, freqs_mhz: np.ndarray, s11: np.ndarray, z0: float = 50.0,
                     comments: list[str] | None = None) -> Path:
    """A Touchstone v1 one-port file (real and imaginary parts, MHz), atomically."""
    path = Path(path)
    if path.suffix.lower() != ".s1p":
        raise UserInputError(f"{path}: a one-port Touchstone file's name ends in .s1p")
    lines = [f"! {c}" for c in (comments or [])]
    lines.append(f"# MHz S RI R {z0:.12g}")
    lines += [f"{f:.9f} {s.real:.15e} {s.imag:.15e}" for f, s in zip(freqs_mhz, s11)]
    with atomic_path(path, suffix=".tmp.s1p") as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return path


def db(s11: np.ndarray) -> np.ndarray:
    """|S11| in dB."""
    return 20 * np.log10(np.maximum(np.abs(s11), 1e-300))
