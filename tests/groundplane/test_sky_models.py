"""Other skies and sites: the tabulated GSM2008/LFSM maps, their interpolation in frequency,
the FoM on them against a brute-force integration, and the site table."""
import json

import numpy as np
import pytest

from groundplane.beam import Beam
from groundplane.cli import main
from groundplane.fom import FomSettings, antenna_temperature, figure_of_merit, linlog_design
from groundplane.reference import reference_antenna_temperature
from groundplane.sky import MODEL_NODES_MHZ, SITES, TabulatedSky, lst_grid, tabulated_sky
from tests.conftest import ROOT

LOWBAND = ROOT / "examples" / "lowband_square10_nec.npz"
FIT = np.arange(55.0, 98.0)


def linlog_rel_residual(freqs, spectra) -> np.ndarray:
    """rms residual of a 5-term LinLog fit over mean T, per column of ``spectra`` [f, n]."""
    a = linlog_design(freqs, 75.0, 2.55, 5)
    coef, *_ = np.linalg.lstsq(a, spectra, rcond=None)
    return np.sqrt(np.mean((spectra - a @ coef) ** 2, axis=0)) / spectra.mean(axis=0)


@pytest.mark.parametrize("name", ["gsm2008", "lfsm"])
def test_the_tabulated_maps_come_back_exactly(name):
    sky = tabulated_sky(name)
    got = sky.maps_at(MODEL_NODES_MHZ)
    assert np.allclose(got, np.exp(sky.log_maps), rtol=1e-12, atol=0)
    assert sky.nside == 64 and got.shape == (8, 12 * 64 ** 2)


def test_the_interpolation_adds_no_spectral_structure_of_its_own():
    """Curved power laws (ln T quadratic in ln nu, curvature as the sky's) sampled at the
    nodes come back between them smooth enough for a 5-term LinLog fit to leave < 1e-4 of T;
    linear interpolation in ln T - ln nu (kinks every 10 MHz) would not."""
    rng = np.random.default_rng(1)
    x = np.log(np.array(MODEL_NODES_MHZ) / 75.0)
    a, b, c = rng.uniform(7, 9, 200), rng.uniform(-2.7, -2.3, 200), rng.uniform(-0.3, 0.3, 200)
    log_maps = a + b * x[:, None] + c * x[:, None] ** 2
    sky = TabulatedSky("synthetic", np.array(MODEL_NODES_MHZ), log_maps)
    assert linlog_rel_residual(FIT, sky.maps_at(FIT)).max() < 1e-4
    kinked = np.exp(np.array([np.interp(np.log(FIT / 75.0), x, log_maps[:, p]) for p in range(200)]).T)
    assert linlog_rel_residual(FIT, kinked).max() > 1e-4


def test_gsm2008_between_its_maps_is_smooth_and_lfsm_carries_its_own_structure():
    """GSM2008 interpolated is LinLog-smooth to ~1e-6 of T in every pixel. The LFSM's tabulated
    maps themselves are not smooth (their spectral index steps between 10 MHz maps: its
    sigma(nu) is piecewise linear in ln nu in lsl), which a FoM on --sky lfsm includes."""
    gsm = tabulated_sky("gsm2008").maps_at(FIT)[:, ::7]
    assert linlog_rel_residual(FIT, gsm).max() < 1e-5
    lfsm = tabulated_sky("lfsm")
    steps = np.diff(lfsm.log_maps, axis=0) / np.diff(np.log(MODEL_NODES_MHZ))[:, None]
    assert np.median(np.abs(np.diff(steps[:5], axis=0))) > 0.02  # index jumps at its 50-80 MHz maps


def test_fom_on_a_model_sky_matches_brute_force():
    beam = Beam.load(LOWBAND)
    s = FomSettings(sky="gsm2008", n_lst=24, lst_bin_hours=0.0)
    idx = np.array([0, 9, 18])
    fast = antenna_temperature(beam, s)[:, idx]
    ref = reference_antenna_temperature(beam, s, lst_grid(24)[idx])
    assert np.max(np.abs(ref / fast - 1)) < 0.005
    haslam = antenna_temperature(beam, FomSettings(n_lst=24, lst_bin_hours=0.0))[:, idx]
    assert 0.6 < np.median(fast / haslam) < 1.4  # the same sky to tens of per cent, not the same numbers


def test_cli_scores_on_each_sky_and_refuses_bad_ones(capsys, tmp_path):
    foms = {}
    for sky in ("haslam", "gsm2008", "lfsm"):
        assert main(["fom", str(LOWBAND), "--sky", sky, "--n-lst", "24", "--json"]) == 0
        out = json.loads(capsys.readouterr().out)
        foms[sky] = out["lst_averaged_fom_mk"]
        assert out["settings"].get("sky", "haslam") == sky
    assert len(set(foms.values())) == 3 and all(v > 0 for v in foms.values())
    low = Beam.load(LOWBAND)
    Beam(low.freqs_mhz - 20, low.theta_deg, low.phi_deg, low.gain, low.meta).save(tmp_path / "low.npz")
    assert main(["fom", str(tmp_path / "low.npz"), "--sky", "gsm2008", "--fit-band", "35", "77"]) == 2
    assert "tabulated at 40-408 MHz only" in capsys.readouterr().err
    assert main(["fom", str(LOWBAND), "--sky", "gsm2008", "--subtract-cmb"]) == 2


def test_sites_move_the_sky_and_custom_coordinates_work(capsys):
    beam = Beam.load(LOWBAND)
    mro = figure_of_merit(beam, FomSettings(n_lst=24)).lst_averaged_mk
    karoo = figure_of_merit(beam, FomSettings(n_lst=24, site=SITES["KAROO"][0])).lst_averaged_mk
    assert karoo != mro
    s = FomSettings(lat_deg=-30.721526, lon_deg=21.428304)
    assert (s.site.lat_deg, s.site.lon_deg) == (SITES["KAROO"][0].lat_deg, SITES["KAROO"][0].lon_deg)
    assert s.as_dict()["lat_deg"] == s.lat_deg and FomSettings().as_dict()["sky"] == "haslam"  # all in the identity
    assert main(["fom", str(LOWBAND), "--site", "karoo", "--n-lst", "24", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["lst_averaged_fom_mk"] == pytest.approx(karoo)
    assert main(["fom", str(LOWBAND), "--lat", "95", "--lon", "0"]) == 2


def test_the_mros_coordinates_by_hand_are_the_default_site():
    beam = Beam.load(LOWBAND)
    from groundplane.sky import MRO

    default = figure_of_merit(beam, FomSettings(n_lst=24)).lst_averaged_mk
    by_hand = figure_of_merit(beam, FomSettings(n_lst=24, lat_deg=MRO.lat_deg, lon_deg=MRO.lon_deg))
    assert by_hand.lst_averaged_mk == default


def test_an_unknown_sky_is_one_line(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["fom", str(LOWBAND), "--sky", "nonsense"])
    err = capsys.readouterr().err.strip()
    assert exc.value.code == 2 and len(err.splitlines()) == 1 and "invalid choice: 'nonsense'" in err
