"""Every loader on real (or vendor-layout) samples, and malformed variants of each."""

import pytest

from groundplane.beam import BeamFormatError
from solvers import load_beam


def test_unknown_format(tmp_path):
    p = tmp_path / "x.txt"
    p.write_text("hello\n")
    with pytest.raises(BeamFormatError, match="unrecognised beam file"):
        load_beam(p)

