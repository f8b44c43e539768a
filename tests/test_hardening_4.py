"""The fourth hardening pass (issue 64): each of its sixteen reproductions gets a one-line error
or a correct answer. Numbers in the docstrings are what the reproduction gave before the fix."""
from __future__ import annotations

import numpy as np
import pytest

from groundplane.beam import Beam
from groundplane.cli import main
from tests.conftest import ROOT

EXAMPLE = ROOT / "examples" / "lowband_square10_nec.npz"


def _err(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    return err[-1] if err else ""


@pytest.fixture(scope="module")
def example() -> Beam:
    return Beam.load(EXAMPLE)


def _variant(tmp_path, example, keep=None, scale=1.0, name="b.npz"):
    k = np.ones(example.freqs_mhz.size, bool) if keep is None else keep(example.freqs_mhz)
    path = tmp_path / name
    sub = example.at_frequencies(np.flatnonzero(k))
    Beam(sub.freqs_mhz, sub.theta_deg, sub.phi_deg, sub.gain * scale, sub.meta).save(path)
    return str(path)


# 3 -------------------------------------------------------------------------------------------
def test_a_beam_cut_short_at_the_band_edge_is_refused_whatever_lies_outside(tmp_path, example, capsys):
    """Dropping 50-54 and 96-100 MHz scored 173.5 mK against 190.7: the 49 -> 55 MHz hole outside
    the band set the edge tolerance to 6 MHz, so a beam ending at 95 MHz passed as 55-97."""
    path = _variant(tmp_path, example, lambda f: ~(((f >= 50) & (f <= 54)) | (f >= 96)))
    assert main(["fom", path, "--n-lst", "24"]) == 2
    assert "95-97 MHz missing" in _err(capsys)


# 2 -------------------------------------------------------------------------------------------
@pytest.mark.parametrize("scale", [1e5, 1e-300, 3.0])
def test_a_gain_on_no_powers_scale_is_refused_by_fom_and_loss(tmp_path, example, capsys, scale):
    """The shipped beam x1e5 scored 19 067 271 mK and `loss` said -8 184 008 %; x1e-300 scored 0.00 mK."""
    path = _variant(tmp_path, example, scale=scale)
    assert main(["fom", path, "--n-lst", "24"]) == 2
    assert "integral over the upper hemisphere" in _err(capsys)
    assert main(["loss", path]) == 2
    assert "is it in dB, or scaled?" in _err(capsys)


def test_a_gain_scale_check_leaves_real_beams_and_normalised_scoring_alone(tmp_path, example):
    share = example.checked_share()
    assert 0.5 < share.min() and share.max() < 1.0  # NEC-2 over MRO soil: 18 % ground loss
    import groundplane as gp

    scaled = Beam.load(_variant(tmp_path, example, scale=1e5))
    assert gp.fom(scaled, n_lst=24, normalise=True).lst_averaged_mk == pytest.approx(
        gp.fom(example, n_lst=24, normalise=True).lst_averaged_mk, rel=1e-9)
