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

from .errors import OutputError, UserInputError


def _no_duplicate_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    keys = [k for k, _ in pairs]
    if len(set(keys)) < len(keys):
        twice = sorted({k for k in keys if keys.count(k) > 1})
        raise ValueError(f"key(s) {', '.join(map(repr, twice))} given twice (JSON keeps the last in silence)")
    return dict(pairs)


def strict_json(text: str) -> Any:
    """``json.loads`` that refuses an object with a key twice (``"side": 10, "side": 20`` took the
    last in silence) with a ``ValueError``, as for any malformed JSON."""
    return json.loads(text, object_pairs_hook=_no_duplicate_keys)


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
        _remove_stale_temps(path, suffix)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".", suffix=suffix)
    except OSError as exc:
        raise UserInputError(f"{path}: cannot write here ({exc.strerror or exc})") from None
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except OSError as exc:  # a full disk, a folder gone read-only: the old file (if any) is untouched
        raise OutputError(f"{path}: could not be written ({exc.strerror or exc})") from exc
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


STALE_TEMP_S = 600.0  # a temp file of ours older than this is a write a kill -9 cut short


def _remove_stale_temps(path: Path, suffix: str) -> None:
    """Remove ``path``'s own temp files (``name.<random><suffix>``) that a killed write left behind,
    when older than STALE_TEMP_S (a write of the same file by another process now is left alone)."""
    import time

    now = time.time()
    for stray in path.parent.glob(f"{glob_escape(path.name)}.*{glob_escape(suffix)}"):
        try:
            if stray.is_file() and now - stray.stat().st_mtime > STALE_TEMP_S:
                stray.unlink()
        except OSError:
            pass


def glob_escape(text: str) -> str:
    """``text`` with glob's special characters taken literally."""
    import glob

    return glob.escape(text)


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


def check_output_dir(path: str | os.PathLike) -> Path:
    """Make (if needed) and probe an output folder before any work, and hold it as its one writer
    (:func:`hold_output_dir`): a command that would solve for minutes and then find it cannot write
    its results, or that another run is writing them, refuses at once instead."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise UserInputError(f"{path}: is a file; give a folder for the results")
    try:
        path.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=path, prefix=".write-probe.")
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise UserInputError(f"{path}: cannot write results here ({exc.strerror or exc})") from None
    hold_output_dir(path)
    return path


WRITER_LOCK = ".groundplane-writer.lock"
_HELD: dict[Path, Any] = {}  # folders this process writes: their open, flock'ed lock files


def hold_output_dir(path: str | os.PathLike) -> bool:
    """Take ``path`` as this process's to write, or refuse (:class:`UserInputError`) naming the run
    that holds it: two searches into one folder left 10 history rows for 5 evaluations. An advisory
    ``flock`` (it goes with its process, even on ``kill -9``: no stale lock to clear). True when
    taken here, False when this process held it already."""
    import fcntl
    import sys
    import time

    path = Path(path).resolve()
    if path in _HELD:
        return False
    try:
        fh = open(path / WRITER_LOCK, "a+")
    except OSError:  # a folder we cannot write a lock in: check_output_dir's probe says why
        return False
    try:
        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        fh.seek(0)
        holder = fh.read(500).strip() or "another process"
        fh.close()
        raise UserInputError(f"{path}: another run is writing here ({holder}); wait for it, or give another -o") from None
    fh.seek(0)
    fh.truncate()
    fh.write(f"pid {os.getpid()}, since {time.strftime('%Y-%m-%d %H:%M:%S')}: {' '.join(sys.argv)[:300]}\n")
    fh.flush()
    _HELD[path] = fh
    return True


def release_output_dir(path: str | os.PathLike | None = None) -> None:
    """Give up ``path`` (every held folder when None), as a command ends."""
    import fcntl

    for p in [Path(path).resolve()] if path is not None else list(_HELD):
        fh = _HELD.pop(p, None)
        if fh is not None:
            fcntl.flock(fh, fcntl.LOCK_UN)
            fh.close()


@contextmanager
def one_writer(path: str | os.PathLike) -> Iterator[Path]:
    """Hold ``path`` (made if needed) for the block, unless this process holds it already (a
    command's :func:`check_output_dir`): the library functions that write a folder use it."""
    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    taken = hold_output_dir(path)
    try:
        yield path
    finally:
        if taken:
            release_output_dir(path)


def warn_once(key: str, message: str) -> None:
    """Print a warning on stderr the first time ``key`` is seen in this process or its parents
    (worker processes inherit what was said through the environment: one warning, not one a
    worker)."""
    import sys

    said = set(filter(None, os.environ.get("GROUNDPLANE_WARNED", "").split("\x1f")))
    if key not in _WARNED and key not in said:
        _WARNED.add(key)
        os.environ["GROUNDPLANE_WARNED"] = "\x1f".join(said | {key})
        print(f"groundplane: warning: {message}", file=sys.stderr)


_WARNED: set[str] = set()


def append_jsonl(path: str | os.PathLike, row: dict[str, Any]) -> None:
    """Append one JSON line and fsync it. A line torn by an earlier kill is ended first,
    so it stays one unreadable line instead of swallowing this row."""
    path = Path(path)
    try:
        with open(path, "ab+") as fh:
            if fh.tell() > 0:
                fh.seek(-1, os.SEEK_END)
                if fh.read(1) != b"\n":
                    fh.write(b"\n")
            fh.write((json.dumps(row) + "\n").encode())
            fh.flush()
            os.fsync(fh.fileno())
    except OSError as exc:  # the rows before this one are whole: a rerun resumes after them
        raise OutputError(f"{path}: could not append ({exc.strerror or exc}); the rows before are kept") from exc


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


def write_csv(path: str | os.PathLike, rows: list[dict[str, Any]], fieldnames=None) -> None:
    """A table as CSV, replaced atomically (a rerun or a kill never leaves half a file);
    columns are ``fieldnames`` (default: the first row's keys), missing cells empty."""
    import csv

    with atomic_path(path, suffix=".tmp.csv") as tmp, open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(fieldnames or rows[0]), extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
