"""Every loader on real (or vendor-layout) samples, and malformed variants of each."""

import numpy as np
import pytest

from groundplane.beam import Beam, BeamFormatError
from solvers import detect_format, load_beam


def test_npz_roundtrip_and_no_pickle(tmp_path):
    b = Beam([50.0, 60.0], np.arange(91.0), np.arange(0, 360, 10.0), np.ones((2, 91, 36)), {"solver": "test"})
    p = b.save(tmp_path / "b.npz")
    assert detect_format(p) == "npz"
    c = load_beam(p)
    assert np.array_equal(c.gain, b.gain) and c.meta["solver"] == "test"
    np.savez(tmp_path / "evil.npz", freqs_mhz=np.array([1.0]), theta_deg=np.array([0.0]),
             phi_deg=np.array([0.0]), gain=np.array([[[1.0]]]), meta=np.array([{"a": 1}], dtype=object))
    with pytest.raises(BeamFormatError, match="not a readable"):
        Beam.load(tmp_path / "evil.npz")
    np.savez(tmp_path / "partial.npz", freqs_mhz=np.array([1.0]))
    with pytest.raises(BeamFormatError, match="missing arrays"):
        Beam.load(tmp_path / "partial.npz")

