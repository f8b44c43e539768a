"""Load any supported beam file into a Beam, detecting the format from the content."""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

from groundplane.beam import Beam, BeamFormatError

FORMATS = ("auto", "feko-ffe", "edges-table", "cst", "hfss", "npz")


def detect_format(path: str | Path) -> str:
    """Guess a beam file's format from its first bytes (not its name)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such beam file")
    with open(path, "rb") as fh:
        head = fh.read(4096)
    if head[:2] == b"PK":
        return "npz"
    text = head.decode("latin-1")
    lines = [l.strip() for l in text.splitlines() if l.strip()]
    first = lines[0] if lines else ""
    if first.upper().startswith("#FREQUENCY") and "MHZ" in first.upper():
        return "edges-table"
    if any(l.startswith("##File Type") or l.startswith("#Request Name") or l.lower().startswith("#frequency:")
           for l in lines[:20]):
        return "feko-ffe"
    if first.startswith('"') and "theta" in first.lower() and "," in first:
        return "hfss"
    if first.lower().startswith("theta") and "[deg" in first.lower():
        return "cst"
    raise BeamFormatError(
        f"{path}: unrecognised beam file (first line '{first[:60]}'); pass --format one of {', '.join(FORMATS[1:])}"
    )


def load_beam(paths: str | Path | Sequence[str | Path], fmt: str = "auto") -> Beam:
    """One Beam from one file, or from several files of one format (FEKO azimuth quadrants,
    CST one-file-per-frequency) that together make one beam."""
    from . import cst, feko, hfss

    if isinstance(paths, (str, Path)):
        paths = [paths]
    paths = [Path(p) for p in paths]
    if not paths:
        raise ValueError("no beam file given")
    if fmt not in FORMATS:
        raise ValueError(f"unknown beam format '{fmt}'; choose one of {', '.join(FORMATS)}")
    fmts = [detect_format(p) if fmt == "auto" else fmt for p in paths]
    if len(set(fmts)) > 1:
        raise BeamFormatError(f"the files mix formats: {dict(zip(map(str, paths), fmts))}")
    kind = fmts[0]
    if kind == "feko-ffe":
        return feko.read_ffe_set(paths)
    if kind == "cst":
        return cst.read_cst_set(paths)
    if len(paths) > 1:
        raise BeamFormatError(f"a {kind} beam is one file; got {len(paths)}")
    if kind == "edges-table":
        return feko.read_edges_table(paths[0])
    if kind == "hfss":
        return hfss.read_hfss(paths[0])
    return Beam.load(paths[0])
