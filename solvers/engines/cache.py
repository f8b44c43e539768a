"""Content-addressed beam cache: a solved candidate is never solved twice.

``<cache>/beams/<key>.npz`` holds finished beams; ``<cache>/partial/<key>/<freq>.npz``
holds each frequency as it completes, so an interrupted solve resumes where it stopped.
Every write is a temp file + rename, so a crash leaves at most a stray temp file, which
is never read. An entry that does not read back (truncated, damaged, or stored under
another key) is deleted and recomputed, never trusted.
"""
from __future__ import annotations

import shutil
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import numpy as np

from groundplane.beam import Beam, BeamFormatError
from groundplane.errors import OutputError, UserInputError
from groundplane.files import atomic_path, warn_once
from groundplane.sky import cache_dir

TMP_SUFFIX = ".tmp.npz"


class BeamCache:
    """Finished beams and per-frequency partial results, keyed by a solver's cache key."""

    def __init__(self, root: str | Path | None = None) -> None:
        self.root = Path(root) if root else cache_dir()
        try:
            (self.root / "beams").mkdir(parents=True, exist_ok=True)
            (self.root / "partial").mkdir(parents=True, exist_ok=True)
        except OSError as exc:  # a read-only or impossible cache: solve anyway, keep nothing (said once)
            warn_once("beam-cache", f"the beam cache {self.root} cannot be written ({exc.strerror or exc}); results "
                                    "are not kept for reuse (set GROUNDPLANE_CACHE to a writable folder)")

    def path(self, key: str) -> Path:
        return self.root / "beams" / f"{key}.npz"

    def get(self, key: str) -> Beam | None:
        """The finished beam of ``key``, or None: a damaged or foreign entry, or one whose gain does
        not match the checksum written with it (or has none), is deleted (and solved again)."""
        p = self.path(key)
        if not p.exists():
            return None
        try:
            beam = Beam.load(p)
        except BeamFormatError:
            beam = None
        said = beam.meta.get("gain_sha256") if beam is not None else None
        if beam is None or beam.meta.get("cache_key") != key or said != gain_checksum(beam.gain):
            if beam is not None:  # an entry without its checksum is never adopted, however plausible
                warn_once(f"checksum {key}", f"{p}: its gain does not match the checksum written with it (or it has "
                                             "none); solving it again")
            p.unlink(missing_ok=True)
            return None
        return beam

    def put(self, key: str, beam: Beam) -> Path:
        """Store a finished beam (its meta must carry ``cache_key``) with its gain's checksum, and
        drop its partials."""
        if beam.meta.get("cache_key") != key or beam.meta.get("gain_sha256") != gain_checksum(beam.gain):
            beam = beam.with_meta(cache_key=key, gain_sha256=gain_checksum(beam.gain))
        try:
            p = beam.save(self.path(key))
        except (OutputError, UserInputError) as exc:  # the result is still returned; only the reuse is lost
            warn_once("beam-cache", f"the beam cache cannot be written ({exc}); results are not kept for reuse")
            return self.path(key)
        shutil.rmtree(self.root / "partial" / key, ignore_errors=True)
        return p

    @contextmanager
    def lock(self, key: str, label: str = "") -> Iterator[None]:
        """Hold ``key`` for one solve at a time: a second process asking for the same design
        waits for the first, then reads its beam from the cache instead of solving it again.
        Holding it, stray temp files of this key (a write interrupted by a kill) are removed.
        An advisory ``flock`` (POSIX; the lock goes with its process, even on ``kill -9``)."""
        import fcntl

        try:
            (self.root / "locks").mkdir(parents=True, exist_ok=True)
            fh = open(self.root / "locks" / f"{key}.lock", "a")
        except OSError:  # a cache we cannot write: no lock, and nothing of ours to clean either
            yield
            return
        with fh:
            try:
                fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                print(f"{label or key}: another process is solving this design; waiting for it", file=sys.stderr)
                fcntl.flock(fh, fcntl.LOCK_EX)
            for stray in [*(self.root / "beams").glob(f"{key}.npz.*{TMP_SUFFIX}"),
                          *(self.root / "partial" / key).glob(f"*{TMP_SUFFIX}")]:
                stray.unlink(missing_ok=True)
            try:
                yield
            finally:
                fcntl.flock(fh, fcntl.LOCK_UN)

    def partial(self, key: str) -> dict[float, tuple[np.ndarray, float, dict[str, float]]]:
        """Frequencies already solved for ``key``: {freq: (gain, seconds, extras)}."""
        out: dict[float, tuple[np.ndarray, float, dict[str, float]]] = {}
        d = self.root / "partial" / key
        if not d.is_dir():
            return out
        for f in d.glob("*.npz"):
            if f.name.endswith(TMP_SUFFIX):
                f.unlink(missing_ok=True)  # a write interrupted by a kill: never complete
                continue
            try:
                with np.load(f, allow_pickle=False) as z:
                    extras = {k: float(z[k]) for k in z.files if k not in ("freq", "gain", "seconds", "gain_sha256")}
                    gain = np.array(z["gain"], dtype=float)
                    said = str(z["gain_sha256"]) if "gain_sha256" in z.files else None
                    if not np.all(np.isfinite(gain)) or (said is not None and said != gain_checksum(gain)):
                        raise ValueError("not the gain that was written")
                    out[float(z["freq"])] = (gain, float(z["seconds"]), extras)
            except Exception:  # noqa: BLE001 - any damage: recompute that frequency
                warn_once(f"partial {key}", f"{d}: a stored frequency is damaged or altered; solving it again")
                f.unlink(missing_ok=True)
        shapes = [v[0].shape for v in out.values()]
        if len(set(shapes)) > 1:  # one of another shape (another model's, or damaged): keep the most common
            common = max(set(shapes), key=shapes.count)
            for freq in [k for k, v in out.items() if v[0].shape != common]:
                del out[freq]
                (d / f"{freq:.6f}.npz").unlink(missing_ok=True)
        return out

    def put_partial(self, key: str, freq: float, gain: np.ndarray, seconds: float, **extras: float) -> None:
        """Store one solved frequency (atomically)."""
        try:
            with atomic_path(self.root / "partial" / key / f"{freq:.6f}.npz", suffix=TMP_SUFFIX) as tmp:
                np.savez(tmp, freq=freq, gain=gain, seconds=seconds, gain_sha256=gain_checksum(gain), **extras)
        except (OutputError, UserInputError) as exc:  # the solve goes on; an interruption then loses more
            warn_once("beam-cache", f"the beam cache cannot be written ({exc}); results are not kept for reuse")


def gain_checksum(gain: np.ndarray) -> str:
    """sha256 of a gain array's float64 bytes: what a cache entry is checked against on reading."""
    import hashlib

    return hashlib.sha256(np.ascontiguousarray(gain, dtype=float).tobytes()).hexdigest()
