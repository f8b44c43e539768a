"""The Figure of Merit: fast path vs an independent integration, and physics sanity checks."""

import numpy as np
import pytest

from groundplane.beam import Beam
from groundplane.fom import (
    Absorption,
    FomSettings,
    antenna_temperature,
    beam_correction_factor,
    figure_of_merit,
    fom_from_spectra,
    gain_derivative,
    gain_polynomial_residuals,
    linlog_design,
    sky_for,
)
from groundplane.reference import reference_antenna_temperature
from groundplane.sky import lst_grid
from tests.conftest import EXAMPLE_BEAM

HIGH = FomSettings(fit_band_mhz=(90.0, 190.0), lst_bin_hours=0.0)  # every LST: compared LST by LST



@pytest.fixture(scope="module")
def highband():
    return Beam.load(EXAMPLE_BEAM)

def test_fast_path_matches_brute_force(highband):
    fast = figure_of_merit(highband, HIGH)
    idx = np.arange(0, 360, 30)
    ref = reference_antenna_temperature(highband, HIGH, lst_grid(360)[idx])
    assert np.max(np.abs(ref / fast.t_ant[:, idx] - 1)) < 0.005
    ref_fom = fom_from_spectra(highband.freqs_mhz, ref, HIGH)
    assert abs(ref_fom.fom.mean() / fast.fom[idx].mean() - 1) < 0.005
    assert np.max(np.abs(ref_fom.fom / fast.fom[idx] - 1)) < 0.02

def test_fast_path_matches_brute_force_normalised_with_cmb(highband):
    s = FomSettings(fit_band_mhz=(90.0, 190.0), normalise=True, subtract_cmb=True)
    idx = np.array([0, 90, 270])
    fast = antenna_temperature(highband, s)[:, idx]
    ref = reference_antenna_temperature(highband, s, lst_grid(360)[idx])
    assert np.max(np.abs(ref / fast - 1)) < 0.005

def test_uniform_beam_sees_mean_visible_sky():
    import astropy.units as u
    import healpy as hp
    from astropy.coordinates import AltAz, SkyCoord

    from groundplane.sky import MRO, load_sky_map, location, lst_times

    theta, phi = np.arange(91.0), np.arange(360.0)
    freqs = np.array([50.0, 75.0, 100.0])
    beam = Beam(freqs, theta, phi, np.ones((3, 91, 360)))
    s = FomSettings()
    t = antenna_temperature(beam, s)
    tn = antenna_temperature(beam, FomSettings(normalise=True))
    sky = load_sky_map()
    l, b = hp.pix2ang(hp.npix2nside(sky.size), np.arange(sky.size), lonlat=True)
    for k in (0, 135, 270):
        tt = lst_times(np.array([float(k)]), MRO)[0]
        alt = SkyCoord(l=l * u.deg, b=b * u.deg, frame="galactic").transform_to(
            AltAz(obstime=tt, location=location(MRO))).alt.deg
        mean_visible = sky[alt > 0].mean() * (75.0 / 408.0) ** -2.55
        assert tn[1, k] == pytest.approx(mean_visible, rel=0.003)
        assert t[1, k] == pytest.approx(mean_visible / 2, rel=0.003)  # G = 1 fills half of 4 pi

def test_achromatic_beam_has_zero_fom(highband):
    g = np.repeat(highband.gain[10:11], highband.freqs_mhz.size, axis=0)
    flat = Beam(highband.freqs_mhz, highband.theta_deg, highband.phi_deg, g)
    r = figure_of_merit(flat, HIGH)
    assert r.lst_averaged_mk < 1e-3
    # the real, chromatic beam is far above that
    assert figure_of_merit(highband, HIGH).lst_averaged_mk > 10

def test_linlog_absorbs_power_law_and_catches_a_bump():
    f = np.arange(55.0, 98.0)
    s = FomSettings(lst_bin_hours=0.0)  # one spectrum, no LSTs to bin
    pl = 3000 * (f / 75) ** -2.55 * (1 + 0.01 * np.log(f / 75))
    assert fom_from_spectra(f, pl[:, None], s).fom[0] < 1e-9
    bump = pl + 0.1 * np.exp(-0.5 * ((f - 78) / 3) ** 2)
    assert fom_from_spectra(f, bump[:, None], s).fom[0] > 0.01
    a = linlog_design(f, 75.0, 2.55, 5)
    assert a.shape == (f.size, 5)

def test_absorption_feature_shape_and_injection(highband):
    t21 = Absorption().temperature(np.array([78.0, 50.0]))
    assert t21[0] == pytest.approx(-0.5)
    assert abs(t21[1]) < 0.01
    f = np.arange(40.0, 101.0)
    s0 = FomSettings()
    g = np.ones((f.size, 91, 360))
    beam = Beam(f, np.arange(91.0), np.arange(360.0), g)
    base = figure_of_merit(beam, s0).lst_averaged_mk
    inj = figure_of_merit(beam, FomSettings(absorption=Absorption())).lst_averaged_mk
    assert base < 1e-3 and inj > 20  # a 500 mK trough leaves tens of mK after a 5-term fit

def test_beam_correction_with_same_model_removes_structure(highband):
    plain = figure_of_merit(highband, HIGH)
    corrected = figure_of_merit(highband, HIGH, correction_beam=highband)
    assert corrected.lst_averaged_mk < 1e-3 * plain.lst_averaged_mk
    b = beam_correction_factor(highband, HIGH, nu_ref_mhz=140.0)
    assert np.allclose(b[np.flatnonzero(highband.freqs_mhz == 140.0)[0]], 1.0)

def test_secondary_metrics(highband):
    res = gain_polynomial_residuals(highband, (90.0, 190.0))
    assert set(res) == {"zenith", "E45", "H45"}
    assert all(np.isfinite(v["peak_to_peak"]) for v in res.values())
    fm, el, d = gain_derivative(highband, 0.0)
    assert d.shape == (highband.freqs_mhz.size - 1, el.size)
    assert el[0] == 0.0 and el[-1] == 180.0

def test_fit_band_without_enough_frequencies_is_an_error(highband):
    with pytest.raises(ValueError, match="fit band"):
        figure_of_merit(highband, FomSettings())  # 55-97 MHz holds 4 of 80-200 MHz in 5 MHz steps

def test_sky_cache_reused_from_disk(highband, tmp_path, monkeypatch):
    from groundplane import sky

    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path))
    s = FomSettings(fit_band_mhz=(90.0, 190.0), n_lst=4, lst_bin_hours=0.0)
    hs = sky_for(highband, s)
    files = list(tmp_path.glob("horizon_sky_*.npy"))
    assert len(files) == 1
    sky._MEMORY.clear()
    again = sky_for(highband, s)
    assert np.array_equal(hs.t408, again.t408)

def test_frequency_smoothing_keeps_broadband_structure_and_removes_narrow_spikes():
    f = np.arange(40.0, 101.0)
    th, ph = np.arange(91.0), np.arange(0.0, 360.0, 10.0)
    broad = (1 + 0.1 * np.cos(2 * np.pi * (f - 40) / 20.0))[:, None, None] * np.cos(np.radians(th))[None, :, None] ** 2
    g = np.repeat(broad, ph.size, axis=2)
    smooth = Beam(f, th, ph, g).frequency_smoothed(12)
    assert np.abs(smooth.gain - g).max() < 2e-3 * g.max()  # a 20 MHz ripple survives
    spiked = g * (1 + 0.01 * (f == 73.0))[:, None, None]
    out = Beam(f, th, ph, spiked).frequency_smoothed(12)
    i = int(np.argmax(f == 73.0))
    assert np.abs(out.gain[i] - g[i]).max() < 0.3 * np.abs(spiked[i] - g[i]).max()  # the spike mostly goes
    assert out.meta["frequency_smoothed_degree"] == 12
    with pytest.raises(ValueError, match="smoothing degree"):
        Beam(f, th, ph, g).frequency_smoothed(61)



@pytest.mark.parametrize("damage", ["overwrite", "truncate", "empty", "no-checksum-garbage", "no-checksum-plausible"])
def test_damaged_sky_cache_is_recomputed_not_trusted(highband, tmp_path, monkeypatch, damage):
    """An overwritten horizon-sky cache once scored 7e30 mK: every kind of damage is caught
    (CRC-32 beside the entry, shape, plausible kelvins), the entry recomputed, the FoM right."""
    from groundplane import sky

    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path))
    sky._MEMORY.clear()
    s = FomSettings(fit_band_mhz=(90.0, 190.0), n_lst=4, lst_bin_hours=0.0)
    good = figure_of_merit(highband, s).lst_averaged_mk
    f = next(tmp_path.glob("horizon_sky_*.npy"))
    raw = f.read_bytes()
    if damage == "overwrite":  # same size, values replaced (header kept)
        f.write_bytes(raw[:128] + np.full((len(raw) - 128) // 4, 1e30, np.float32).tobytes())
    elif damage == "truncate":
        f.write_bytes(raw[: len(raw) // 2])
    elif damage == "empty":
        f.write_bytes(b"")
    elif damage == "no-checksum-plausible":  # the sky scaled x2, checksum gone: plausible kelvins, wrong
        np.save(f, 2 * np.load(f))
        f.with_suffix(".crc.json").unlink()
    else:  # garbage values and the checksum gone
        f.write_bytes(raw[:128] + np.full((len(raw) - 128) // 4, -5.0, np.float32).tobytes())
        f.with_suffix(".crc.json").unlink()
    sky._MEMORY.clear()
    assert figure_of_merit(highband, s).lst_averaged_mk == pytest.approx(good, rel=1e-9)


def test_narrow_band_rms_sees_resonances_not_broadband_chromaticity():
    from groundplane.fom import narrow_band_rms

    f = np.arange(40.0, 101.0)
    th, ph = np.arange(91.0), np.arange(0.0, 360.0, 10.0)
    ripple = (f / 75.0) ** -0.5 * (1 + 0.1 * np.cos(2 * np.pi * (f - 40) / 60.0))  # broadband chromaticity
    broad = ripple[:, None, None] * np.cos(np.radians(th))[None, :, None] ** 2
    g = np.repeat(broad, ph.size, axis=2) + 1e-3
    assert narrow_band_rms(Beam(f, th, ph, g)) < 1e-4
    spiky = g * (1 + 0.01 * np.isin(f, [61.0, 73.0, 88.0]))[:, None, None]
    assert narrow_band_rms(Beam(f, th, ph, spiky)) > 1e-3


def test_lst_bins_average_spectra_before_the_fit():
    """Binned FoM = the FoM of the bin-averaged spectra: a bump whose sign flips from one LST
    to the next averages out in a 2 h bin, a bump that stays does not."""
    f = np.arange(50.0, 101.0)
    smooth = 1000 * (f / 75) ** -2.55
    bump = 0.5 * np.exp(-0.5 * ((f - 70) / 3) ** 2)
    flip = np.where(np.arange(24) % 2, 1.0, -1.0)
    binned = FomSettings(n_lst=24, lst_bin_hours=2)
    t_flip = smooth[:, None] + bump[:, None] * flip[None, :]
    t_stay = smooth[:, None] + bump[:, None] * np.ones(24)[None, :]
    every = fom_from_spectra(f, t_flip, FomSettings(n_lst=24, lst_bin_hours=0.0))
    assert every.lst_averaged_mk > 50
    flip_binned = fom_from_spectra(f, t_flip, binned)
    assert flip_binned.fom.shape == (12,) and flip_binned.lst_averaged_mk < 1e-6
    assert np.allclose(flip_binned.lst_hours, np.arange(12) * 2 + 1)
    stay = fom_from_spectra(f, t_stay, binned)
    assert stay.lst_averaged_mk == pytest.approx(fom_from_spectra(f, t_stay, FomSettings(n_lst=24, lst_bin_hours=0.0)).lst_averaged_mk)


def test_lst_bins_must_tile_the_day_and_leave_old_identities_alone():
    with pytest.raises(Exception, match="lst-bin 7 h"):
        FomSettings(lst_bin_hours=7)
    with pytest.raises(Exception, match="must be >= 0"):
        FomSettings(lst_bin_hours=-2)
    with pytest.raises(Exception, match="100 LSTs"):
        FomSettings(n_lst=100, lst_bin_hours=2)
    assert FomSettings().lst_bin_hours == 2.0  # the default: the paper's 2 h bins (its section 6)
    assert FomSettings(lst_bin_hours=0).as_dict()["lst_bin_hours"] == 0  # every setting in the identity
    with pytest.raises(Exception, match="--lst-bin 0"):  # the message says how to score every LST instead
        FomSettings(n_lst=4)
    assert FomSettings(lst_bin_hours=2).as_dict()["lst_bin_hours"] == 2
    assert FomSettings(lst_bin_hours=2).lsts_per_bin == 30


def test_an_unbinned_result_rebins_without_a_new_sky_product():
    f = np.arange(50.0, 101.0)
    t = 1000 * (f / 75)[:, None] ** -2.55 + 0.5 * np.sin(np.arange(24))[None, :] * np.exp(-0.5 * ((f - 70) / 3) ** 2)[:, None]
    every = fom_from_spectra(f, t, FomSettings(n_lst=24, lst_bin_hours=0.0))
    direct = fom_from_spectra(f, t, FomSettings(n_lst=24, lst_bin_hours=4))
    rebinned = every.in_lst_bins(4)
    assert np.allclose(rebinned.fom, direct.fom) and np.allclose(rebinned.lst_hours, direct.lst_hours)
    with pytest.raises(Exception, match="already in 4 h"):
        rebinned.in_lst_bins(2)


@pytest.mark.parametrize("bad, match", [(dict(nu0_mhz=0.0), "--nu0 0"), (dict(nu0_mhz=-75.0), "--nu0 -75"),
                                        (dict(beta=1e6), "--beta 1e"), (dict(n_lst=1_000_000), "--n-lst 1000000")])
def test_impossible_fom_settings_are_refused_by_name(bad, match):
    """These once ended in LAPACK noise and a LinAlgError (beta, nu0) or ran silently (n_lst)."""
    with pytest.raises(Exception, match=match):
        FomSettings(lst_bin_hours=0.0, **bad)


def test_a_typo_d_frequency_step_is_refused_before_any_solve():
    from groundplane.options import parse_freqs

    with pytest.raises(Exception, match="not a band anyone solves"):
        parse_freqs("40:99000:1")
    assert len(parse_freqs("40:100:0.25")) == 241


def test_workers_are_capped_at_the_cores_and_say_so(capsys):
    import os

    from solvers.engines.workers import usable_workers

    cores = os.cpu_count() or 1
    assert usable_workers(50, 100) == cores and "--workers 50" in capsys.readouterr().err
    assert usable_workers(2, 1) == 1 and usable_workers(1, 10) == 1


def test_thin_or_gappy_spectra_are_refused_not_scored():
    """A beam with 61-89 MHz removed scored 83.1 mK, one sampled every 7 MHz 55.2 mK, for a
    239.5 mK beam: each is refused, naming the hole or the count; 2 MHz steps still score."""
    from groundplane.fom import fit_band_mask

    with pytest.raises(Exception, match="no frequency between 60 and 90 MHz"):
        fit_band_mask(np.r_[np.arange(40.0, 61.0), np.arange(90.0, 101.0)], (55.0, 97.0), 5)
    with pytest.raises(Exception, match="holds 6 .* needs at least 10"):
        fit_band_mask(np.arange(40.0, 101.0, 7.0), (55.0, 97.0), 5)
    with pytest.raises(Exception, match="55-97 MHz missing"):  # not '40-97': the band starts at 55
        fit_band_mask(np.array([40.0]), (55.0, 97.0), 5)
    assert fit_band_mask(np.arange(40.0, 101.0, 2.0), (55.0, 97.0), 5).sum() == 21
