"""Every loader on real (or vendor-layout) samples, and malformed variants of each."""

import numpy as np
import pytest

from groundplane.beam import BeamFormatError
from solvers import detect_format, load_beam
from tests.conftest import DATA


def test_cst_files_make_multi_frequency_beam():
    paths = sorted(DATA.glob("cst_farfield*.txt"))
    assert {detect_format(p) for p in paths} == {"cst"}
    beam = load_beam(paths)
    assert beam.freqs_mhz.tolist() == [50.0, 75.0]
    assert beam.phi_deg.tolist() == list(np.arange(0, 360, 30.0))  # 360 folded onto 0
    assert 10 * np.log10(beam.gain[0, 0, 0]) == pytest.approx(6.735604, abs=1e-5)

def test_cst_malformed(tmp_path):
    src = sorted(DATA.glob("cst_farfield*.txt"))[0].read_text().splitlines()
    p = tmp_path / "farfield (f=60) [1].txt"
    p.write_text("\n".join(src[:-20]))
    with pytest.raises(BeamFormatError, match="incomplete angular grid"):
        load_beam(p)
    p2 = tmp_path / "nofreq.txt"
    p2.write_text("\n".join(src))
    with pytest.raises(BeamFormatError, match="do not record the frequency"):
        load_beam(p2)
    lines = list(src)
    lines[5] = lines[5][:30]
    p.write_text("\n".join(lines))
    with pytest.raises(BeamFormatError, match=r":6: expected 8 columns"):
        load_beam(p)

