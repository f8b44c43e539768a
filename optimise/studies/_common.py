"""Helpers shared by the studies (not a study itself)."""
from __future__ import annotations

import platform
import time
from typing import Iterable

import numpy as np

from groundplane import paper
from groundplane.beam import Beam
from groundplane.design import Design
from groundplane.files import write_csv  # noqa: F401 - the studies' CSV writer
from groundplane.fom import FomSettings, figure_of_merit
from solvers.engines import DEFAULT_FREQS_MHZ, make_solver
from solvers.engines.base import SolveSettings

FREQS = np.asarray(DEFAULT_FREQS_MHZ)


def _engine_of(settings) -> str:
    """The engine whose settings these are."""
    from solvers.engines import ENGINES

    return next(name for name, cls in ENGINES.items() if cls.settings_class is type(settings))


def solve(design: Design, settings, freqs: Iterable[float] = FREQS) -> tuple[Beam, float]:
    """A cached solve by the engine these settings belong to, on the default worker count, with
    progress; returns (beam, wall seconds)."""
    t0 = time.perf_counter()
    beam = make_solver(_engine_of(settings), settings, workers=SolveSettings().workers, progress=True).solve(design, freqs)
    return beam, time.perf_counter() - t0


def cached(design: Design, settings, freqs: Iterable[float] = FREQS) -> Beam | None:
    """The cached beam of a solve, or None (never solves)."""
    return make_solver(_engine_of(settings), settings).cached(design, freqs)


def engine_settings(engine: str, **values):
    """``engine``'s settings with the given values where it has such a setting (a study row
    names its plate once; each engine takes what it models)."""
    from dataclasses import fields

    from solvers.engines import ENGINES

    cls = ENGINES[engine].settings_class
    names = {f.name for f in fields(cls)}
    return cls(**{k: v for k, v in values.items() if k in names})


def fom_mk(beam: Beam) -> float:
    """LST-averaged FoM (mK) with the paper's settings."""
    return figure_of_merit(beam, FomSettings().every_lst()).lst_averaged_mk


def fom_and_binned_mk(beam: Beam) -> tuple[float, float]:
    """LST-averaged FoM (mK) with the paper's settings, every LST and in its 2 h LST bins (the
    binning of its section 6, where Table 2's soil numbers meet the data), from one sky product."""
    res = figure_of_merit(beam, FomSettings().every_lst())
    return res.lst_averaged_mk, res.in_lst_bins(paper.DATA_LST_BIN_HOURS).lst_averaged_mk


def zenith_dbi(beam: Beam, f: float = 75.0) -> float:
    i = int(np.argmin(np.abs(beam.freqs_mhz - f)))
    return float(10 * np.log10(beam.gain[i, 0, 0]))


def efficiency(beam: Beam, f: float = 75.0) -> float:
    """Upper-hemisphere mean gain / 2 at ``f``: the fraction of power not lost in the soil."""
    from groundplane.comparison import upper_hemisphere_efficiency

    return float(upper_hemisphere_efficiency(beam)[int(np.argmin(np.abs(beam.freqs_mhz - f)))])


def narrow_rms(beam: Beam, degree: int = 12) -> float:
    """rms(G - its degree-``degree`` Chebyshev fit in frequency) / mean G over the whole
    stored grid (the committed v1 studies used this); see ``groundplane.fom.narrow_band_rms``
    for the upper-hemisphere metric."""
    return float(np.std(beam.gain - beam.frequency_smoothed(degree).gain) / np.mean(beam.gain))


def verdict(condition: bool, holds: str, fails: str) -> str:
    """A report's conclusion as a condition on its rows: the sentence for the outcome the
    numbers give (both are written, so a rerun that changes the numbers changes the verdict)."""
    return holds if condition else fails


def machine() -> str:
    """The machine and every engine's identity, for a report's header."""
    from solvers.engines import ENGINES

    engines = "; ".join(f"{n} {make_solver(n).engine_identity()}" for n in sorted(ENGINES))
    return f"{platform.machine()}, {platform.python_version()}, engines: {engines}"
