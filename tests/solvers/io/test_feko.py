"""Every loader on real (or vendor-layout) samples, and malformed variants of each."""

import numpy as np
import pytest

from groundplane.beam import BeamFormatError
from solvers import detect_format, load_beam
from tests.conftest import quadrant_paths, shared_file


def test_feko_quadrants_stitch_into_one_beam():
    beam = load_beam(quadrant_paths())
    assert beam.shape == (1, 181, 360)
    assert beam.freqs_mhz.tolist() == [40.0]
    assert beam.phi_deg[0] == 0 and beam.phi_deg[-1] == 359
    # the FEKO model has its dipole along y; the loader turns phi = 0 onto the excitation axis
    assert beam.meta["phi_rotation_deg"] == 90.0
    assert beam.beam_width_3db(40, 0) < beam.beam_width_3db(40, 90)  # E-plane narrower
    assert 10 * np.log10(beam.gain[0, 0, 0]) == pytest.approx(8.555, abs=0.01)  # zenith gain in the file

def test_single_ffe_quadrant_is_incomplete_grid_but_loads():
    b = load_beam(quadrant_paths()[0])
    assert b.phi_deg.tolist() == list(range(91))

def test_ffe_quadrants_with_disagreeing_overlap(tmp_path):
    paths = quadrant_paths()
    text = paths[1].read_text().splitlines()
    # the 91-180 quadrant, relabelled to start at phi 90 where it overlaps quadrant 0-90
    bad = []
    for line in text:
        parts = line.split()
        if parts and not line.startswith("#") and float(parts[1]) == 91.0:  # add a phi 90 cut 3 dB off
            parts[1] = "9.00000000E+01"
            parts[-1] = str(float(parts[-1]) + 3.0)
            bad.append("  ".join(parts))
        bad.append(line)
    p = tmp_path / "q2.ffe"
    p.write_text("\n".join(bad).replace("#No. of Phi Samples: 90", "#No. of Phi Samples: 91"))
    with pytest.raises(BeamFormatError, match="listed 2 times"):
        load_beam([paths[0], p])

def test_truncated_ffe_names_file_and_rows(tmp_path):
    src = quadrant_paths()[0].read_text().splitlines()
    p = tmp_path / "trunc.ffe"
    p.write_text("\n".join(src[:5000]))
    with pytest.raises(BeamFormatError, match=r"trunc\.ffe.*expected 181 theta x 91 phi"):
        load_beam(p)

def test_ffe_nan_and_garbage(tmp_path):
    src = quadrant_paths()[0].read_text().splitlines()
    for bad, msg in (("nan", "non-finite"), ("x1.0", "not a number")):
        lines = list(src)
        parts = lines[20].split()
        parts[-1] = bad
        lines[20] = "  ".join(parts)
        p = tmp_path / f"bad_{msg[:3]}.ffe"
        p.write_text("\n".join(lines))
        with pytest.raises(BeamFormatError, match=msg):
            load_beam(p)
    lines = list(src)
    lines[30] = lines[30] + " 1.0"
    p = tmp_path / "cols.ffe"
    p.write_text("\n".join(lines))
    with pytest.raises(BeamFormatError, match=r"cols\.ffe:31: expected 9 numbers, found 10"):
        load_beam(p)

def test_edges_table():
    p = shared_file("edges_highband_feko_gain_db.txt")
    assert detect_format(p) == "edges-table"
    beam = load_beam(p)
    assert beam.shape == (25, 91, 360)
    assert beam.freqs_mhz[0] == 80 and beam.freqs_mhz[-1] == 200
    assert beam.theta_deg[0] == 0 and beam.theta_deg[-1] == 90
    # zenith = elevation 90 = last column of the file (8.184 dB at 80 MHz, az 0)
    assert 10 * np.log10(beam.gain[0, 0, 0]) == pytest.approx(8.184, abs=1e-3)
    assert beam.beam_width_3db(150, 0) == pytest.approx(74.0, abs=1.0)  # E-plane
    assert beam.beam_width_3db(150, 90) == pytest.approx(111.5, abs=1.0)  # H-plane

def test_edges_table_malformed(tmp_path):
    lines = shared_file("edges_highband_feko_gain_db.txt").read_text().splitlines()
    p = tmp_path / "short.txt"
    p.write_text("\n".join(lines[:300]))  # first block cut at 298 rows
    with pytest.raises(BeamFormatError, match="298 azimuth rows, expected 360"):
        load_beam(p)
    bad = list(lines[:362])
    bad[50] = bad[50].rsplit(" ", 1)[0]
    p.write_text("\n".join(bad))
    with pytest.raises(BeamFormatError, match=r"short\.txt:51: expected 92 numbers, found 91"):
        load_beam(p)
    bad = list(lines[:362])
    bad[40] = bad[40].replace("-60.000", "nan", 1)
    p.write_text("\n".join(bad))
    with pytest.raises(BeamFormatError, match="not finite"):
        load_beam(p)

def test_one_quadrant_cannot_be_scored():
    from groundplane.fom import figure_of_merit

    with pytest.raises(ValueError, match="full circle"):
        figure_of_merit(load_beam(quadrant_paths()[0]))



def test_edges_table_units_and_azimuth_numbers_are_checked_with_their_line(tmp_path):
    """'#FREQUENCY 80000000 MHz' (Hz written under MHz) and an azimuth row numbered nan or inf
    were accepted or crashed; each is refused naming its line."""
    lines = shared_file("edges_highband_feko_gain_db.txt").read_text().splitlines()
    p = tmp_path / "t.txt"
    head = next(i for i, ln in enumerate(lines) if ln.upper().startswith("#FREQUENCY"))
    bad = list(lines[:362])
    bad[head] = "#FREQUENCY 80000000 MHz"
    p.write_text("\n".join(bad))
    with pytest.raises(BeamFormatError, match=rf"t\.txt:{head + 1}: implausible frequency 8e\+07 MHz"):
        load_beam(p)
    row = next(i for i, ln in enumerate(lines) if ln.startswith("az"))
    for token in ("nan", "inf", "1.5"):
        bad = list(lines[:362])
        parts = bad[row].split()
        bad[row] = " ".join([parts[0], token, *parts[2:]])
        p.write_text("\n".join(bad))
        with pytest.raises(BeamFormatError, match=rf"t\.txt:{row + 1}: azimuth row number"):
            load_beam(p)
