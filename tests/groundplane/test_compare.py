"""`groundplane compare` and `groundplane plot`: identities a comparison must keep, refusals,
and the figures written."""
import json

import numpy as np
import pytest

from groundplane.beam import Beam
from groundplane.cli import main
from groundplane.comparison import compare_beams, direction_differences, upper_hemisphere_efficiency
from tests.conftest import ROOT

LOWBAND = ROOT / "examples" / "lowband_square10_nec.npz"


@pytest.fixture(scope="module")
def lowband() -> Beam:
    return Beam.load(LOWBAND)


def _save(beam: Beam, path, gain=None, freqs=None) -> str:
    Beam(beam.freqs_mhz if freqs is None else freqs, beam.theta_deg, beam.phi_deg,
         beam.gain if gain is None else gain, beam.meta).save(path)
    return str(path)


def test_compare_a_beam_with_itself_is_zero_everywhere(capsys):
    assert main(["compare", str(LOWBAND), str(LOWBAND), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["freqs_mhz"] == list(np.arange(40.0, 101.0))
    (pair,) = out["pairs"]
    assert pair["rms_db"] == [0.0] * 61 and pair["max_db"] == [0.0] * 61 and pair["zenith_ratio"] == [1.0] * 61
    a, b = out["beams"]
    assert a["fom_mk"] == b["fom_mk"] and a["fom_binned_mk"] == b["fom_binned_mk"]
    for key in ("path", "fom_mk", "fom_binned_mk", "efficiency", "width_e_deg", "width_h_deg"):
        assert key in a
    assert len(a["fom_lst_mk"]) == 360 and len(a["fom_binned_lst_mk"]) == 12  # every 4 min and 2 h bins


def test_a_constant_gain_factor_is_its_db_and_scales_the_fom_exactly(lowband, tmp_path, capsys):
    """0.1 dB more gain everywhere: 0.1 dB rms at every frequency, and the FoM x 10^0.01 (the
    LinLog fit is linear in T_ant, so its residuals scale with a constant gain factor)."""
    scaled = _save(lowband, tmp_path / "scaled.npz", gain=lowband.gain * 10 ** 0.01)
    assert main(["compare", str(LOWBAND), scaled, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    (pair,) = out["pairs"]
    assert np.allclose(pair["rms_db"], 0.1, rtol=1e-9) and np.allclose(pair["zenith_ratio"], 10 ** 0.01, rtol=1e-12)
    a, b = out["beams"]
    assert b["fom_mk"] / a["fom_mk"] == pytest.approx(10 ** 0.01, rel=1e-9)
    assert b["fom_binned_mk"] / a["fom_binned_mk"] == pytest.approx(10 ** 0.01, rel=1e-9)
    assert np.allclose(np.array(b["efficiency"]) / a["efficiency"], 10 ** 0.01)


def test_a_local_change_shows_where_it_is(lowband):
    """1 dB more gain in one band of zenith angles above the cut, and a change below the cut
    that must not count: the rms is the band's share of the sky, the largest is 1 dB."""
    gain = lowband.gain.copy()
    band = (lowband.theta_deg >= 30) & (lowband.theta_deg <= 40)
    gain[:, band] *= 10 ** 0.1
    gain[:, lowband.theta_deg > 85] *= 100.0  # below 5 deg elevation: outside a 10 deg cut
    other = Beam(lowband.freqs_mhz, lowband.theta_deg, lowband.phi_deg, gain, {"source": "changed"})
    d = direction_differences(lowband, other, elevation_cut_deg=10.0)
    w = lowband.upper_hemisphere().solid_angle_weights()[:81]
    share = w[band[:81]].sum() / w.sum()
    assert np.allclose(d["max_db"], 1.0) and np.allclose(d["rms_db"], np.sqrt(share))
    assert np.allclose(d["zenith_ratio"], 1.0)


def test_grids_are_compared_on_the_directions_they_share(lowband, tmp_path):
    """A beam exported on a 2 deg grid against the same beam at 1 deg: nothing differs."""
    coarse = Beam(lowband.freqs_mhz, lowband.theta_deg[::2], lowband.phi_deg[::2], lowband.gain[:, ::2, ::2],
                  {"source": "coarse"})
    c = compare_beams([lowband, coarse], ["fine", "coarse"])
    assert c.theta_deg.size == 46 and c.phi_deg.size == 180
    assert np.all(c.pairs[0].rms_db == 0.0)
    assert c.beams[0].fom.lst_averaged_mk == c.beams[1].fom.lst_averaged_mk


def test_efficiency_of_an_isotropic_beam_is_half():
    iso = Beam([50.0], np.arange(0.0, 181.0), np.arange(0.0, 360.0), np.ones((1, 181, 360)))
    assert upper_hemisphere_efficiency(iso) == pytest.approx([0.5])


def test_beams_that_share_too_little_are_refused(lowband, tmp_path, capsys):
    far = _save(lowband, tmp_path / "far.npz", freqs=lowband.freqs_mhz + 200)
    assert main(["compare", str(LOWBAND), far]) == 2
    err = capsys.readouterr().err
    assert "share no frequency" in err and "lowband_square10_nec.npz (61 frequencies 40-100 MHz)" in err
    # overlapping only at 90-100 MHz: too few for the 55-97 MHz fit, said as such
    late = _save(lowband, tmp_path / "late.npz", freqs=lowband.freqs_mhz + 50)
    assert main(["compare", str(LOWBAND), late]) == 2
    assert "share 11 frequencies (90-100 MHz)" in capsys.readouterr().err
    assert main(["compare", str(LOWBAND)]) == 2
    assert "at least two" in capsys.readouterr().err


def test_compare_prints_tables_and_draws(tmp_path, capsys):
    png = tmp_path / "cmp.png"
    assert main(["compare", str(LOWBAND), str(LOWBAND), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "| beam | FoM every LST (mK) | FoM 2 h bins (mK)" in out and "| 75 |" in out
    assert png.stat().st_size > 20_000


def test_plot_writes_the_figure_and_one_file_per_panel(tmp_path, capsys):
    png = tmp_path / "b.png"
    assert main(["plot", str(LOWBAND), "-o", str(png)]) == 0
    assert png.stat().st_size > 50_000
    assert main(["plot", str(LOWBAND), str(LOWBAND), "-o", str(tmp_path / "p.svg"), "--panels"]) == 0
    for panel in ("cuts", "derivative", "poly3", "widths"):
        assert (tmp_path / f"p-{panel}.svg").stat().st_size > 10_000
    assert main(["plot", str(LOWBAND), "-o", str(tmp_path / "x.png"), "--freqs", "33"]) == 2
    assert "none of the beams holds 33 MHz" in capsys.readouterr().err
    assert main(["plot", str(LOWBAND), "-o", str(tmp_path / "noformat")]) == 2
