"""HFSS far-field CSV ("Export report data" of a radiation pattern report).

HFSS writes quoted column headers with units, one row a direction (and frequency)::

    "Freq [MHz]","Phi [deg]","Theta [deg]","dB(GainTotal) []"
    75,0,-180,-28.1

The frequency is a column, or (single-frequency reports) a qualifier inside the quantity's
header, e.g. ``"dB(GainTotal) [] - Freq='0.075GHz'"``. Gain columns understood:
dB(GainTotal), GainTotal, dB(RealizedGainTotal), RealizedGainTotal, dB(DirTotal), DirTotal.
Theta may run -180..180 (the two halves of each phi cut); it is folded onto 0..180.
"""
from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np

from groundplane.beam import Beam, BeamFormatError

from . import BeamFormat, head_lines, register_format
from ._grid import UNIT_SCALE_TO_MHZ, assemble, check_frequency, db_to_linear, samples_to_grid, where

_QUANTITIES = ("realizedgaintotal", "gaintotal", "dirtotal")
_HEAD = re.compile(r"^\s*([^\[]+?)\s*\[([^\]]*)\](.*)$")
_FREQ_QUAL = re.compile(r"Freq\s*=\s*'([0-9.eE+-]+)\s*(GHz|MHz|kHz|Hz)'", re.IGNORECASE)


def _gain_column(names: list[str], header: list[str], path: Path) -> tuple[int, bool]:
    """(index, in dB) of the first gain quantity HFSS wrote, in order of preference."""
    for q in _QUANTITIES:
        for i, n in enumerate(names):
            bare = n.replace(" ", "")
            if bare == f"db({q})" or bare == q:
                return i, bare.startswith("db(")
    raise BeamFormatError(f"{where(path, 1)}: no gain column (dB(GainTotal), GainTotal, dB(RealizedGainTotal), "
                          f"dB(DirTotal), ...) in {header}")


def _hfss_columns(header: list[str], path: Path) -> dict:
    """Which columns hold theta, phi, frequency and gain, in which units (the frequency from the
    gain header's Freq='..' qualifier when there is no frequency column)."""
    parsed = []
    for h in header:
        m = _HEAD.match(h)
        parsed.append((m.group(1).strip(), m.group(2).strip().lower(), m.group(3)) if m else (h.strip(), "", ""))
    names = [p[0].lower() for p in parsed]

    def col(prefix: str) -> int | None:
        return next((i for i, n in enumerate(names) if n == prefix), None)

    i_theta, i_phi, i_freq = col("theta"), col("phi"), col("freq")
    if i_theta is None or i_phi is None:
        raise BeamFormatError(
            f"{where(path, 1)}: expected 'Theta [deg]' and 'Phi [deg]' columns in the HFSS header, got {header}"
        )
    i_gain, is_db = _gain_column(names, header, path)
    fixed_freq = None
    if i_freq is None:
        m = _FREQ_QUAL.search(parsed[i_gain][2])
        if not m:
            raise BeamFormatError(f"{where(path, 1)}: no 'Freq [..]' column and no Freq='..' qualifier in the gain header")
        fixed_freq = float(m.group(1)) * UNIT_SCALE_TO_MHZ[m.group(2).lower()]
    f_scale = UNIT_SCALE_TO_MHZ.get(parsed[i_freq][1], None) if i_freq is not None else 1.0
    if f_scale is None:
        raise BeamFormatError(f"{where(path, 1)}: unknown frequency unit '{parsed[i_freq][1]}'")
    ang_scale = {}
    for i in (i_theta, i_phi):
        unit = parsed[i][1]
        if unit not in ("deg", "rad"):
            raise BeamFormatError(f"{where(path, 1)}: angle unit '{unit}' of '{header[i]}' (expected deg or rad)")
        ang_scale[i] = 1.0 if unit == "deg" else 180.0 / np.pi
    return {"theta": i_theta, "phi": i_phi, "freq": i_freq, "gain": i_gain, "is_db": is_db, "fixed_freq": fixed_freq,
            "f_scale": f_scale, "ang_scale": ang_scale}


def read_hfss(path: str | Path) -> Beam:
    """One HFSS far-field CSV (any number of frequencies). One piece: a line-by-line reader whose
    every refusal names the file and line it is at."""
    path = Path(path)
    with open(path, newline="", errors="replace") as fh:
        reader = csv.reader(fh)
        try:
            header = next(reader)
        except StopIteration:
            raise BeamFormatError(f"{path}: empty file") from None
        c = _hfss_columns(header, path)
        i_theta, i_phi, i_freq, i_gain, ang = c["theta"], c["phi"], c["freq"], c["gain"], c["ang_scale"]
        rows = []
        for lineno, rec in enumerate(reader, 2):
            if not rec or all(not r.strip() for r in rec):
                continue
            if len(rec) != len(header):
                raise BeamFormatError(f"{where(path, lineno)}: expected {len(header)} fields, found {len(rec)}")
            try:
                rows.append([float(rec[i_freq]) * c["f_scale"] if i_freq is not None else c["fixed_freq"],
                             float(rec[i_theta]) * ang[i_theta], float(rec[i_phi]) * ang[i_phi], float(rec[i_gain])])
            except ValueError:
                raise BeamFormatError(f"{where(path, lineno)}: not a number in {rec}") from None
            if i_freq is not None and (len(rows) == 1 or rows[-1][0] != rows[-2][0]):
                check_frequency(rows[-1][0], where(path, lineno))  # each new frequency, with its line
    if not rows:
        raise BeamFormatError(f"{path}: header but no data rows")
    a = np.asarray(rows)
    gain = db_to_linear(a[:, 3]) if c["is_db"] else a[:, 3]
    freqs = np.unique(np.round(a[:, 0], 9))
    grids = []
    for f in freqs:
        sel = np.isclose(a[:, 0], f)
        grids.append(samples_to_grid(a[sel, 1], a[sel, 2], gain[sel], f"{path} at {f:g} MHz"))
    return assemble(list(freqs), grids, str(path), {"format": "hfss", "solver": "HFSS", "quantity": header[i_gain]})


def _sniff(head: bytes) -> bool:
    first = (head_lines(head, 1) or [""])[0]
    return first.startswith('"') and "theta" in first.lower() and "," in first


register_format(BeamFormat("hfss", _sniff, lambda paths: read_hfss(paths[0]),
                           description="HFSS far-field report CSV (theta -180..180 folded)"))
