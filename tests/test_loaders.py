"""Every loader on real (or vendor-layout) samples, and malformed variants of each."""
from pathlib import Path

import numpy as np
import pytest

from groundplane.beam import Beam, BeamFormatError
from solvers import detect_format, load_beam

from .conftest import shared_file

DATA = Path(__file__).parent / "data"
QUADRANTS = ["0-90", "91-180", "181-270", "271-360"]


def quadrant_paths():
    return [shared_file(f"feko_lowband_soil_40MHz_{q}.ffe") for q in QUADRANTS]


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
        if parts and not line.startswith("#") and float(parts[1]) == 91.0:
            parts[1] = "9.00000000E+01"
            parts[-1] = str(float(parts[-1]) + 3.0)
            line = "  ".join(parts)
        bad.append(line)
    p = tmp_path / "q2.ffe"
    p.write_text("\n".join(bad))
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


def test_beam_validation():
    with pytest.raises(BeamFormatError, match="shape"):
        Beam([50.0], np.arange(91.0), np.arange(360.0), np.ones((1, 90, 360)))
    with pytest.raises(BeamFormatError, match="360 = 0"):
        Beam([50.0], np.arange(91.0), np.arange(361.0), np.ones((1, 91, 361)))
    with pytest.raises(BeamFormatError, match="not finite"):
        g = np.ones((1, 91, 360))
        g[0, 3, 4] = np.nan
        Beam([50.0], np.arange(91.0), np.arange(360.0), g)


def test_unknown_format(tmp_path):
    p = tmp_path / "x.txt"
    p.write_text("hello\n")
    with pytest.raises(BeamFormatError, match="unrecognised beam file"):
        load_beam(p)


def test_solid_angle_weights_cover_hemisphere():
    b = Beam([50.0], np.arange(91.0), np.arange(360.0), np.ones((1, 91, 360)))
    assert b.solid_angle_weights().sum() == pytest.approx(2 * np.pi, rel=1e-12)


def test_one_quadrant_cannot_be_scored():
    from groundplane.fom import figure_of_merit

    with pytest.raises(ValueError, match="full circle"):
        figure_of_merit(load_beam(quadrant_paths()[0]))
