"""CST Studio far-field ASCII export (``Export -> Farfield ... ASCII``; one frequency a file).

Layout (CST's documented column header, then a dashed rule, then one row a direction)::

    Theta [deg.]  Phi   [deg.]  Abs(Gain)[dBi   ]   Abs(Theta)[dBi   ]  Phase(Theta)[deg.]  Abs(Phi  )[dBi   ]  Phase(Phi  )[deg.]  Ax.Ratio[dB    ]
    ------------------------------------------------------------------------------------------------------------------------------------------------------
       0.000    0.000    5.123e+00    ...

The first magnitude column is ``Abs(Dir.)``, ``Abs(Gain)`` or ``Abs(Realized Gain)``
depending on the plot mode; the unit in its brackets says dB or linear. The frequency is
not in the file: CST names exports ``farfield (f=75) [1].txt``, so it is read from
``f=<number>`` in the file name (MHz unless a unit follows), or given explicitly.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from groundplane.beam import Beam, BeamFormatError

from . import BeamFormat, head_lines, register_format
from ._grid import UNIT_SCALE_TO_MHZ, assemble, db_to_linear, samples_to_grid, where

_FREQ_IN_NAME = re.compile(r"f\s*=\s*([0-9.]+(?:[eE][+-]?\d+)?)\s*(GHz|MHz|kHz|Hz)?", re.IGNORECASE)
_MAGNITUDE = ("abs(realized gain)", "abs(gain)", "abs(dir.)", "abs(directivity)")


def frequency_from_name(path: Path) -> float | None:
    """The frequency (MHz) CST writes into an export's name as ``f=<number>``, or None."""
    m = _FREQ_IN_NAME.search(path.name)
    if not m:
        return None
    return float(m.group(1)) * UNIT_SCALE_TO_MHZ[(m.group(2) or "MHz").lower()]


def _columns(header: str) -> list[tuple[str, str]]:
    """(name, unit) pairs from CST's header line, e.g. ('abs(gain)', 'dbi')."""
    return [(n.strip().lower(), u.strip().lower()) for n, u in re.findall(r"([^\[\]]+?)\s*\[([^\]]*)\]", header)]


def read_cst(path: str | Path, freq_mhz: float | None = None) -> Beam:
    """One CST far-field ASCII file at one frequency."""
    path = Path(path)
    freq = freq_mhz if freq_mhz is not None else frequency_from_name(path)
    if freq is None:
        raise BeamFormatError(
            f"{path}: CST exports do not record the frequency; name the file with 'f=<MHz>' "
            "(as CST does: 'farfield (f=75) [1].txt') or pass the frequency explicitly"
        )
    with open(path, "r", errors="replace") as fh:
        lines = fh.read().splitlines()
    head_i = next((i for i, l in enumerate(lines) if l.strip()), None)
    if head_i is None:
        raise BeamFormatError(f"{path}: empty file")
    cols = _columns(lines[head_i])
    names = [c[0] for c in cols]
    if len(cols) < 3 or not names[0].startswith("theta") or not names[1].startswith("phi"):
        raise BeamFormatError(
            f"{where(path, head_i + 1)}: expected CST header 'Theta [deg.]  Phi [deg.]  Abs(...)[dBi] ...', "
            f"got '{lines[head_i].strip()[:80]}'"
        )
    mag = next((i for i, n in enumerate(names) if n in _MAGNITUDE), None)
    if mag is None:
        raise BeamFormatError(f"{where(path, head_i + 1)}: no gain or directivity magnitude column in {names}")
    unit = cols[mag][1]
    rows = []
    for lineno, line in enumerate(lines[head_i + 1:], head_i + 2):
        s = line.strip()
        if not s or set(s) <= {"-"}:
            continue
        parts = s.split()
        if len(parts) != len(cols):
            raise BeamFormatError(f"{where(path, lineno)}: expected {len(cols)} columns, found {len(parts)}")
        try:
            rows.append([float(parts[0]), float(parts[1]), float(parts[mag])])
        except ValueError:
            raise BeamFormatError(f"{where(path, lineno)}: not a number in '{s[:60]}'") from None
    if not rows:
        raise BeamFormatError(f"{path}: header but no data rows")
    a = np.asarray(rows)
    gain = db_to_linear(a[:, 2]) if unit.startswith("db") else a[:, 2]
    grid = samples_to_grid(a[:, 0], a[:, 1], gain, f"{path} at {freq:g} MHz")
    return assemble([freq], [grid], str(path),
                    {"format": "cst", "solver": "CST", "quantity": names[mag]})


def read_cst_set(paths: list[str | Path], freqs_mhz: list[float] | None = None) -> Beam:
    """One CST file per frequency, stacked into one beam."""
    beams = [read_cst(p, None if freqs_mhz is None else freqs_mhz[i]) for i, p in enumerate(paths)]
    if len(beams) == 1:
        return beams[0]
    grids = [(b.theta_deg, b.phi_deg, b.gain[0]) for b in beams]
    return assemble([float(b.freqs_mhz[0]) for b in beams], grids, " + ".join(map(str, paths)),
                    {"format": "cst", "solver": "CST", "parts": [str(p) for p in paths]})


def _sniff(head: bytes) -> bool:
    first = (head_lines(head, 1) or [""])[0].lower()
    return first.startswith("theta") and "[deg" in first


register_format(BeamFormat("cst", _sniff, read_cst_set, multi_file=True,
                           description="CST far-field ASCII export, one file per frequency (f=<MHz> in the name)"))
