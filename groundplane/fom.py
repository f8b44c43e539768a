"""The chromaticity Figure of Merit of Mahesh et al. 2021 (SPEC section 3), and the
secondary chromaticity metrics of their section 2.3.

T_ant(nu, LST) = 1/(4 pi) * sum_pixels G(nu, pix) * T_sky(nu, pix, LST) * dOmega(pix)
is one matrix product ``gain[f, pix] @ (dOmega * T408)[pix, LST]`` scaled by the power
law; a 5-term LinLog model is fitted per LST by linear least squares, and the FoM is the
RMS of the residuals over the fit band, per LST and averaged over LST.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from . import paper
from .beam import Beam
from .design import EXCITATION_AZIMUTH_DEG
from .errors import BeamFormatError, SettingsError, UserInputError
from .options import option
from .sky import (
    MRO,
    SITES,
    SKY_MODELS,
    T_CMB_K,
    HorizonSky,
    Site,
    horizon_sky,
    horizon_weights,
    lst_grid,
    site_by_name,
    tabulated_sky,
)


@dataclass(frozen=True)
class Absorption:
    """Flattened-Gaussian absorption feature of Bowman et al. 2018 (added to the sky)."""

    nu0_mhz: float = 78.0
    tau: float = 7.0
    width_mhz: float = 18.0
    amplitude_k: float = 0.5

    def temperature(self, freqs_mhz: np.ndarray) -> np.ndarray:
        """T21(nu) in K (negative: an absorption)."""
        nu = np.asarray(freqs_mhz, dtype=float)
        b = 4 * (nu - self.nu0_mhz) ** 2 / self.width_mhz**2 * np.log(
            -1 / self.tau * np.log((1 + np.exp(-self.tau)) / 2)
        )
        return -self.amplitude_k * (1 - np.exp(-self.tau * np.exp(b))) / (1 - np.exp(-self.tau))


MIN_POINTS_PER_TERM = 2  # a 5-term fit on 6-7 points scored 55-92 mK for a 240 mK beam (and ranked first)
MAX_GAP_FRACTION = 1 / 8  # 55-97 MHz: 5.25 MHz; a beam with 61-89 MHz removed scored 83.1 mK for 239.5
MAX_LSTS = 1440  # every minute of LST: the horizon-sky product grows as LSTs x directions
MAX_BETA = 10.0  # sky spectral indices are 2-3; far outside, (nu/408)^-beta over- or underflows
MAX_GAIN = 1e6  # linear (60 dBi): a wide-beam antenna's gain is a few; above this the spectra overflow the fit
NU0_RANGE = 2.0  # nu0 within this factor of the fit band: 1e20 or 1e-300 MHz scored 554 and 2.8e6 mK, 1e308 LinAlgError


@dataclass(frozen=True)
class FomSettings:
    """Everything the FoM depends on besides the beam. Defaults are the paper's.

    >>> FomSettings().fit_band_mhz, FomSettings().n_terms, FomSettings().lst_bin_hours
    ((55.0, 97.0), 5, 2.0)
    """

    beta: float = option(paper.SKY_SPECTRAL_INDEX, "sky spectral index")
    fit_band_mhz: tuple[float, float] = option(paper.FIT_BAND_MHZ, "LinLog fit band (MHz)", flag="--fit-band",
                                               metavar=("LO", "HI"))
    nu0_mhz: float = option(paper.LINLOG_NU0_MHZ, "LinLog reference frequency (MHz)", flag="--nu0")
    n_terms: int = option(paper.LINLOG_TERMS, "LinLog terms", flag="--terms")
    antenna_azimuth_deg: float = option(EXCITATION_AZIMUTH_DEG, "excitation axis azimuth from North through East "
                                        "(deg)", flag="--antenna-azimuth", metavar="DEG")
    site: Site | None = option(None, f"observing site: {', '.join(SITES)} (or --lat and --lon; default MRO)",
                               parse=site_by_name, metavar="NAME")
    lat_deg: float | None = option(None, "site latitude (deg, geodetic), with --lon: a site not in --site's list",
                                   flag="--lat", metavar="DEG")
    lon_deg: float | None = option(None, "site east longitude (deg), with --lat", flag="--lon", metavar="DEG")
    sky: str = option("haslam", "sky model: haslam (the 408 MHz map scaled by (nu/408)^-beta, the paper's), gsm2008 "
                      "or lfsm (maps at 40-100 and 408 MHz, each pixel interpolated by a cubic spline in ln T - ln nu)",
                      choices=tuple(SKY_MODELS))
    n_lst: int = option(360, "LST bins over 24 h")
    lst_bin_hours: float = option(paper.DATA_LST_BIN_HOURS, "average the simulated spectra into LST bins this wide "
                                  "(h) before the fit, as drift-scan data are binned (the paper fits data binned in "
                                  "2 h of LST, its section 6); 0: every LST",
                                  flag="--lst-bin", metavar="HOURS")
    normalise: bool = option(False, "divide by the beam integral (EDGES pipeline) instead of 4 pi")
    subtract_cmb: bool = option(False, "remove 2.725 K from the map before scaling it")
    absorption: Absorption | None = option(None, "add the Bowman et al. 2018 absorption feature to the sky",
                                           switch=Absorption)

    def every_lst(self) -> "FomSettings":
        """These settings scoring every LST, unbinned (SPEC section 3's FoM; the paper's 2 h bins are
        the default).

        >>> FomSettings().every_lst().lst_bin_hours
        0.0
        """
        return replace(self, lst_bin_hours=0.0)

    def __post_init__(self) -> None:
        lo, hi = self.fit_band_mhz
        if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
            raise SettingsError(f"fit band must be 0 < lo < hi MHz, got {self.fit_band_mhz}")
        if self.n_terms < 1:
            raise SettingsError(f"n_terms must be >= 1, got {self.n_terms}")
        if not 1 <= self.n_lst <= MAX_LSTS:
            raise SettingsError(f"--n-lst {self.n_lst}: must be 1-{MAX_LSTS} (every minute of LST at most; the paper "
                                "scores 360, every 4 min)")
        if not (math.isfinite(self.nu0_mhz) and lo / NU0_RANGE <= self.nu0_mhz <= hi * NU0_RANGE):
            raise SettingsError(f"--nu0 {self.nu0_mhz:g}: the LinLog reference frequency must lie within a factor "
                                f"{NU0_RANGE:g} of the fit band ({lo / NU0_RANGE:g}-{hi * NU0_RANGE:g} MHz; the paper's "
                                f"75 MHz in 55-97): far from it ln(nu/nu0)^m is ill-conditioned and the fit meaningless")
        if not (math.isfinite(self.beta) and abs(self.beta) <= MAX_BETA):
            raise SettingsError(f"--beta {self.beta:g}: a sky spectral index is a few (the paper's 2.55); "
                                f"|beta| <= {MAX_BETA:g} is accepted")
        if not (math.isfinite(self.antenna_azimuth_deg) and abs(self.antenna_azimuth_deg) <= 360):
            raise SettingsError(f"--antenna-azimuth {self.antenna_azimuth_deg:g}: an azimuth is -360..360 deg "
                                "(1e308 was scored as if it were one)")
        if (self.lat_deg is None) != (self.lon_deg is None):
            raise SettingsError("--lat and --lon go together (a site is both)")
        if self.lat_deg is not None:
            if not (math.isfinite(self.lat_deg) and abs(self.lat_deg) <= 90 and math.isfinite(self.lon_deg)):
                raise SettingsError(f"--lat {self.lat_deg:g} --lon {self.lon_deg:g}: latitude must be -90..90 deg, "
                                    "longitude finite")
            if self.site is not None and (self.site.lat_deg, self.site.lon_deg) != (self.lat_deg, self.lon_deg):
                raise SettingsError(f"--site {self.site.name} and --lat {self.lat_deg:g} --lon {self.lon_deg:g} are two "
                                    "places: give the site's name or its coordinates, not both")
            object.__setattr__(self, "site", Site(f"lat {self.lat_deg:g} lon {self.lon_deg:g}", self.lat_deg,
                                                  self.lon_deg))
        elif self.site is None:
            object.__setattr__(self, "site", MRO)
        if self.sky != "haslam" and self.subtract_cmb:
            raise SettingsError(f"--subtract-cmb scales the Haslam map without its CMB; --sky {self.sky} gives "
                                "the sky at each frequency (CMB included) and is not scaled")
        if self.lst_bin_hours < 0:
            raise SettingsError(f"--lst-bin {self.lst_bin_hours:g} h must be >= 0 (0: no binning)")
        if self.lst_bin_hours:
            per_bin = self.lst_bin_hours * self.n_lst / 24.0
            if not (self.lst_bin_hours <= 24 and abs(per_bin - round(per_bin)) < 1e-9
                    and self.n_lst % round(per_bin) == 0):
                bins = 24.0 / self.lst_bin_hours
                hint = (f" (--n-lst {math.lcm(self.n_lst, round(bins))} holds whole bins of it)"
                        if abs(bins - round(bins)) < 1e-9 else "")
                raise SettingsError(f"--lst-bin {self.lst_bin_hours:g} h must hold a whole number of the "
                                    f"{self.n_lst} LSTs (every {24 / self.n_lst:g} h) and divide 24 h evenly{hint}; "
                                    "--lst-bin 0 scores every LST")

    @property
    def lsts_per_bin(self) -> int:
        """How many simulated LSTs one FoM bin averages (1: no binning)."""
        return round(self.lst_bin_hours * self.n_lst / 24.0) if self.lst_bin_hours else 1

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["fit_band_mhz"] = list(self.fit_band_mhz)
        return d


@dataclass
class FomResult:
    """FoM per LST (K) with the spectra it came from.

    >>> import groundplane as gp
    >>> r = gp.fom("examples/lowband_square10_nec.npz", n_lst=24)
    >>> r.fom_mk.shape, r.residuals.shape[0] == int(r.fit_mask.sum())
    ((12,), True)
    """

    freqs_mhz: np.ndarray  # all beam frequencies
    lst_hours: np.ndarray
    t_ant: np.ndarray  # [f, lst] K
    fit_mask: np.ndarray  # which freqs are in the fit band
    residuals: np.ndarray  # [f_fit, lst] K
    fom: np.ndarray  # [lst] K
    settings: FomSettings
    extra: dict[str, Any] = field(default_factory=dict)
    ground_loss: np.ndarray | None = None  # per beam frequency (groundplane.fom() fills it), None: undefined

    @property
    def lst_averaged_mk(self) -> float:
        """The FoM averaged over LST (bins), mK: the headline number."""
        return float(np.mean(self.fom) * 1e3)

    @property
    def fom_mk(self) -> np.ndarray:
        """The FoM per LST (bin), mK."""
        return self.fom * 1e3

    def in_lst_bins(self, hours: float) -> "FomResult":
        """The same spectra averaged into LST bins ``hours`` wide (no new sky product): one
        beam scored both every LST and binned."""
        if self.settings.lst_bin_hours:
            raise SettingsError(f"this FoM is already in {self.settings.lst_bin_hours:g} h LST bins")
        return fom_from_spectra(self.freqs_mhz, self.t_ant, replace(self.settings, lst_bin_hours=hours),
                                self.lst_hours)

    def as_json(self) -> dict[str, Any]:
        return {
            "lst_averaged_fom_mk": self.lst_averaged_mk,
            "fom_mk": (self.fom * 1e3).tolist(),
            "lst_hours": self.lst_hours.tolist(),
            "freqs_mhz": self.freqs_mhz.tolist(),
            "fit_freqs_mhz": self.freqs_mhz[self.fit_mask].tolist(),
            "settings": self.settings.as_dict(),
            **self.extra,
        }


# --------------------------------------------------------------------------- core
def _hemisphere(beam: Beam) -> tuple[Beam, np.ndarray]:
    hemi = beam.upper_hemisphere()
    src = beam.meta.get("source", "beam")
    if hemi.theta_deg.size < 2 or hemi.theta_deg[0] > 1e-6 or hemi.theta_deg[-1] < 90 - 1e-6:
        raise BeamFormatError(f"{src}: the beam must cover theta 0..90 deg to be scored")
    phi = hemi.phi_deg
    gaps = np.diff(np.concatenate([phi, [phi[0] + 360.0]]))
    if phi.size < 4 or gaps[-1] > 1.5 * np.max(gaps[:-1]):
        raise BeamFormatError(
            f"{src}: the beam covers azimuth {phi[0]:g}..{phi[-1]:g} deg only; a drift-scan FoM needs the "
            "full circle (for FEKO quadrant exports, give all the quadrant files together)"
        )
    return hemi, hemi.solid_angle_weights()


def sky_for(beam: Beam, settings: FomSettings, progress: bool = False) -> HorizonSky:
    """The horizon-frame sky on this beam's grid (cached)."""
    hemi, _ = _hemisphere(beam)
    return horizon_sky(
        hemi.theta_deg,
        hemi.phi_deg,
        lsts_deg=lst_grid(settings.n_lst),
        site=settings.site,
        antenna_azimuth_deg=settings.antenna_azimuth_deg,
        progress=progress,
    )


def beam_sky_products(beam: Beam, sky: HorizonSky) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sum G w T408 [f, lst], sum G w [f], sum w T408 [lst]) over the upper hemisphere."""
    hemi, w = _hemisphere(beam)
    g = hemi.gain.reshape(hemi.freqs_mhz.size, w.size)
    t = sky.matrix()  # [lst, pix]
    gw = g * w.reshape(1, -1)
    return gw @ t.T, gw.sum(axis=1), t @ w.ravel()


def model_sky_products(beam: Beam, settings: FomSettings, progress: bool = False,
                       at_mhz: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sum G w T_nu [f, lst], sum G w [f], LST hours) for a tabulated sky model: each
    frequency's map (or every frequency at ``at_mhz``) resampled at every LST."""
    hemi, w = _hemisphere(beam)
    model = tabulated_sky(settings.sky)
    maps = model.maps_at(beam.freqs_mhz if at_mhz is None else [at_mhz])  # refuses a band it lacks, before minutes
    hw = horizon_weights(hemi.theta_deg, hemi.phi_deg, lsts_deg=lst_grid(settings.n_lst), site=settings.site,
                         antenna_azimuth_deg=settings.antenna_azimuth_deg, nside=model.nside, progress=progress)
    gw = hemi.gain.reshape(hemi.freqs_mhz.size, -1) * w.reshape(1, -1)
    if at_mhz is not None:
        maps = np.repeat(maps, gw.shape[0], axis=0)
    return hw.products(gw, maps), gw.sum(axis=1), hw.lst_hours


def sky_products(beam: Beam, settings: FomSettings, progress: bool = False
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sum G w T [f, lst], sum G w [f], LST hours) on the settings' sky; for Haslam T is the
    408 MHz map (scaled per frequency afterwards), for a model the sky at each frequency."""
    if settings.sky == "haslam":
        sky = sky_for(beam, settings, progress=progress)
        gwt, gw, _ = beam_sky_products(beam, sky)
        return gwt, gw, sky.lst_hours
    return model_sky_products(beam, settings, progress)


def antenna_temperature(
    beam: Beam, settings: FomSettings = FomSettings(), sky: HorizonSky | None = None
) -> np.ndarray:
    """T_ant [f, lst] in K: the beam-weighted sky above the horizon (SPEC 3.4)."""
    if sky is not None or settings.sky == "haslam":
        gwt, gw, _ = beam_sky_products(beam, sky or sky_for(beam, settings))
    else:
        gwt, gw, _ = model_sky_products(beam, settings)
    return t_ant_from_products(beam.freqs_mhz, gwt, gw, settings)


def check_products(beam: Beam, gwt: np.ndarray, gw: np.ndarray) -> None:
    """Refuse a beam the FoM cannot score: a frequency whose gain integrates to zero (no beam
    there: every spectrum would be 0 and the FoM 0 mK), or gains so large the sky products
    overflow (a dB column read as linear?)."""
    src = beam.meta.get("source", "beam")
    bad = np.flatnonzero(~np.isfinite(gw) | ~np.all(np.isfinite(gwt), axis=1) | (beam.gain.max(axis=(1, 2)) > MAX_GAIN))
    if bad.size:
        raise BeamFormatError(f"{src}: its gain at {beam.freqs_mhz[bad[0]]:g} MHz (largest {beam.gain.max():.3g}) "
                              "overflows the sky integral; a linear power gain is a few at most (dB read as linear?)")
    zero = np.flatnonzero(gw <= 0)
    if zero.size:
        raise BeamFormatError(f"{src}: its gain is zero over the whole upper hemisphere at "
                              f"{beam.freqs_mhz[zero[0]]:g} MHz"
                              + (f" (and {zero.size - 1} more frequencies)" if zero.size > 1 else "")
                              + ": there is no beam to score there")


def t_ant_from_products(freqs, gwt, gw, settings: FomSettings) -> np.ndarray:
    """T_ant [f, lst] (K) from the sky products: the power law (or a model's maps), the CMB and the
    absorption feature as the settings say, over 4 pi (or the beam integral with ``normalise``)."""
    scale = (np.asarray(freqs) / 408.0) ** (-settings.beta)
    if settings.sky != "haslam":  # a model's maps are the sky at each frequency already
        t = gwt
    elif settings.subtract_cmb:
        # T_sky = (T408 - T_cmb) s(nu) + T_cmb
        t = scale[:, None] * (gwt - T_CMB_K * gw[:, None]) + T_CMB_K * gw[:, None]
    else:
        t = scale[:, None] * gwt
    if settings.absorption is not None:
        t = t + settings.absorption.temperature(freqs)[:, None] * gw[:, None]
    if settings.normalise:
        return t / gw[:, None]
    return t / (4 * np.pi)


def linlog_design(freqs_mhz: np.ndarray, nu0_mhz: float, beta: float, n_terms: int) -> np.ndarray:
    """LinLog basis [f, m] = (nu/nu0)^-beta * ln(nu/nu0)^m (SPEC 3.5)."""
    x = np.asarray(freqs_mhz, dtype=float) / nu0_mhz
    return x[:, None] ** (-beta) * np.log(x)[:, None] ** np.arange(n_terms)[None, :]


def fit_band_mask(freqs_mhz: np.ndarray, band: tuple[float, float], n_terms: int) -> np.ndarray:
    """Which frequencies lie in the fit band. A beam must cover the whole band (to within
    one of its own frequency steps): a beam cut short would be scored on part of the band
    and look less chromatic than it is."""
    lo, hi = band
    f = np.asarray(freqs_mhz, dtype=float)
    # the beam's own step where it is scored: a hole outside the band (40-49 then 55-95 MHz) must not
    # widen the tolerance at the band's edges (it let a beam cut at 95 MHz score as 55-97)
    near = np.sort(f[(f >= lo - 1e-9) & (f <= hi + 1e-9)])
    step = float(np.median(np.diff(near))) if near.size > 1 else (float(np.max(np.diff(f))) if f.size > 1 else 0.0)
    if f.size and (f.min() > lo + step + 1e-9 or f.max() < hi - step - 1e-9):
        missing = [f"{lo:g}-{min(f.min(), hi):g}" if f.min() > lo + step + 1e-9 else None,
                   f"{max(f.max(), lo):g}-{hi:g}" if f.max() < hi - step - 1e-9 else None]
        raise UserInputError(
            f"the beam covers {f.min():g}-{f.max():g} MHz but the fit band is {lo:g}-{hi:g} MHz: "
            f"{' and '.join(m for m in missing if m)} MHz missing (solve or export the whole band, or set --fit-band)"
        )
    mask = (f >= lo - 1e-9) & (f <= hi + 1e-9)
    need = MIN_POINTS_PER_TERM * n_terms
    if mask.sum() < need:
        raise UserInputError(
            f"fit band {lo:g}-{hi:g} MHz holds {int(mask.sum())} of the beam's frequencies "
            f"({freqs_mhz.min():g}-{freqs_mhz.max():g} MHz); a {n_terms}-term fit needs at least {need} "
            f"({MIN_POINTS_PER_TERM} per term): with fewer, the fit follows the beam's structure and hides it"
        )
    inside = f[mask]
    gaps = np.diff(np.concatenate([[lo], inside, [hi]]))  # from the band's edges: a hole at an end is a hole too
    widest = int(np.argmax(gaps))
    if gaps[widest] > MAX_GAP_FRACTION * (hi - lo) + 1e-9:
        a, b = np.concatenate([[lo], inside, [hi]])[widest:widest + 2]
        raise UserInputError(
            f"the beam has no frequency between {a:g} and {b:g} MHz, a gap of {gaps[widest]:g} MHz in the "
            f"{lo:g}-{hi:g} MHz fit band (at most {MAX_GAP_FRACTION * (hi - lo):g} MHz, 1/{round(1 / MAX_GAP_FRACTION)} "
            "of the band): a fit across a hole scores the beam as smoother than it is"
        )
    return mask


def linlog_residuals(freqs_mhz: np.ndarray, spectra: np.ndarray, settings: FomSettings) -> np.ndarray:
    """Residuals [f, n] of a LinLog least-squares fit to each column of ``spectra``."""
    a = linlog_design(freqs_mhz, settings.nu0_mhz, settings.beta, settings.n_terms)
    coef, *_ = np.linalg.lstsq(a, spectra, rcond=None)
    return spectra - a @ coef


def fom_from_spectra(
    freqs_mhz: np.ndarray, t_ant: np.ndarray, settings: FomSettings, lst_hours: np.ndarray | None = None
) -> FomResult:
    """FoM(LST) = RMS over the fit band of T_ant minus its LinLog fit (SPEC 3.6). With
    ``settings.lst_bin_hours`` the spectra are first averaged into LST bins from LST 0 h
    (as a drift scan's data are), and the FoM is per bin; ``t_ant`` and ``lst_hours`` of
    the result are then the binned spectra and the bin centres."""
    freqs_mhz = np.asarray(freqs_mhz, dtype=float)
    mask = fit_band_mask(freqs_mhz, settings.fit_band_mhz, settings.n_terms)
    if lst_hours is None:
        lst_hours = lst_grid(t_ant.shape[1]) / 15.0
    k = settings.lsts_per_bin
    if k > 1:
        if t_ant.shape[1] % k:
            raise SettingsError(f"{t_ant.shape[1]} LSTs do not split into bins of {k}")
        t_ant = t_ant.reshape(t_ant.shape[0], -1, k).mean(axis=2)
        lst_hours = np.asarray(lst_hours)[::k] + settings.lst_bin_hours / 2
    res = linlog_residuals(freqs_mhz[mask], t_ant[mask], settings)
    fom = np.sqrt(np.mean(res**2, axis=0))
    if not np.all(np.isfinite(fom)):  # the checks upstream should make this unreachable: never print "nan mK"
        raise SettingsError("the FoM is not finite for these spectra and settings (an overflow in the fit)")
    return FomResult(freqs_mhz, np.asarray(lst_hours), t_ant, mask, res, fom, settings)


def smoothing_matrix(freqs_mhz: np.ndarray, degree: int) -> np.ndarray:
    """[f, f]: the least-squares fit of a degree-``degree`` Chebyshev series over the band, as the
    linear map it is (what :meth:`Beam.frequency_smoothed` applies to each direction's G(nu)).
    The sky integral is linear in G, so the products of the smoothed beam are this matrix times
    the beam's: one sky convolution scores both."""
    f = np.asarray(freqs_mhz, dtype=float)
    x = (2 * f - f.min() - f.max()) / (f.max() - f.min())
    basis = np.polynomial.chebyshev.chebvander(x, degree)  # [f, degree + 1]
    return basis @ np.linalg.pinv(basis)


def figure_of_merit_check(beam: Beam, settings: FomSettings) -> None:
    """What refuses a beam before the sky is built: one it cannot cover (a FEKO quadrant) or fit."""
    _hemisphere(beam)
    if not settings.normalise:  # T_ant scales with the gain: one on no power's scale scores anything
        beam.checked_share()
    fit_band_mask(beam.freqs_mhz, settings.fit_band_mhz, settings.n_terms)


def figure_of_merit(
    beam: Beam,
    settings: FomSettings = FomSettings(),
    *,
    correction_beam: Beam | None = None,
    progress: bool = False,
) -> FomResult:
    """The FoM of a beam. With ``correction_beam`` the spectra are first divided by the
    beam-correction factor computed from that beam model (Mozdzen et al. 2019)."""
    figure_of_merit_check(beam, settings)
    gwt, gw, lst_hours = sky_products(beam, settings, progress)
    check_products(beam, gwt, gw)
    t_ant = t_ant_from_products(beam.freqs_mhz, gwt, gw, settings)
    extra: dict[str, Any] = {}
    if correction_beam is not None:
        b = beam_correction_factor(correction_beam, settings, freqs_mhz=beam.freqs_mhz)
        t_ant = t_ant / b
        extra["beam_corrected_with"] = correction_beam.meta.get("source", "beam")
    result = fom_from_spectra(beam.freqs_mhz, t_ant, settings, lst_hours)
    result.extra.update(extra)
    return result


# ---------------------------------------------------------------- secondary metrics
def beam_correction_factor(
    beam: Beam,
    settings: FomSettings = FomSettings(),
    nu_ref_mhz: float | None = None,
    freqs_mhz: np.ndarray | None = None,
) -> np.ndarray:
    """B(nu, LST) = int G(nu) T_sky(nu_ref) dOmega / int G(nu_ref) T_sky(nu_ref) dOmega.

    ``nu_ref`` (default: the beam frequency nearest the LinLog nu0, 75 MHz in the paper)
    must be one of the beam's frequencies; ``freqs_mhz`` (default: the beam's) must be
    too, so a correction computed from a model beam can be applied to another beam's spectra.
    """
    if nu_ref_mhz is None:
        nu_ref_mhz = float(beam.freqs_mhz[np.argmin(np.abs(beam.freqs_mhz - settings.nu0_mhz))])
    iref = _freq_index(beam, nu_ref_mhz)
    if settings.sky == "haslam":  # the 408 MHz map: its scale to nu_ref cancels in the ratio
        gwt, gw, _ = beam_sky_products(beam, sky_for(beam, settings))
    else:
        gwt, gw, _ = model_sky_products(beam, settings, at_mhz=nu_ref_mhz)
    check_products(beam, gwt, gw)  # a zero correction beam would divide by zero
    b = gwt / gwt[iref][None, :]
    if freqs_mhz is None:
        return b
    idx = [_freq_index(beam, f) for f in np.asarray(freqs_mhz)]
    return b[idx]


def _freq_index(beam: Beam, f: float) -> int:
    i = np.flatnonzero(np.isclose(beam.freqs_mhz, f, atol=1e-6))
    if i.size == 0:
        raise UserInputError(f"{f} MHz is not among the frequencies of {beam.meta.get('source', 'the beam')}")
    return int(i[0])


def gain_polynomial_residuals(
    beam: Beam, band_mhz: tuple[float, float] = (50.0, 100.0), n_terms: int = 3
) -> dict[str, dict[str, list[float]]]:
    """Residuals of an ``n_terms`` polynomial fit of G vs frequency at zenith and at 45 deg
    elevation in the E- (phi 0) and H- (phi 90) planes (paper section 2.3)."""
    mask = fit_band_mask(beam.freqs_mhz, band_mhz, n_terms)
    f = beam.freqs_mhz[mask]
    out: dict[str, dict[str, list[float]]] = {}
    for name, theta, phi in (("zenith", 0.0, 0.0), ("E45", 45.0, 0.0), ("H45", 45.0, 90.0)):
        g = beam.gain_at(theta, phi)[mask]
        coef = np.polyfit(f - f.mean(), g, n_terms - 1)
        r = g - np.polyval(coef, f - f.mean())
        out[name] = {"freqs_mhz": f.tolist(), "gain": g.tolist(), "residual": r.tolist(),
                     "peak_to_peak": float(np.ptp(r))}
    return out


def gain_derivative(beam: Beam, phi_deg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """dG/dnu (per MHz) across the vertical plane ``phi_deg``: elevation 0..180 deg runs
    from the horizon at phi through zenith (90) to the horizon at phi + 180, as in the
    paper's plots. Returns (frequency mid-points, elevation, dG/dnu [f-1, elevation])."""
    elev, g = vertical_plane(beam, phi_deg)
    deriv = np.diff(g, axis=0) / np.diff(beam.freqs_mhz)[:, None]
    return 0.5 * (beam.freqs_mhz[1:] + beam.freqs_mhz[:-1]), elev, deriv


def vertical_plane(beam: Beam, phi_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """(elevation 0..180 deg, gain [f, elevation]) across the vertical plane at ``phi_deg``:
    the horizon at phi, zenith at 90, the horizon at phi + 180 (the paper's axes)."""
    hemi = beam.upper_hemisphere()
    elev = np.concatenate([90.0 - hemi.theta_deg, 90.0 + hemi.theta_deg[1:]])
    g = np.concatenate([hemi.cut(phi_deg), hemi.cut(phi_deg + 180.0)[:, 1:]], axis=1)
    order = np.argsort(elev)
    return elev[order], g[:, order]


def narrow_band_rms(beam: Beam, degree: int = 12) -> float | None:
    """Narrow-band spectral structure of a beam: rms over the upper hemisphere of G minus
    its degree-``degree`` Chebyshev fit in frequency, over mean G (None when the beam has
    too few frequencies for that fit). Broadband chromaticity (a ~10 MHz period and slower)
    passes the fit; sub-MHz resonances of a model do not (values: results/plate_model.md)."""
    if beam.freqs_mhz.size < 2 * degree + 1:
        return None
    hemi = beam.upper_hemisphere()
    return float(np.std(hemi.gain - hemi.frequency_smoothed(degree).gain) / np.mean(hemi.gain))


def chromaticity_report(beam: Beam, settings: FomSettings = FomSettings()) -> dict[str, Any]:
    """The secondary metrics in one JSON-able dict."""
    band = (max(50.0, beam.freqs_mhz.min()), min(100.0, beam.freqs_mhz.max()))
    from .loss import largest_in_band, loss_or_note

    rep: dict[str, Any] = {}
    loss, note = loss_or_note(beam)
    rep["ground_loss"] = loss.tolist() if loss is not None else None
    if loss is not None:
        rep["max_ground_loss_fit_band"] = largest_in_band(beam.freqs_mhz, loss, settings.fit_band_mhz)
    else:
        rep["ground_loss_note"] = note
    if (nb := narrow_band_rms(beam)) is not None:
        rep["narrow_band_rms"] = nb
    try:
        rep["gain_poly3_residuals"] = gain_polynomial_residuals(beam, band)
    except UserInputError as exc:
        rep["gain_poly3_residuals"] = {"error": str(exc)}
    for plane, phi in (("E", 0.0), ("H", 90.0)):
        fm, el, d = gain_derivative(beam, phi)
        rep[f"max_abs_dG_dnu_{plane}"] = float(np.max(np.abs(d)))
    return rep
