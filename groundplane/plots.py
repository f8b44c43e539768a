"""Figures people would rather look at than read: FoM vs LST and residual spectra."""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from .fom import FomResult


def pyplot():
    """matplotlib.pyplot on the file-only Agg backend (no display needed), imported on first use."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


FIGURE_SUFFIXES = (".png", ".pdf", ".svg")


def check_figure_path(path: str | Path) -> Path:
    """Refuse a figure path that cannot be written or names no format (a directory or a
    missing suffix: matplotlib would silently write ``<dir>.png``)."""
    from .errors import UserInputError
    from .files import check_output

    path = Path(path)
    check_output(path)
    if path.suffix.lower() not in FIGURE_SUFFIXES:
        raise UserInputError(f"{path}: a figure file needs one of the suffixes {', '.join(FIGURE_SUFFIXES)}")
    return path


def finish_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Lay out, write (atomically) and close a figure: the last step of every figure here."""
    fig.tight_layout()
    save_figure(fig, path, dpi=dpi)
    pyplot().close(fig)
    return Path(path)


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Write a figure atomically to ``path``, whose suffix names the format; the same figure
    gives the same bytes (no date, fixed SVG ids), so a committed figure changes only with its content."""
    import matplotlib

    from .files import atomic_path

    path = check_figure_path(path)
    fmt = path.suffix[1:].lower()
    metadata = {"svg": {"Date": None}, "pdf": {"CreationDate": None}}.get(fmt)
    with atomic_path(path, suffix=path.suffix) as tmp, matplotlib.rc_context({"svg.hashsalt": "groundplane"}):
        fig.savefig(tmp, dpi=dpi, format=fmt, metadata=metadata)
    return path


def fom_figure(results: Sequence[FomResult], labels: Sequence[str], path: str | Path,
               lst_hours_for_residuals: Sequence[float] = (2.0, 6.0, 12.0, 18.0)) -> Path:
    """FoM vs LST (top) and LinLog residual spectra at a few LSTs (bottom), one line per beam."""
    plt = pyplot()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    n = len(lst_hours_for_residuals)
    fig = plt.figure(figsize=(10, 4 + 2.2 * ((n + 1) // 2)))
    gs = fig.add_gridspec(1 + (n + 1) // 2, 2, height_ratios=[1.6] + [1] * ((n + 1) // 2))
    ax = fig.add_subplot(gs[0, :])
    for r, lab in zip(results, labels):
        ax.plot(r.lst_hours, r.fom * 1e3, label=f"{lab} ({r.lst_averaged_mk:.1f} mK)")
    ax.set_xlabel("LST (h)")
    ax.set_ylabel("FoM (mK)")
    ax.set_xlim(0, 24)
    ax.set_yscale("log")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, title="LST-averaged FoM", title_fontsize=8)
    for k, lst in enumerate(lst_hours_for_residuals):
        a = fig.add_subplot(gs[1 + k // 2, k % 2])
        for r, lab in zip(results, labels):
            i = int(np.argmin(np.abs(r.lst_hours - lst)))
            a.plot(r.freqs_mhz[r.fit_mask], r.residuals[:, i] * 1e3, label=lab)
        a.set_title(f"LST {lst:g} h: residuals after {results[0].settings.n_terms}-term LinLog", fontsize=9)
        a.set_xlabel("frequency (MHz)")
        a.set_ylabel("T_ant - model (mK)")
        a.grid(alpha=0.3)
    return finish_figure(fig, path)


# ------------------------------------------------------------------ beam figures
BEAM_PANELS = ("cuts", "derivative", "poly3", "widths")
"""The panels of :func:`beam_figures`: gain cuts, dG/dnu maps, 3-term residuals, beam widths."""


def _show_freqs(beams, freqs: Sequence[float] | None) -> list[float]:
    """The frequencies the cut panel draws: those asked for, else the lowest, middle and
    highest the first beam holds."""
    if freqs:
        return list(freqs)
    f = beams[0].freqs_mhz
    return sorted({float(f[0]), float(f[len(f) // 2]), float(f[-1])})


def _draw_cuts(fig, spec, beams, labels, freqs) -> None:
    from .fom import vertical_plane

    styles = ["-", "--", ":", "-."]
    cmap = pyplot().get_cmap("viridis")
    for col, (phi, plane) in enumerate(((0.0, "E-plane (phi 0)"), (90.0, "H-plane (phi 90)"))):
        ax = fig.add_subplot(spec[col])
        for j, (beam, lab) in enumerate(zip(beams, labels)):
            elev, g = vertical_plane(beam, phi)
            for i, f in enumerate(freqs):
                k = int(np.argmin(np.abs(beam.freqs_mhz - f)))
                if abs(beam.freqs_mhz[k] - f) > 1e-6:
                    continue
                db = 10 * np.log10(np.maximum(g[k], 1e-30))
                ax.plot(elev, db, ls=styles[j % len(styles)], color=cmap(i / max(1, len(freqs) - 1) * 0.9),
                        label=f"{lab}, {f:g} MHz" if len(beams) > 1 else f"{f:g} MHz", lw=1.2)
        ax.set(title=f"gain, {plane}", xlabel="elevation across the plane (deg)", ylabel="gain (dBi)",
               xlim=(0, 180), ylim=(-25, 10))
        ax.set_xticks([0, 30, 60, 90, 120, 150, 180])
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)


def _draw_derivative(fig, spec, beams, labels) -> None:
    from .fom import gain_derivative

    maps = [[gain_derivative(b, phi) for phi in (0.0, 90.0)] if b.freqs_mhz.size > 1 else None for b in beams]
    peak = max([float(np.max(np.abs(d))) for row in maps if row for (_, _, d) in row] + [0.0]) or 1.0
    sub = spec.subgridspec(len(beams), 2)
    for j, (row, lab) in enumerate(zip(maps, labels)):
        if row is None:  # one frequency: no derivative in frequency to draw
            ax = fig.add_subplot(sub[j, :])
            ax.text(0.5, 0.5, f"{lab}: dG/dnu needs two frequencies or more", ha="center", va="center")
            ax.axis("off")
            continue
        for col, ((fm, elev, d), plane) in enumerate(zip(row, ("E-plane", "H-plane"))):
            ax = fig.add_subplot(sub[j, col])
            im = ax.pcolormesh(elev, fm, d, cmap="RdBu_r", vmin=-peak, vmax=peak, shading="nearest")
            ax.set(title=f"dG/dnu, {plane}" + (f": {lab}" if len(beams) > 1 else ""), xlabel="elevation (deg)",
                   ylabel="frequency (MHz)", xlim=(0, 180))
            fig.colorbar(im, ax=ax, label="dG/dnu (1/MHz)")


def _draw_poly3(fig, spec, beams, labels) -> None:
    from .errors import UserInputError
    from .fom import gain_polynomial_residuals

    sub = spec.subgridspec(1, 3)
    axes = [fig.add_subplot(sub[0, i]) for i in range(3)]
    for beam, lab in zip(beams, labels):
        band = (max(50.0, beam.freqs_mhz.min()), min(100.0, beam.freqs_mhz.max()))
        try:
            res = gain_polynomial_residuals(beam, band)
        except UserInputError as exc:  # too few frequencies for the fit: say so on the figure
            axes[0].text(0.02, 0.02, f"{lab}: {exc}"[:90], transform=axes[0].transAxes, fontsize=6)
            continue
        for ax, (name, title) in zip(axes, (("zenith", "zenith"), ("E45", "E-plane, 45 deg elevation"),
                                            ("H45", "H-plane, 45 deg elevation"))):
            r = res[name]
            ax.plot(r["freqs_mhz"], r["residual"], label=f"{lab} (p-p {r['peak_to_peak']:.4f})", lw=1.2)
            ax.set(title=f"G - 3-term fit in nu: {title}", xlabel="frequency (MHz)", ylabel="residual gain (linear)")
    for ax in axes:
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:  # a beam too short for the fit draws nothing
            ax.legend(fontsize=7)


def _draw_widths(fig, spec, beams, labels) -> None:
    """3 dB widths in the E and H planes, and the ground loss, against frequency."""
    from .loss import loss_or_note

    sub = spec.subgridspec(1, 3)
    for col, (phi, plane) in enumerate(((0.0, "E-plane"), (90.0, "H-plane"))):
        ax = fig.add_subplot(sub[0, col])
        for beam, lab in zip(beams, labels):
            ax.plot(beam.freqs_mhz, [beam.beam_width_3db(f, phi) for f in beam.freqs_mhz], label=lab, lw=1.2)
        ax.set(title=f"3 dB beam width, {plane}", xlabel="frequency (MHz)", ylabel="full width (deg)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    ax = fig.add_subplot(sub[0, 2])
    notes = []
    for beam, lab in zip(beams, labels):
        loss, note = loss_or_note(beam)
        if loss is None:
            notes.append(f"{lab}: no ground loss (gain not normalised to input power)")
            continue
        ax.plot(beam.freqs_mhz, 100 * loss, "o-" if beam.freqs_mhz.size == 1 else "-", label=lab, lw=1.2, ms=3)
    for i, text in enumerate(notes):
        ax.text(0.02, 0.95 - 0.08 * i, text[:80], transform=ax.transAxes, fontsize=6, va="top")
    ax.set(title="ground loss: 1 - upper-hemisphere share", xlabel="frequency (MHz)", ylabel="loss (% of input power)")
    ax.grid(alpha=0.3)
    if len(notes) < len(beams):
        ax.legend(fontsize=7)


def beam_figures(beams: Sequence, labels: Sequence[str], path: str | Path, panels: bool = False,
                 freqs: Sequence[float] | None = None) -> list[Path]:
    """The paper's beam figures for one or several beams on shared axes: gain vs elevation in
    the E and H planes, dG/dnu maps vs elevation and frequency, residuals of a 3-term
    polynomial in frequency at zenith and 45 deg elevation, 3 dB widths and the ground loss vs
    frequency. One
    file, or with ``panels`` one per panel (``<stem>-<panel><suffix>``)."""
    plt = pyplot()
    path = check_figure_path(path)
    shown = _show_freqs(beams, freqs)
    draw = {"cuts": (lambda fig, spec: _draw_cuts(fig, spec.subgridspec(1, 2), beams, labels, shown), 4.2),
            "derivative": (lambda fig, spec: _draw_derivative(fig, spec, beams, labels), 3.6 * len(beams)),
            "poly3": (lambda fig, spec: _draw_poly3(fig, spec, beams, labels), 3.6),
            "widths": (lambda fig, spec: _draw_widths(fig, spec, beams, labels), 3.6)}
    written = []
    groups = [[p] for p in BEAM_PANELS] if panels else [list(BEAM_PANELS)]
    for group in groups:
        heights = [draw[p][1] for p in group]
        fig = plt.figure(figsize=(13, sum(heights) + 0.6))
        spec = fig.add_gridspec(len(group), 1, height_ratios=heights)
        for i, p in enumerate(group):
            draw[p][0](fig, spec[i])
        fig.suptitle(", ".join(labels) if len(labels) < 4 else f"{len(labels)} beams", fontsize=10)
        written.append(finish_figure(fig, path.with_name(f"{path.stem}-{group[0]}{path.suffix}") if panels else path))
    return written


def comparison_figure(comparison, path: str | Path) -> Path:
    """What ``groundplane compare`` found: each beam minus the first in dB over the sky (polar
    maps, zenith at the centre) at the lowest, middle and highest common frequency; the rms
    difference vs frequency; FoM vs LST of each beam (lines every LST, markers in LST bins)."""
    plt = pyplot()
    path = check_figure_path(path)
    c = comparison
    f = c.freqs_mhz
    picks = sorted({0, len(f) // 2, len(f) - 1})
    common = c.common
    n_pairs = len(c.pairs)
    fig = plt.figure(figsize=(13, 3.6 * n_pairs + 4.2))
    spec = fig.add_gridspec(n_pairs + 1, len(picks) if len(picks) > 1 else 2)
    sky = common[0].theta_deg <= 90.0 - c.elevation_cut_deg + 1e-9
    theta = common[0].theta_deg[sky]
    phi = np.radians(np.append(common[0].phi_deg, common[0].phi_deg[0] + 360.0))
    diffs = [10 * np.log10(np.maximum(b.gain[:, sky], 1e-30) / np.maximum(common[0].gain[:, sky], 1e-30))
             for b in common[1:]]
    lim = max(float(np.max(np.abs(d[picks]))) for d in diffs) or 0.01
    for row, (p, d) in enumerate(zip(c.pairs, diffs)):
        for col, k in enumerate(picks):
            ax = fig.add_subplot(spec[row, col], projection="polar")
            z = np.concatenate([d[k], d[k][:, :1]], axis=1)
            im = ax.pcolormesh(phi, theta, z, cmap="RdBu_r", vmin=-lim, vmax=lim, shading="nearest")
            ax.set_title(f"{p.b} - {p.a}, {f[k]:g} MHz", fontsize=8)
            ax.set_theta_zero_location("E")
            ax.set_yticks([30, 60, 90 - c.elevation_cut_deg])
            ax.tick_params(labelsize=6)
            fig.colorbar(im, ax=ax, label="dB", shrink=0.8)
    fig.text(0.01, 0.995, "maps: radius = zenith angle (deg), angle = azimuth from the excitation axis (phi 0 = "
             "E-plane)", fontsize=7, va="top")
    ax = fig.add_subplot(spec[n_pairs, 0])
    for p in c.pairs:
        ax.plot(f, p.rms_db, label=f"{p.b} - {p.a}", lw=1.2)
    ax.set(title=f"rms difference over the sky above {c.elevation_cut_deg:g} deg", xlabel="frequency (MHz)",
           ylabel="rms (dB)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax = fig.add_subplot(spec[n_pairs, 1:])
    for b in c.beams:
        line, = ax.plot(b.fom.lst_hours, b.fom.fom * 1e3, lw=1.0, label=f"{b.label} ({b.fom.lst_averaged_mk:.1f} mK; "
                        f"{b.fom_binned.lst_averaged_mk:.1f} in {c.bin_hours:g} h bins)")
        ax.plot(b.fom_binned.lst_hours, b.fom_binned.fom * 1e3, "o", color=line.get_color(), ms=4)
    ax.set(title="FoM vs LST (lines every LST, markers in LST bins)", xlabel="LST (h)", ylabel="FoM (mK)", xlim=(0, 24))
    ax.set_yscale("log")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return finish_figure(fig, path)


def s11_figure(rows: Sequence, z0: float, path: str | Path) -> Path:
    """|S11| (dB) and the input impedance (R, X) against frequency, one line per beam:
    ``rows`` of (label, frequencies, impedance, S11)."""
    plt = pyplot()
    path = check_figure_path(path)
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    for i, (label, f, z, s) in enumerate(rows):
        a.plot(f, 20 * np.log10(np.maximum(np.abs(s), 1e-300)), color=f"C{i}", label=label)
        b.plot(f, z.real, color=f"C{i}", label=f"{label}: R")
        b.plot(f, z.imag, "--", color=f"C{i}", label=f"{label}: X")
    a.set(xlabel="frequency (MHz)", ylabel=f"|S11| (dB, {z0:g} ohm)", title="reflection coefficient")
    b.set(xlabel="frequency (MHz)", ylabel="ohm", title="input impedance")
    for ax in (a, b):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    return finish_figure(fig, path)
