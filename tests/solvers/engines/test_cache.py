"""The beam cache after kills and damage: nothing half-written is ever read."""
import numpy as np

from groundplane.beam import Beam
from solvers.engines import BeamCache


def test_interrupted_and_damaged_partials_are_dropped_not_read(tmp_path):
    cache = BeamCache(tmp_path)
    key = "k" * 32
    cache.put_partial(key, 50.0, np.ones((91, 91)), 1.0, gain_calibration_kappa=0.9)
    d = tmp_path / "partial" / key
    (d / "tmpab12.tmp.npz").write_bytes(b"PK\x03\x04 half a zip")  # a kill -9 during a write
    good = d / "60.000000.npz"
    cache.put_partial(key, 60.0, np.ones((91, 91)), 1.0)
    good.write_bytes(good.read_bytes()[:100])  # truncated on disk
    got = cache.partial(key)
    assert set(got) == {50.0} and got[50.0][2] == {"gain_calibration_kappa": 0.9}
    assert sorted(p.name for p in d.iterdir()) == ["50.000000.npz"]  # the rest deleted, recomputed later


def test_damaged_or_foreign_beam_entries_are_deleted(tmp_path):
    cache = BeamCache(tmp_path)
    b = Beam([50.0], np.arange(91.0), np.arange(0.0, 360.0, 30.0), np.ones((1, 91, 12)))
    cache.put("a" * 32, b)
    assert cache.get("a" * 32) is not None
    cache.path("a" * 32).write_bytes(cache.path("a" * 32).read_bytes()[:200])
    assert cache.get("a" * 32) is None and not cache.path("a" * 32).exists()
    cache.put("b" * 32, b)
    cache.path("b" * 32).rename(cache.path("c" * 32))  # stored under another design's key
    assert cache.get("c" * 32) is None and not cache.path("c" * 32).exists()
