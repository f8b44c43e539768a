"""Two or more beams side by side: on their common frequencies and directions, how far apart
their gains are (per frequency, over the sky above an elevation cut), their zenith ratio,
widths and efficiencies, and their FoMs scored with identical settings on identical
frequencies. The question an engineer asks of a model against an export, a new mesh
against the old, or one engine against another.

Conventions: a difference is ``B - A`` in dB (``10 log10(G_B / G_A)``) for each beam B against
the first beam A; its rms over the sky is weighted by solid angle (each direction counts for
the sky it sees, so the many samples crowded near zenith on a theta-phi grid do not dominate);
``zenith_ratio`` is ``G_B / G_A`` at zenith; efficiency is the upper hemisphere's share of the
radiated power, ``int G dOmega / 4 pi`` over theta <= 90 deg (1 for a lossless model over PEC).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Sequence

import numpy as np

from . import paper
from .beam import Beam
from .errors import UserInputError
from .fom import FomResult, FomSettings, figure_of_merit, fit_band_mask
from .loss import loss_or_note

__all__ = ["BeamSummary", "Comparison", "PairDifference", "common_beams", "compare_beams", "direction_differences",
           "shared_grid", "upper_hemisphere_efficiency"]

GRID_DECIMALS = 6  # frequencies (MHz) and angles (deg) equal to 1e-6 are the same sample
MIN_DIRECTIONS = 9  # fewer common directions above the cut cannot say how two beams differ over the sky


def _label(beam: Beam) -> str:
    return str(beam.meta.get("source", "beam"))


def _shared(values: Sequence[np.ndarray]) -> np.ndarray:
    """The values every array holds (to GRID_DECIMALS), sorted."""
    common = set(np.round(values[0], GRID_DECIMALS))
    for v in values[1:]:
        common &= set(np.round(v, GRID_DECIMALS))
    return np.array(sorted(common), float)


def _take(beam: Beam, freqs: np.ndarray, theta: np.ndarray, phi: np.ndarray) -> Beam:
    pick = [np.flatnonzero(np.isin(np.round(have, GRID_DECIMALS), want))
            for have, want in ((beam.freqs_mhz, freqs), (beam.theta_deg, theta), (beam.phi_deg, phi))]
    at = beam.at_frequencies(pick[0])  # per-frequency meta (impedance, timings) follows the frequencies kept
    return Beam(at.freqs_mhz, at.theta_deg[pick[1]], at.phi_deg[pick[2]], at.gain[:, pick[1]][:, :, pick[2]], at.meta)


def _describe(beam: Beam, label: str) -> str:
    f = beam.freqs_mhz
    return f"{label} ({f.size} frequencies {f.min():g}-{f.max():g} MHz)"


def shared_grid(beams: Sequence[Beam], labels: Sequence[str] | None = None, elevation_cut_deg: float = 10.0,
                min_freqs: int = 1) -> list[Beam]:
    """Each beam restricted to the frequencies and (theta, phi) directions all of them hold.
    Refused, naming the beams and what they lack, when they share fewer than ``min_freqs``
    frequencies, or too few directions above the cut to compare, or no zenith."""
    labels = list(labels or [_label(b) for b in beams])
    if len(beams) < 2:
        raise UserInputError("compare needs at least two beams")
    freqs = _shared([b.freqs_mhz for b in beams])
    if freqs.size < max(1, min_freqs):
        what = ", ".join(_describe(b, lab) for b, lab in zip(beams, labels))
        raise UserInputError(f"the beams share {'no frequency' if freqs.size == 0 else f'{freqs.size} frequencies'}"
                             f" (at least {min_freqs} needed): {what}")
    theta = _shared([b.theta_deg for b in beams])
    phi = _shared([b.phi_deg for b in beams])
    grids = "; ".join(f"{lab}: theta {b.theta_deg.size} values {b.theta_deg.min():g}-{b.theta_deg.max():g}, "
                      f"phi {b.phi_deg.size} values step {np.diff(b.phi_deg).min() if b.phi_deg.size > 1 else 360:g}"
                      for b, lab in zip(beams, labels))
    if theta.size == 0 or theta[0] != 0.0:
        raise UserInputError(f"the beams' grids share no zenith direction (theta 0): {grids}")
    above = theta[theta <= 90.0 - elevation_cut_deg + 1e-9]
    if above.size * phi.size < MIN_DIRECTIONS or phi.size < 2:
        raise UserInputError(f"the beams' grids share {above.size} theta x {phi.size} phi values above "
                             f"{elevation_cut_deg:g} deg elevation (at least {MIN_DIRECTIONS} directions and 2 "
                             f"azimuths needed): {grids}")
    return [_take(b, freqs, theta, phi) for b in beams]


def common_beams(beams: Sequence[Beam], labels: Sequence[str], settings: FomSettings = FomSettings(),
                 elevation_cut_deg: float = 10.0) -> list[Beam]:
    """:func:`shared_grid`, refused also when the common frequencies are fewer than the FoM's
    fit needs or leave a hole in its band (the beams could not be scored alike)."""
    common = shared_grid(beams, labels, elevation_cut_deg)
    freqs = common[0].freqs_mhz
    try:
        fit_band_mask(freqs, settings.fit_band_mhz, settings.n_terms)
    except UserInputError as exc:
        what = ", ".join(_describe(b, lab) for b, lab in zip(beams, labels))
        raise UserInputError(f"the beams share {freqs.size} frequencies ({freqs.min():g}-{freqs.max():g} MHz), "
                             f"too few to score them alike: {exc}. Beams: {what}") from None
    return common


def upper_hemisphere_efficiency(beam: Beam) -> np.ndarray:
    """int G dOmega / 4 pi over the upper hemisphere, per frequency (:meth:`Beam.upper_hemisphere_share`)."""
    return beam.upper_hemisphere_share()


def direction_differences(a: Beam, b: Beam, elevation_cut_deg: float = 10.0) -> dict[str, np.ndarray]:
    """Per frequency: the solid-angle-weighted rms and the largest |B - A| in dB over the
    directions at least ``elevation_cut_deg`` above the horizon, and G_B / G_A at zenith.
    The beams must be on the same frequencies and grid (:func:`common_beams`)."""
    if a.gain.shape != b.gain.shape or not (np.array_equal(a.freqs_mhz, b.freqs_mhz)
                                            and np.array_equal(a.theta_deg, b.theta_deg)
                                            and np.array_equal(a.phi_deg, b.phi_deg)):
        raise UserInputError(f"{_label(a)} and {_label(b)} are not on the same frequencies and grid "
                             "(take common_beams first)")
    sky = a.theta_deg <= 90.0 - elevation_cut_deg + 1e-9
    tiny = np.finfo(float).tiny  # a null in either beam is a large, finite difference, not -inf
    db = 10 * np.log10(np.maximum(b.gain[:, sky], tiny) / np.maximum(a.gain[:, sky], tiny))
    w = a.upper_hemisphere().solid_angle_weights()[sky[a.theta_deg <= 90.0 + 1e-9]]
    rms = np.sqrt(np.einsum("ftp,tp->f", db ** 2, w) / w.sum())
    with np.errstate(divide="ignore", invalid="ignore"):
        zenith = b.gain[:, 0].mean(axis=1) / a.gain[:, 0].mean(axis=1)  # theta 0: every phi is zenith
    return {"rms_db": rms, "max_db": np.abs(db).max(axis=(1, 2)), "zenith_ratio": zenith}


@dataclass
class BeamSummary:
    """One beam's numbers on the common frequencies: the FoM every LST and in LST bins, and
    per frequency its efficiency, 3 dB widths in the E (phi 0) and H (phi 90) planes."""

    label: str
    path: str
    fom: FomResult
    fom_binned: FomResult
    efficiency: np.ndarray
    width_e_deg: np.ndarray
    width_h_deg: np.ndarray
    ground_loss: np.ndarray | None = None  # None when the gain is not normalised to input power
    ground_loss_note: str | None = None

    def as_json(self) -> dict[str, Any]:
        return {"label": self.label, "path": self.path, "fom_mk": self.fom.lst_averaged_mk,
                "fom_binned_mk": self.fom_binned.lst_averaged_mk, "fom_lst_mk": (self.fom.fom * 1e3).tolist(),
                "fom_binned_lst_mk": (self.fom_binned.fom * 1e3).tolist(), "efficiency": self.efficiency.tolist(),
                "width_e_deg": _json_floats(self.width_e_deg), "width_h_deg": _json_floats(self.width_h_deg),
                "ground_loss": None if self.ground_loss is None else self.ground_loss.tolist(),
                **({"ground_loss_note": self.ground_loss_note} if self.ground_loss_note else {})}

    def loss_cell(self, i: int | None = None) -> str:
        """The ground loss in %: at frequency index ``i``, or its range; '-' when undefined."""
        if self.ground_loss is None:
            return "-"
        v = 100 * self.ground_loss
        return f"{v[i]:.2f}" if i is not None else f"{v.min():.2f}-{v.max():.2f}"


@dataclass
class PairDifference:
    """Beam ``b`` against beam ``a`` (the first): per frequency and per LST."""

    a: str
    b: str
    rms_db: np.ndarray
    max_db: np.ndarray
    zenith_ratio: np.ndarray
    fom_diff_mk: np.ndarray  # FoM_b - FoM_a at every LST
    fom_binned_diff_mk: np.ndarray  # the same in LST bins

    def as_json(self) -> dict[str, Any]:
        return {"a": self.a, "b": self.b, "rms_db": self.rms_db.tolist(), "max_db": self.max_db.tolist(),
                "zenith_ratio": self.zenith_ratio.tolist(), "fom_diff_mk": self.fom_diff_mk.tolist(),
                "fom_binned_diff_mk": self.fom_binned_diff_mk.tolist()}


@dataclass
class Comparison:
    """What :func:`compare_beams` found, with the common grid and the settings it used."""

    freqs_mhz: np.ndarray
    theta_deg: np.ndarray
    phi_deg: np.ndarray
    elevation_cut_deg: float
    settings: FomSettings
    bin_hours: float
    beams: list[BeamSummary]
    pairs: list[PairDifference]
    common: list[Beam] = field(repr=False, default_factory=list)

    @property
    def lst_hours(self) -> np.ndarray:
        return self.beams[0].fom.lst_hours

    def as_json(self) -> dict[str, Any]:
        return {"freqs_mhz": self.freqs_mhz.tolist(), "theta_deg": self.theta_deg.tolist(),
                "phi_deg": self.phi_deg.tolist(), "elevation_cut_deg": self.elevation_cut_deg,
                "lst_hours": self.lst_hours.tolist(), "lst_bin_hours": self.bin_hours,
                "binned_lst_hours": self.beams[0].fom_binned.lst_hours.tolist(),
                "fom_settings": {k: v for k, v in self.settings.as_dict().items() if k != "lst_bin_hours"},
                "beams": [b.as_json() for b in self.beams], "pairs": [p.as_json() for p in self.pairs]}

    def markdown(self) -> str:
        """The tables a reader wants: one row per beam, then one row per frequency."""
        f = self.freqs_mhz
        first = self.beams[0].label
        s = self.settings
        lines = [f"Common: {f.size} frequencies {f.min():g}-{f.max():g} MHz, {self.theta_deg.size} x "
                 f"{self.phi_deg.size} (theta x phi) directions; differences over the sky above "
                 f"{self.elevation_cut_deg:g} deg elevation; FoM: {s.n_terms}-term LinLog over "
                 f"{s.fit_band_mhz[0]:g}-{s.fit_band_mhz[1]:g} MHz, every LST and in {self.bin_hours:g} h LST bins.",
                 "", f"| beam | FoM every LST (mK) | FoM {self.bin_hours:g} h bins (mK) | FoM / {first}'s | "
                 "ground loss (%, min-max) | efficiency (min-max) | E width (deg, min-max) | H width (deg, min-max) |",
                 "|---|---|---|---|---|---|---|---|"]
        ref = self.beams[0].fom.lst_averaged_mk
        for b in self.beams:
            lines.append(f"| {b.label} | {b.fom.lst_averaged_mk:.2f} | {b.fom_binned.lst_averaged_mk:.2f} | "
                         f"{b.fom.lst_averaged_mk / ref:.4f} | {b.loss_cell()} | {_span(b.efficiency, 3)} | "
                         f"{_span(b.width_e_deg, 1)} | {_span(b.width_h_deg, 1)} |")
        lines += [f"\n{b.label}: no ground loss: {b.ground_loss_note}" for b in self.beams if b.ground_loss_note]
        from .s11 import db, input_impedance, reflection

        s11 = [input_impedance(b) for b in self.common]
        if self.common and s11[0] is not None:
            for b, z in zip(self.beams[1:], s11[1:]):
                if z is not None:
                    d = np.abs(db(reflection(z)) - db(reflection(s11[0])))
                    lines += ["", f"|S11| (50 ohm) of {b.label} against {self.beams[0].label}: differs by "
                              f"{d.mean():.2f} dB on average, at most {d.max():.2f} dB (at {f[int(np.argmax(d))]:g} MHz)."]
        for p in self.pairs:
            k = int(np.argmax(p.rms_db))
            lines += ["", f"{p.b} - {p.a}: rms over the sky {p.rms_db.min():.3f}-{p.rms_db.max():.3f} dB "
                      f"(largest at {f[k]:g} MHz), largest single direction {p.max_db.max():.3f} dB, zenith ratio "
                      f"{p.zenith_ratio.min():.4f}-{p.zenith_ratio.max():.4f}; FoM per LST differs by "
                      f"{p.fom_diff_mk.min():+.2f} to {p.fom_diff_mk.max():+.2f} mK."]
        head = "| f (MHz) | " + " | ".join(f"{b.label} loss % / E / H width" for b in self.beams) + " | " + " | ".join(
            f"{p.b} - {p.a}: rms dB / max dB / zenith ratio" for p in self.pairs) + " |"
        lines += ["", head, "|" + "---|" * (1 + len(self.beams) + len(self.pairs))]
        for i, fi in enumerate(f):
            cells = [f"{b.loss_cell(i)} / {b.width_e_deg[i]:.1f} / {b.width_h_deg[i]:.1f}" for b in self.beams]
            cells += [f"{p.rms_db[i]:.3f} / {p.max_db[i]:.3f} / {p.zenith_ratio[i]:.4f}" for p in self.pairs]
            lines.append(f"| {fi:g} | " + " | ".join(cells) + " |")
        return "\n".join(lines)


def _span(v: np.ndarray, digits: int) -> str:
    if not np.isfinite(v).any():
        return "-"
    return f"{np.nanmin(v):.{digits}f}-{np.nanmax(v):.{digits}f}"


def _json_floats(v: np.ndarray) -> list:
    """NaN (a width the beam does not reach) as JSON null."""
    return [float(x) if np.isfinite(x) else None for x in v]


def compare_beams(beams: Sequence[Beam], labels: Sequence[str] | None = None, paths: Sequence[str] | None = None,
                  settings: FomSettings = FomSettings(), elevation_cut_deg: float = 10.0,
                  progress: bool = False) -> Comparison:
    """Every beam against the first on their common frequencies and directions; each scored
    with ``settings`` every LST and in LST bins (``settings.lst_bin_hours``, or the paper's
    2 h when that is 0)."""
    labels = list(labels or [_label(b) for b in beams])
    paths = list(paths or labels)
    if not 0.0 <= elevation_cut_deg < 90.0:
        raise UserInputError(f"--elevation-cut {elevation_cut_deg:g}: must be 0-90 deg (exclusive of 90)")
    common = common_beams(beams, labels, settings, elevation_cut_deg)
    bin_hours = settings.lst_bin_hours or paper.DATA_LST_BIN_HOURS
    every = settings.every_lst()
    replace(settings, lst_bin_hours=bin_hours)  # refuse bins that do not divide the LSTs before scoring
    summaries = []
    for beam, label, path in zip(common, labels, paths):
        fom = figure_of_merit(beam, every, progress=progress)
        freqs = beam.freqs_mhz
        summaries.append(BeamSummary(label, str(path), fom, fom.in_lst_bins(bin_hours), upper_hemisphere_efficiency(beam),
                                     np.array([beam.beam_width_3db(x, 0.0) for x in freqs]),
                                     np.array([beam.beam_width_3db(x, 90.0) for x in freqs]), *loss_or_note(beam)))
    pairs = []
    a = summaries[0]
    for beam, s in zip(common[1:], summaries[1:]):
        d = direction_differences(common[0], beam, elevation_cut_deg)
        pairs.append(PairDifference(a.label, s.label, d["rms_db"], d["max_db"], d["zenith_ratio"],
                                    (s.fom.fom - a.fom.fom) * 1e3, (s.fom_binned.fom - a.fom_binned.fom) * 1e3))
    c = common[0]
    return Comparison(c.freqs_mhz, c.theta_deg, c.phi_deg, elevation_cut_deg, settings, bin_hours, summaries, pairs,
                      common)
