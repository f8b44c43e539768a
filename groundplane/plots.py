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


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Write a figure atomically to ``path``, whose suffix names the format."""
    from .files import atomic_path

    path = check_figure_path(path)
    with atomic_path(path, suffix=path.suffix) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.suffix[1:].lower())
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
        ax.plot(r.lst_hours, r.fom * 1e3, label=f"{lab} ({r.lst_averaged_fom_mk:.1f} mK)")
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
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path
