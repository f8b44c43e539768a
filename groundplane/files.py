"""Writing files so that a crash or ``kill -9`` loses nothing already written: atomic
replacement and fsync'd JSON-lines logs (written by hand: the standard library has the
pieces, not these two patterns)."""
from __future__ import annotations

import json
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator

from .errors import UserInputError


@contextmanager
def atomic_path(path: str | os.PathLike, suffix: str = ".tmp") -> Iterator[Path]:
    """Yield a temporary path beside ``path``; when the block succeeds it replaces
    ``path`` in one rename, otherwise it is deleted. ``suffix`` must keep any extension a
    writer insists on (``np.savez`` appends ``.npz`` otherwise)."""
    path = Path(path)
    if path.is_dir():
        raise UserInputError(f"{path}: is a directory; give a file name to write")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".", suffix=suffix)
    except OSError as exc:
        raise UserInputError(f"{path}: cannot write here ({exc.strerror or exc})") from None
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def check_output(path: str | os.PathLike) -> str:
    """Refuse, before any work, an output path that cannot be written (a directory, a
    folder without write permission); returns the note a command prints when it will
    replace an existing file (always atomically)."""
    path = Path(path)
    if path.is_dir():
        raise UserInputError(f"{path}: is a directory; give a file name to write")
    parent = path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not os.access(parent, os.W_OK | os.X_OK):
        raise UserInputError(f"{path}: cannot write here ({parent} is not writable)")
    return " (replaced the existing file atomically)" if path.exists() else ""


def append_jsonl(path: str | os.PathLike, row: dict[str, Any]) -> None:
    """Append one JSON line and fsync it. A line torn by an earlier kill is ended first,
    so it stays one unreadable line instead of swallowing this row."""
    path = Path(path)
    with open(path, "ab+") as fh:
        if fh.tell() > 0:
            fh.seek(-1, os.SEEK_END)
            if fh.read(1) != b"\n":
                fh.write(b"\n")
        fh.write((json.dumps(row) + "\n").encode())
        fh.flush()
        os.fsync(fh.fileno())


def read_jsonl(path: str | os.PathLike) -> list[dict[str, Any]]:
    """Every complete JSON-object line of ``path`` (none if it does not exist); lines torn
    by a kill are skipped: what they held is simply computed again."""
    path = Path(path)
    if not path.exists():
        return []
    rows = []
    with open(path, errors="replace") as fh:
        for line in fh:
            line = line.strip()
            if not line:
                continue
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue
            if isinstance(row, dict):
                rows.append(row)
    return rows
