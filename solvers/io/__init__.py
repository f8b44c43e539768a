"""Beam files in: one reader module per vendor format, and the registry that dispatches
to them by content (never by file name).

A format is a :class:`BeamFormat` (a name, a ``sniff`` of the file's first bytes, a
``read`` of one or several files) given to :func:`register_format`; every module in this
package registers its formats when imported, and they are all imported here, so a new
format is one new module. ``groundplane fom --format`` offers whatever is registered.
"""
from __future__ import annotations

import importlib
import os
import pkgutil
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

from groundplane.beam import Beam
from groundplane.errors import BeamFormatError, UserInputError

__all__ = ["BeamFormat", "FORMATS", "register_format", "detect_format", "load_beam", "format_names"]

SNIFF_BYTES = 4096


@dataclass(frozen=True)
class BeamFormat:
    """A beam-file format.

    Parameters
    ----------
    name : str
        What ``--format`` calls it.
    sniff : callable
        ``sniff(head: bytes) -> bool``: does a file starting with these bytes look like this format?
    read : callable
        ``read(paths: list[Path]) -> Beam``: one beam from the files.
    multi_file : bool
        Whether several files can make one beam (azimuth quadrants, one file a frequency).
    description : str
        One line for ``--help`` and the README.
    """

    name: str
    sniff: Callable[[bytes], bool]
    read: Callable[[list[Path]], Beam]
    multi_file: bool = False
    description: str = ""


FORMATS: dict[str, BeamFormat] = {}
"""Registered formats, in sniffing order."""


def register_format(fmt: BeamFormat) -> BeamFormat:
    """Add (or replace) a format; returns it."""
    if not fmt.name or fmt.name == "auto":
        raise ValueError(f"a beam format needs a name other than 'auto', got {fmt.name!r}")
    FORMATS[fmt.name] = fmt
    return fmt


def format_names() -> list[str]:
    """'auto' and every registered format name (the ``--format`` choices)."""
    return ["auto", *FORMATS]


def head_lines(head: bytes, n: int = 20) -> list[str]:
    """The first ``n`` non-blank lines of a file's head, stripped (for text sniffers)."""
    return [line.strip() for line in head.decode("latin-1").splitlines() if line.strip()][:n]


MAX_BEAM_FILE_BYTES = 4 * 2**30  # the largest real export here is 7.5 MB; a 1-degree 61-frequency npz is 16 MB


def check_beam_file(path: Path) -> None:
    """Refuse, before reading a byte, what cannot be a beam file: nothing there, a folder, a
    device or pipe (``/dev/zero`` read as a beam grew to 7.6 GB), or a file larger than any beam."""
    import stat

    try:
        st = path.stat()
    except FileNotFoundError:
        raise UserInputError(f"{path}: no such beam file") from None
    except OSError as exc:
        raise UserInputError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if stat.S_ISDIR(st.st_mode):
        raise UserInputError(f"{path}: is a directory, not a beam file")
    if not stat.S_ISREG(st.st_mode):
        raise UserInputError(f"{path}: not a regular file (a device or a pipe); a beam is a file on disk")
    if st.st_size > MAX_BEAM_FILE_BYTES:
        raise BeamFormatError(f"{path}: {st.st_size / 2**30:.1f} GiB; no beam file is larger than "
                              f"{MAX_BEAM_FILE_BYTES / 2**30:g} GiB")


def detect_format(path: str | Path) -> str:
    """A beam file's format from its first bytes (not its name)."""
    path = Path(path)
    check_beam_file(path)
    with open(path, "rb") as fh:
        head = fh.read(SNIFF_BYTES)
    if not head:
        raise BeamFormatError(f"{path}: empty file (0 bytes): an export or a copy that did not finish?")
    for fmt in FORMATS.values():
        if fmt.sniff(head):
            return fmt.name
    first = "".join(c if c.isprintable() else "?" for c in (head_lines(head, 1) or [""])[0])
    raise BeamFormatError(
        f"{path}: unrecognised beam file (first line '{first[:60]}'); pass --format one of {', '.join(FORMATS)}"
    )


def load_beam(paths: str | os.PathLike | Sequence[str | os.PathLike], fmt: str = "auto") -> Beam:
    """One Beam from one file, or from several files of one format that together make one
    beam (FEKO azimuth quadrants, CST one file per frequency)."""
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    files = [Path(p) for p in paths]
    if not files:
        raise UserInputError("no beam file given")
    if fmt != "auto" and fmt not in FORMATS:
        raise UserInputError(f"unknown beam format '{fmt}'; choose one of {', '.join(format_names())}")
    for p in files:
        check_beam_file(p)
    kinds = [detect_format(p) if fmt == "auto" else fmt for p in files]
    if len(set(kinds)) > 1:
        raise BeamFormatError(f"the files mix formats: {dict(zip(map(str, files), kinds))}")
    spec = FORMATS[kinds[0]]
    if len(files) > 1 and not spec.multi_file:
        raise BeamFormatError(f"a {spec.name} beam is one file; got {len(files)}")
    return spec.read(files)


for _m in pkgutil.iter_modules(__path__):  # every format module registers itself
    if not _m.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_m.name}")
