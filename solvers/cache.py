"""Content-addressed beam cache: a solved candidate is never solved twice.

``<cache>/beams/<key>.npz`` holds finished beams; ``<cache>/partial/<key>/<freq>.npz``
holds each frequency as it completes, so an interrupted solve resumes where it stopped.
Every write is a temp file + rename: a crash leaves no corrupt entry; an unreadable entry
is treated as absent and recomputed.
"""
from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from groundplane.beam import Beam, BeamFormatError
from groundplane.sky import cache_dir


class BeamCache:
    def __init__(self, root: str | Path | None = None) -> None:
        self.root = Path(root) if root else cache_dir()
        (self.root / "beams").mkdir(parents=True, exist_ok=True)
        (self.root / "partial").mkdir(parents=True, exist_ok=True)

    def path(self, key: str) -> Path:
        return self.root / "beams" / f"{key}.npz"

    def get(self, key: str) -> Beam | None:
        p = self.path(key)
        if not p.exists():
            return None
        try:
            return Beam.load(p)
        except BeamFormatError:
            return None

    def put(self, key: str, beam: Beam) -> Path:
        p = beam.save(self.path(key))
        shutil.rmtree(self.root / "partial" / key, ignore_errors=True)
        return p

    def partial(self, key: str) -> dict[float, tuple[np.ndarray, float, float]]:
        """Frequencies already solved for ``key``: {freq: (gain, kappa, seconds)}."""
        out: dict[float, tuple[np.ndarray, float, float]] = {}
        d = self.root / "partial" / key
        if not d.is_dir():
            return out
        for f in d.glob("*.npz"):
            try:
                with np.load(f, allow_pickle=False) as z:
                    out[float(z["freq"])] = (np.array(z["gain"]), float(z["kappa"]), float(z["seconds"]))
            except (OSError, ValueError, KeyError):
                continue
        return out

    def put_partial(self, key: str, freq: float, gain: np.ndarray, kappa: float, seconds: float) -> None:
        d = self.root / "partial" / key
        d.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=d, suffix=".tmp.npz")
        os.close(fd)
        try:
            np.savez(tmp, freq=freq, gain=gain, kappa=kappa, seconds=seconds)
            os.replace(tmp, d / f"{freq:.6f}.npz")
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
