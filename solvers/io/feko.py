"""FEKO far-field exports: the ``.ffe`` file (one or many frequencies, possibly one azimuth
quadrant per file) and the EDGES-format FEKO gain table (``#FREQUENCY nn MHz`` blocks of
360 azimuth rows by 91 elevation columns, gain in dB)."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from groundplane.beam import Beam, BeamFormatError

from . import BeamFormat, head_lines, register_format
from ._grid import assemble, check_frequency, db_to_linear, merge_phi, samples_to_grid, where

_GAIN_COLUMNS = ("Gain(Total)", "Realized Gain(Total)", "Directivity(Total)")


def _float_row(parts: list[str], path: Path, lineno: int, expected: int) -> list[float]:
    if len(parts) != expected:
        raise BeamFormatError(f"{where(path, lineno)}: expected {expected} numbers, found {len(parts)}")
    try:
        vals = [float(p) for p in parts]
    except ValueError as exc:
        raise BeamFormatError(f"{where(path, lineno)}: not a number ({exc})") from None
    return vals


def _count(body: str, path: Path, lineno: int) -> int:
    """A header's sample count ('#No. of Theta Samples: 181')."""
    try:
        n = int(body.split(":", 1)[1])
    except ValueError:
        raise BeamFormatError(f"{where(path, lineno)}: unreadable sample count '{body}'") from None
    if n < 1:
        raise BeamFormatError(f"{where(path, lineno)}: sample count must be >= 1, got '{body}'")
    return n


def _close_block(path: Path, block: dict | None, lineno: int, blocks: list[dict]) -> None:
    """Check one finished frequency block (columns, row count) and append it to ``blocks``."""
    if block is None:
        return
    if block["columns"] is None:
        raise BeamFormatError(f"{where(path, lineno)}: the block at {block['freq_mhz']:g} MHz (starting line "
                              f"{block['start']}) has no column-name line; truncated, or not a FEKO export")
    for c in ("Theta", "Phi"):
        if c not in block["columns"]:
            raise BeamFormatError(f"{where(path, block['start'])}: no '{c}' column in the block at "
                                  f"{block['freq_mhz']:g} MHz (found {', '.join(block['columns'])})")
    rows = np.asarray(block["rows"], dtype=float).reshape(-1, len(block["columns"]))
    n_expected = block["n_theta"] * block["n_phi"] if block["n_theta"] and block["n_phi"] else None
    if n_expected is not None and rows.shape[0] != n_expected:
        raise BeamFormatError(
            f"{where(path, lineno)}: the block at {block['freq_mhz']:g} MHz (starting line "
            f"{block['start']}) has {rows.shape[0]} data rows, expected {block['n_theta']} theta x "
            f"{block['n_phi']} phi = {n_expected} (truncated file?)"
        )
    blocks.append({**block, "rows": rows})


def _ffe_block(body: str, path: Path, lineno: int) -> dict:
    """A new frequency block from its ``#Frequency:`` line (in Hz)."""
    try:
        f_hz = float(body.split(":", 1)[1])
    except ValueError:
        raise BeamFormatError(f"{where(path, lineno)}: unreadable frequency '{body}'") from None
    check_frequency(f_hz / 1e6, where(path, lineno))
    return {"freq_mhz": f_hz / 1e6, "rows": [], "columns": None, "n_theta": None, "n_phi": None, "start": lineno,
            "result": None}


def _ffe_header(body: str, block: dict, path: Path, lineno: int) -> None:
    """A block's header line: its sample counts, result type or column names (others ignored)."""
    low = body.lower()
    if low.startswith("no. of theta samples:"):
        block["n_theta"] = _count(body, path, lineno)
    elif low.startswith("no. of phi samples:"):
        block["n_phi"] = _count(body, path, lineno)
    elif low.startswith("result type:"):
        block["result"] = body.split(":", 1)[1].strip()
    elif '"Theta"' in body:
        block["columns"] = re.findall(r'"([^"]+)"', body)


def read_ffe(path: str | Path) -> Beam:
    """One FEKO ``.ffe`` file (all frequency blocks in it). One piece: a line-by-line reader whose
    every refusal names the file and line it is at."""
    path = Path(path)
    blocks: list[dict] = []
    cur: dict | None = None

    with open(path, "r", errors="replace") as fh:
        for lineno, raw in enumerate(fh, 1):
            line = raw.strip()
            if not line:
                continue
            if line.startswith("#"):
                body = line.lstrip("#").strip()
                if body.lower().startswith("frequency:"):
                    _close_block(path, cur, lineno, blocks)
                    cur = _ffe_block(body, path, lineno)
                elif cur is not None:
                    _ffe_header(body, cur, path, lineno)
                continue
            if cur is None or cur["columns"] is None:
                raise BeamFormatError(
                    f"{where(path, lineno)}: data before a '#Frequency:' header and column-name line; "
                    "not a FEKO .ffe far-field file?"
                )
            cur["rows"].extend(_float_row(line.split(), path, lineno, len(cur["columns"])))
        _close_block(path, cur, lineno if cur else 0, blocks)
    if not blocks:
        raise BeamFormatError(f"{path}: no '#Frequency:' block found; not a FEKO .ffe far-field file")

    freqs, grids = [], []
    axis = _zenith_polarisation_axis(blocks[len(blocks) // 2])
    for b in blocks:
        cols = b["columns"]
        gcol = next((c for c in _GAIN_COLUMNS if c in cols), None)
        if gcol is None:
            raise BeamFormatError(
                f"{where(path, b['start'])}: no total gain or directivity column (looked for "
                f"{', '.join(_GAIN_COLUMNS)}; found {', '.join(cols)}). Export with 'Gain' or 'Directivity'."
            )
        rows = b["rows"]
        theta = rows[:, cols.index("Theta")]
        phi = rows[:, cols.index("Phi")]
        gain = db_to_linear(rows[:, cols.index(gcol)])
        freqs.append(b["freq_mhz"])
        grids.append(samples_to_grid(theta, phi, gain, f"{path} at {b['freq_mhz']:g} MHz"))
    # Every block must cover the same directions before stacking.
    gcols = {next((c for c in _GAIN_COLUMNS if c in b["columns"]), None) for b in blocks}
    meta = {"format": "feko-ffe", "solver": "FEKO", "quantity": gcols.pop() if len(gcols) == 1 else "mixed columns"}
    if axis is not None:
        meta["excitation_axis_deg"] = axis
    return assemble(freqs, grids, str(path), meta)


def _zenith_polarisation_axis(block: dict) -> float | None:
    """Azimuth (deg, 0..180) of the E-field's major axis at zenith: the excitation axis of a
    dipole model. None when the file has no field columns or no zenith sample."""
    cols = block["columns"]
    need = ("Re(Etheta)", "Im(Etheta)", "Re(Ephi)", "Im(Ephi)")
    if not all(c in cols for c in need):
        return None
    rows = block["rows"]
    zen = np.flatnonzero(np.abs(rows[:, cols.index("Theta")]) < 1e-9)
    if zen.size == 0:
        return None
    r = rows[zen[0]]
    phi = np.radians(r[cols.index("Phi")])
    et = r[cols.index("Re(Etheta)")] + 1j * r[cols.index("Im(Etheta)")]
    ep = r[cols.index("Re(Ephi)")] + 1j * r[cols.index("Im(Ephi)")]
    ex = et * np.cos(phi) - ep * np.sin(phi)
    ey = et * np.sin(phi) + ep * np.cos(phi)
    angles = np.radians(np.arange(0.0, 180.0, 0.25))
    amp = np.abs(ex * np.cos(angles) + ey * np.sin(angles))
    return float(np.degrees(angles[int(np.argmax(amp))]))


def read_ffe_set(paths: list[str | Path], align_excitation_axis: bool = True) -> Beam:
    """Several ``.ffe`` files (e.g. four azimuth quadrants) stitched into one beam.

    FEKO models are often built with the dipole along y; with ``align_excitation_axis`` the
    beam is turned so phi = 0 is the excitation axis (the Beam convention), found from the
    E-field's polarisation at zenith and recorded in ``meta['phi_rotation_deg']``.
    """
    beams = [read_ffe(p) for p in paths]
    beam = beams[0] if len(beams) == 1 else merge_phi(beams, " + ".join(str(p) for p in paths))
    axes = [b.meta["excitation_axis_deg"] for b in beams if "excitation_axis_deg" in b.meta]
    if align_excitation_axis and axes:
        step = float(np.diff(beam.phi_deg)[0]) if beam.phi_deg.size > 1 else 360.0
        offset = round(axes[0] / step) * step
        full_circle = beam.phi_deg.size * step == 360.0
        if offset % 180 != 0 and full_circle:
            beam = beam.rotated(offset)
    return beam


_EDGES_HEADER = re.compile(r"^#\s*FREQUENCY\s+([0-9.eE+-]+)\s*MHz", re.IGNORECASE)
_EDGES_S11 = re.compile(r"s11\s+(-?[0-9.eE+-]+)\s*dB\s+(-?[0-9.eE+-]+)\s+(-?[0-9.eE+-]+)", re.IGNORECASE)


def read_edges_table(path: str | Path, n_azimuth: int = 360) -> Beam:
    """The EDGES-format FEKO gain table: per frequency, ``n_azimuth`` rows ``az N g_el0 ... g_el90``
    (gain in dB, elevation 0 = horizon in the first column). One piece: a line-by-line reader
    whose every refusal names the file and line it is at."""
    path = Path(path)
    freqs: list[float] = []
    tables: list[np.ndarray] = []
    elev: np.ndarray | None = None
    rows: list[list[float]] = []
    f_cur: float | None = None
    start = 0
    impedance: dict[float, complex | None] = {}

    def close(lineno: int) -> None:
        if f_cur is None:
            return
        if len(rows) != n_azimuth:
            raise BeamFormatError(
                f"{where(path, lineno)}: the block at {f_cur:g} MHz (line {start}) has {len(rows)} azimuth rows, "
                f"expected {n_azimuth} (truncated file?)"
            )
        freqs.append(f_cur)
        tables.append(np.asarray(rows, dtype=float))

    with open(path, "r", errors="replace") as fh:
        lineno = 0
        for lineno, raw in enumerate(fh, 1):
            line = raw.strip()
            if not line:
                continue
            m = _EDGES_HEADER.match(line)
            if m:
                close(lineno)
                f_cur, rows, start = check_frequency(float(m.group(1)), where(path, lineno)), [], lineno
                z = _EDGES_S11.search(line)  # "s11 -1.463 dB 6.136 -33.741": |S11| (50 ohm) and R, X of the input
                impedance[f_cur] = complex(float(z.group(2)), float(z.group(3))) if z else None
                continue
            if line.startswith("#"):
                elev = _edges_elevations(line, elev, where(path, lineno))
                continue
            if f_cur is None:
                raise BeamFormatError(f"{where(path, lineno)}: data before the first '#FREQUENCY nn MHz' header")
            rows.append(_edges_row(line, path, lineno, elev, len(rows)))
        close(lineno)
    return _edges_beam(path, freqs, tables, elev, impedance, n_azimuth)


def _edges_elevations(line: str, first: np.ndarray | None, at: str) -> np.ndarray:
    """An elevation header line's columns (deg), which every block must repeat."""
    try:
        e = np.asarray([float(c) for c in line.lstrip("#").split()])
    except ValueError:
        raise BeamFormatError(f"{at}: unreadable elevation header line") from None
    if first is not None and (e.shape != first.shape or not np.allclose(e, first)):
        raise BeamFormatError(f"{at}: elevation columns differ from the first block")
    return e


def _edges_row(line: str, path: Path, lineno: int, elev: np.ndarray | None, expected: int) -> np.ndarray:
    """One ``az N g_el0 ... g_el90`` row's gains (dB), refused out of order or short."""
    parts = line.split()
    if parts[0].lower() != "az":
        raise BeamFormatError(f"{where(path, lineno)}: expected a row starting 'az N', got '{parts[0]}'")
    n_el = elev.size if elev is not None else 91
    vals = _float_row(parts[1:], path, lineno, 1 + n_el)
    if not np.isfinite(vals[0]) or vals[0] != int(vals[0]):
        raise BeamFormatError(f"{where(path, lineno)}: azimuth row number '{parts[1]}' is not a whole number")
    if int(vals[0]) != expected:
        raise BeamFormatError(f"{where(path, lineno)}: azimuth row {int(vals[0])} out of order, expected {expected}")
    return vals[1:]


def _edges_beam(path: Path, freqs: list[float], tables: list[np.ndarray], elev: np.ndarray | None,
                impedance: dict[float, complex | None], n_azimuth: int) -> Beam:
    """The blocks read as one beam, in frequency order (the header's impedance kept when every
    block has one)."""
    if not freqs:
        raise BeamFormatError(f"{path}: no '#FREQUENCY nn MHz' block; not an EDGES-format gain table")
    el = elev if elev is not None else np.arange(91.0)
    theta = 90.0 - el[::-1]
    az = np.arange(n_azimuth) * 360.0 / n_azimuth
    gain = np.stack([db_to_linear(t[:, ::-1].T) for t in tables])  # [f, theta, phi]
    order = np.argsort(freqs)
    if np.unique(freqs).size != len(freqs):
        raise BeamFormatError(f"{path}: a frequency block is repeated")
    # The EDGES table's azimuth is the antenna-frame angle from the excitation axis.
    meta = {"source": str(path), "format": "edges-table", "solver": "FEKO"}
    zs = [impedance.get(freqs[i]) for i in order]
    if zs and all(z is not None for z in zs):  # the header's input impedance, at every frequency
        meta.update(input_impedance_re=[z.real for z in zs], input_impedance_im=[z.imag for z in zs])
    return Beam(np.asarray(freqs)[order], theta, az, gain[order], meta)


def _sniff_ffe(head: bytes) -> bool:
    return any(l.startswith("##File Type") or l.startswith("#Request Name") or l.lower().startswith("#frequency:")
               for l in head_lines(head))


def _sniff_edges(head: bytes) -> bool:
    first = (head_lines(head, 1) or [""])[0].upper()
    return first.startswith("#FREQUENCY") and "MHZ" in first


register_format(BeamFormat("edges-table", _sniff_edges, lambda paths: read_edges_table(paths[0]),
                           description="EDGES-format FEKO gain table (#FREQUENCY blocks, 360 x 91, dB)"))
register_format(BeamFormat("feko-ffe", _sniff_ffe, read_ffe_set, multi_file=True,
                           description="FEKO .ffe far field; azimuth-quadrant files are stitched"))
