"""Every loader on real (or vendor-layout) samples, and malformed variants of each."""

import numpy as np
import pytest

from groundplane.beam import BeamFormatError
from solvers import detect_format, load_beam
from tests.conftest import DATA


def test_hfss_csv_folds_negative_theta():
    p = DATA / "hfss_gain.csv"
    assert detect_format(p) == "hfss"
    beam = load_beam(p)
    assert beam.freqs_mhz.tolist() == [50.0, 75.0]
    assert beam.phi_deg.tolist() == list(np.arange(0, 360, 30.0))
    cst = load_beam(sorted(DATA.glob("cst_farfield*.txt")))
    assert np.allclose(beam.gain, cst.gain, rtol=1e-4)

def test_hfss_malformed(tmp_path):
    lines = (DATA / "hfss_gain.csv").read_text().splitlines()
    p = tmp_path / "h.csv"
    p.write_text("\n".join([lines[0].replace("dB(GainTotal)", "dB(Something)")] + lines[1:]))
    with pytest.raises(BeamFormatError, match="no gain column"):
        load_beam(p)
    bad = list(lines)
    bad[7] = "50,0,-90"
    p.write_text("\n".join(bad))
    with pytest.raises(BeamFormatError, match=r"h\.csv:8: expected 4 fields"):
        load_beam(p)
    p.write_text("\n".join(lines[:90]))
    with pytest.raises(BeamFormatError, match="incomplete angular grid"):
        load_beam(p)
    p.write_text("\n".join(lines[:200]))
    with pytest.raises(BeamFormatError, match="grid at 75 MHz .* differs from the one at 50 MHz"):
        load_beam(p)

