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
    with pytest.raises(BeamFormatError, match="incomplete angular grid|uneven phi grid"):
        load_beam(p)
    p.write_text("\n".join(lines[:200]))
    with pytest.raises(BeamFormatError, match="grid at 75 MHz .* differs from the one at 50 MHz|75 MHz: uneven phi grid"):
        load_beam(p)



def test_implausible_frequency_units_and_missing_cuts_are_refused(tmp_path):
    lines = (DATA / "hfss_gain.csv").read_text().splitlines()
    p = tmp_path / "h.csv"
    p.write_text("\n".join([lines[0].replace("Freq [MHz]", "Freq [Hz]")] + lines[1:]))  # mislabelled unit
    with pytest.raises(BeamFormatError, match=r"h\.csv.*implausible frequency 5e-05 MHz"):
        load_beam(p)
    # drop the phi = 60 deg cut: not a coarser grid, a missing cut
    p.write_text("\n".join([lines[0]] + [l for l in lines[1:] if l.split(",")[1] != "60"]))
    with pytest.raises(BeamFormatError, match=r"uneven phi grid: steps of 30 deg but 30 -> 90 deg"):
        load_beam(p)


def test_feko_frequency_in_mhz_instead_of_hz_names_the_line(tmp_path):
    from tests.conftest import quadrant_paths

    src = quadrant_paths()[0]
    p = tmp_path / "q.ffe"
    p.write_text(src.read_text().replace("#Frequency: 4.00000000E+07", "#Frequency: 40"))
    with pytest.raises(BeamFormatError, match=r"q\.ffe:4: implausible frequency 4e-05 MHz"):
        load_beam(p)


def test_a_ghz_column_holding_mhz_values_is_refused_with_its_line(tmp_path):
    """'Freq [GHz]' over values written in MHz read as 50000-75000 MHz and were scored."""
    lines = (DATA / "hfss_gain.csv").read_text().splitlines()
    p = tmp_path / "h.csv"
    p.write_text("\n".join([lines[0].replace("Freq [MHz]", "Freq [GHz]")] + lines[1:]))
    with pytest.raises(BeamFormatError, match=r"h\.csv:2: implausible frequency 50000 MHz"):
        load_beam(p)
