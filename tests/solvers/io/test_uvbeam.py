"""Beams out to and back from pyuvdata's UVBeam (beamfits)."""
import numpy as np
import pytest

from groundplane.beam import Beam
from groundplane.cli import main
from solvers.io import detect_format, load_beam
from tests.conftest import ROOT

LOWBAND = ROOT / "examples" / "lowband_square10_nec.npz"


def test_npz_to_uvbeam_and_back_is_exact(tmp_path, capsys):
    fits, back = tmp_path / "beam.fits", tmp_path / "back.npz"
    assert main(["convert", str(LOWBAND), "-o", str(fits)]) == 0
    assert detect_format(fits) == "uvbeam"
    assert main(["convert", str(fits), "-o", str(back)]) == 0
    a, b = Beam.load(LOWBAND), Beam.load(back)
    assert np.array_equal(a.freqs_mhz, b.freqs_mhz) and np.array_equal(a.theta_deg, b.theta_deg)
    assert np.array_equal(a.phi_deg, b.phi_deg) and np.array_equal(a.gain, b.gain)
    assert {k: v for k, v in b.meta.items() if k in a.meta and k != "source"} == \
        {k: v for k, v in a.meta.items() if k != "source"}  # the provenance survives


def test_the_uvbeam_says_what_it_is(tmp_path):
    from pyuvdata import UVBeam

    main(["convert", str(LOWBAND), "-o", str(tmp_path / "b.fits")])
    uvb = UVBeam.from_file(str(tmp_path / "b.fits"))
    assert uvb.beam_type == "power" and uvb.pixel_coordinate_system == "az_za"
    assert uvb.data_normalization == "physical" and list(uvb.polarization_array) == [-5]  # xx
    assert np.allclose(uvb.freq_array, np.arange(40e6, 101e6, 1e6))
    assert "(az=phi:theexcitationaxisisthexaxis,East)" in "".join(uvb.history.split())
    # the FoM of the file read back is the original's
    assert main(["fom", str(tmp_path / "b.fits"), "--n-lst", "24"]) == 0


def test_a_damaged_uvbeam_is_one_clear_error(tmp_path):
    main(["convert", str(LOWBAND), "-o", str(tmp_path / "b.fits")])
    data = (tmp_path / "b.fits").read_bytes()
    (tmp_path / "cut.fits").write_bytes(data[: len(data) // 3])
    with pytest.raises(ValueError, match="cut.fits: not a readable UVBeam file"):
        load_beam(tmp_path / "cut.fits")
