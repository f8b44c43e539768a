"""One candidate in, one scored row out: the unit every sweep, optimiser step and the
study reproductions are made of. Candidate, settings and the result row are defined here
once.

A candidate's beam comes from an engine (through its cache) or from a solver export file
(FEKO/CST/HFSS/npz), so exported designs join the same ranking. Scoring runs in this
process (healpy); engines run in worker processes.
"""
from __future__ import annotations

import hashlib
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from groundplane.beam import Beam
from groundplane.design import Design, Soil
from groundplane.errors import UserInputError
from groundplane.fom import FomResult, FomSettings, figure_of_merit, figure_of_merit_check, narrow_band_rms
from groundplane.loss import largest_in_band, loss_or_note
from groundplane.shapes import GroundPlane, to_dict
from solvers.engines import ENGINES, Solver, make_solver
from solvers.engines.base import SolveSettings
from solvers.io import load_beam

RESIDUAL_LSTS_H = (2.0, 6.0, 12.0, 18.0)


@dataclass(frozen=True)
class Candidate:
    """A named ground plane (solved by the settings' engine) or a beam file (loaded)."""

    name: str
    plane: GroundPlane | None = None
    beam_paths: tuple[str, ...] = ()
    beam_format: str = "auto"
    metal_area_m2: float | None = None  # for beam files whose shape we do not know

    def __post_init__(self) -> None:
        if (self.plane is None) == (not self.beam_paths):
            raise UserInputError(f"candidate '{self.name}': give either a shape/preset or a beam file, not both or neither")

    def identity(self) -> dict[str, Any]:
        if self.plane is not None:
            return {"plane": to_dict(self.plane)}
        files = []
        for p in self.beam_paths:
            st = Path(p).stat() if Path(p).exists() else None
            files.append([str(p), st.st_size if st else None, st.st_mtime_ns if st else None])
        return {"beam_files": files, "format": self.beam_format}


IDENTITY_VERSION = 2  # 2: every field always present (1 left out NEC's engine name and FoM fields at old defaults)


@dataclass(frozen=True)
class EvalSettings:
    """How candidates are solved and scored (the same for every row of one sweep): the soil,
    the solve (engine, frequencies, processes), the engine's model (mesh, plate, blade) and
    the FoM. Each part is its own settings dataclass, declared once where it belongs."""

    soil: Soil = field(default_factory=Soil)
    solve: SolveSettings = field(default_factory=SolveSettings)
    model: Any = None  # the engine's model settings (its ``settings_class``); None: the engine's defaults
    fom: FomSettings = field(default_factory=FomSettings)

    def __post_init__(self) -> None:
        if self.solve.engine not in ENGINES:
            raise UserInputError(f"engine '{self.solve.engine}': choose one of {', '.join(ENGINES)}")
        model_class = ENGINES[self.solve.engine].settings_class
        if self.model is None:
            object.__setattr__(self, "model", model_class())
        elif not isinstance(self.model, model_class):
            raise UserInputError(f"engine {self.solve.engine} takes {model_class.__name__} model settings, "
                                 f"got {type(self.model).__name__}")

    @property
    def engine(self) -> str:
        return self.solve.engine

    @property
    def freqs_mhz(self) -> tuple[float, ...]:
        return self.solve.freqs_mhz

    @property
    def workers(self) -> int:
        return self.solve.workers

    def with_solve(self, **changes: Any) -> "EvalSettings":
        """The same settings with some solve fields changed (``freqs_mhz``, ``workers``)."""
        from dataclasses import replace

        return replace(self, solve=replace(self.solve, **changes))

    def check_scorable(self) -> None:
        """Refuse, before any solve, an engine that cannot solve candidates on soil and
        frequencies that the FoM could not score (they miss the fit band or hold too few
        points in it for the fit)."""
        from groundplane.fom import fit_band_mask

        grounds = ENGINES[self.engine].grounds  # each engine declares what it can put under a design
        if "soil" not in grounds:
            able = " or ".join(f"--engine {n}" for n, cls in sorted(ENGINES.items()) if "soil" in cls.grounds) or "another engine"
            raise UserInputError(f"--engine {self.engine} solves over {', '.join(grounds)} ground only, and candidates "
                                 f"here lie on soil: use {able} (or `groundplane solve --engine {self.engine} "
                                 "--ground pec` for one design above PEC)")

        try:
            fit_band_mask(np.asarray(self.freqs_mhz, dtype=float), self.fom.fit_band_mhz, self.fom.n_terms)
        except UserInputError as exc:
            raise UserInputError(f"--freqs {self.freqs_mhz[0]:g}-{self.freqs_mhz[-1]:g} MHz cannot be scored: "
                                 f"{exc}") from None

    @property
    def spacing(self) -> float | None:
        """The engine's plate-grid spacing (m), if it has one."""
        return getattr(self.model, "spacing", None)

    def with_spacing(self, spacing: float) -> "EvalSettings":
        """The same settings at another plate-grid spacing (a finer or coarser mesh)."""
        from dataclasses import replace

        return replace(self, model=replace(self.model, spacing=spacing))

    def make_solver(self, progress: bool = False, workers: int | None = None) -> Solver:
        return make_solver(self.engine, self.model, workers=self.workers if workers is None else workers,
                           progress=progress)

    def identity(self) -> dict[str, Any]:
        """Everything a row's FoM depends on (sweep row keys, search histories). Bump
        ``IDENTITY_VERSION`` when its form changes: old rows are then scored again (from cached
        beams), never matched under a key that meant something else."""
        return {
            "identity_version": IDENTITY_VERSION,
            "engine": self.engine,
            "soil": [self.soil.eps_r, self.soil.sigma],
            "mesh": self.model.as_dict(),
            "freqs": [round(float(f), 6) for f in self.freqs_mhz],
            "fom": self.fom.as_dict(),
        }

    def describe(self) -> str:
        """One line for reports: engine, model settings, band, fit band."""
        f = self.freqs_mhz
        step = f"{f[1] - f[0]:g} MHz steps" if len(f) > 1 else "one frequency"
        return (f"engine {self.engine} {json.dumps(self.model.as_dict())}; soil eps_r {self.soil.eps_r:g}, "
                f"sigma {self.soil.sigma:g} S/m; {len(f)} frequencies {min(f):g}-{max(f):g} MHz ({step}); "
                f"LinLog fit {self.fom.fit_band_mhz[0]:g}-{self.fom.fit_band_mhz[1]:g} MHz, {self.fom.n_lst} LSTs"
                + (f" averaged in {self.fom.lst_bin_hours:g} h bins" if self.fom.lst_bin_hours else ""))


def row_key(candidate: Candidate, settings: EvalSettings, extra: dict[str, Any] | None = None) -> str:
    """A stable key for (candidate, settings[, ``extra``: e.g. the scenario set]): a sweep never
    scores the same pair twice."""
    blob = json.dumps({"c": candidate.identity(), "s": settings.identity(), **({"x": extra} if extra else {})},
                      sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:20]


def candidate_beam(candidate: Candidate, settings: EvalSettings, progress: bool = False) -> tuple[Beam, float]:
    """The candidate's beam (solved or loaded) and the seconds it took."""
    t0 = time.perf_counter()
    if candidate.plane is None:
        return load_beam(list(candidate.beam_paths), candidate.beam_format), time.perf_counter() - t0
    beam = settings.make_solver(progress).solve(Design(candidate.plane, settings.soil), settings.freqs_mhz)
    return beam, time.perf_counter() - t0


SMOOTHING_DEGREE = 12  # Chebyshev degree over the band: keeps structure down to a ~10 MHz period


def scored_products(beam: Beam, fom: FomSettings) -> tuple[FomResult, float | None]:
    """The beam's FoM and the FoM of its G(nu) smoothed by a degree-SMOOTHING_DEGREE Chebyshev
    fit (None when the band is too short for it), from ONE sky convolution: the sky integral is
    linear in G, so the smoothed beam's products are the smoothing matrix times the beam's. (The
    fit's rare slightly negative values near the horizon are kept here; ``Beam.frequency_smoothed``
    clips them, to stay a beam: on the shipped NEC beam the two differ by 0.000 %.)"""
    from groundplane.fom import check_products, fom_from_spectra, sky_products, smoothing_matrix, t_ant_from_products

    figure_of_merit_check(beam, fom)
    gwt, gw, lst_hours = sky_products(beam, fom)
    check_products(beam, gwt, gw)
    result = fom_from_spectra(beam.freqs_mhz, t_ant_from_products(beam.freqs_mhz, gwt, gw, fom), fom, lst_hours)
    if beam.freqs_mhz.size < 2 * SMOOTHING_DEGREE + 1:
        return result, None
    m = smoothing_matrix(beam.freqs_mhz, SMOOTHING_DEGREE)
    smoothed = fom_from_spectra(beam.freqs_mhz, t_ant_from_products(beam.freqs_mhz, m @ gwt, m @ gw, fom), fom,
                                lst_hours)
    return result, float(smoothed.lst_averaged_mk)


def solver_cpu_s(beam: Beam) -> float | None:
    """Solver time summed over frequencies, from the beam's own timings (None for exports)."""
    secs = beam.meta.get("seconds_per_frequency")
    return None if secs is None else round(float(np.sum(secs)), 2)


def score(candidate: Candidate, beam: Beam, settings: EvalSettings, seconds: float) -> dict[str, Any]:
    """The result row of a candidate whose beam is known."""
    result, smoothed = scored_products(beam, settings.fom)  # one sky convolution for both
    fom_mk = float(result.lst_averaged_mk)
    if not math.isfinite(fom_mk):
        raise ArithmeticError(f"candidate '{candidate.name}': FoM is not finite")
    loss, loss_note = loss_or_note(beam)
    residuals = {}
    for h in RESIDUAL_LSTS_H:
        i = int(np.argmin(np.abs(result.lst_hours - h)))
        residuals[f"{h:g}"] = (result.residuals[:, i] * 1e3).round(4).tolist()
    return {
        **row_head(candidate, "ok"),
        "lst_averaged_fom_mk": fom_mk,
        # diagnostic: the FoM once narrow-band structure (solver artefacts) is smoothed out
        # of G(nu) (`groundplane fom --smooth-frequency`)
        "fom_smoothed_mk": smoothed,
        "narrow_band_rms": narrow_band_rms(beam, SMOOTHING_DEGREE),
        "fom_mk": (result.fom * 1e3).round(4).tolist(),
        "lst_hours": result.lst_hours.round(6).tolist(),
        "fit_freqs_mhz": result.freqs_mhz[result.fit_mask].tolist(),
        "residuals_mk": residuals,
        # the share of the input power the soil absorbs, per beam frequency, and its largest in the fit band
        "ground_loss": None if loss is None else loss.round(8).tolist(),
        "max_ground_loss": None if loss is None else largest_in_band(beam.freqs_mhz, loss, settings.fom.fit_band_mhz),
        **({"ground_loss_note": loss_note} if loss_note else {}),
        **({"mesh_note": beam.meta["mesh_note"]} if beam.meta.get("mesh_note") else {}),
        "freqs_mhz": beam.freqs_mhz.tolist(),
        "solve_s": round(seconds, 2),
        # what the solve cost, from the beam's own per-frequency timings: a cache hit has
        # solve_s ~ 0 but still reports this (wall time is about this over the worker count)
        "solver_cpu_s": solver_cpu_s(beam),
        "n_segments": beam.meta.get("n_segments"),
        "n_unknowns": beam.meta.get("n_unknowns"),  # surface engines: RWG edges
        "beam_cache_key": beam.meta.get("cache_key"),
        "source": beam.meta.get("source"),
    }


def evaluate(candidate: Candidate, settings: EvalSettings, progress: bool = False) -> dict[str, Any]:
    """Solve (or load) and score one candidate. Errors become a row with status 'failed'
    and the reason, so one bad candidate never stops a sweep."""
    try:
        beam, secs = candidate_beam(candidate, settings, progress)
        return score(candidate, beam, settings, secs)
    except KeyboardInterrupt:
        raise
    except Exception as exc:  # noqa: BLE001 - reported in the row, never swallowed silently
        return failed_row(candidate, f"{type(exc).__name__}: {exc}")


def pec_floor_mk(settings: EvalSettings, progress: bool = False) -> float:
    """The blade alone over infinite PEC on the same engine, mesh and FoM settings (the paper's
    reference case): the part of a design's FoM that comes from the antenna model, and a floor
    no finite plane on soil goes below in this model."""
    from groundplane.design import InfinitePEC

    beam = settings.make_solver(progress).solve(Design(None, InfinitePEC()), settings.freqs_mhz)
    return float(figure_of_merit(beam, settings.fom).lst_averaged_mk)


def row_head(candidate: Candidate, status: str) -> dict[str, Any]:
    """The columns every result row starts with: who the candidate is and how it ended."""
    plane = candidate.plane
    return {
        "name": candidate.name,
        "status": status,
        "shape": plane.kind if plane else "beam-file",
        "params": plane.params() if plane else {"beam": list(candidate.beam_paths)},
        "metal_area_m2": plane.metal_area if plane else candidate.metal_area_m2,
        "extent_m": plane.extent if plane else None,
    }


def failed_row(candidate: Candidate, reason: str) -> dict[str, Any]:
    """The row of a candidate whose solve or scoring failed."""
    return {**row_head(candidate, "failed"), "error": reason, "lst_averaged_fom_mk": None}


def invalid_row(name: str, shape: str, params: dict[str, Any], reason: str) -> dict[str, Any]:
    """The row of a family member whose geometry is impossible (kept in the report)."""
    return {"name": name, "status": "invalid", "shape": shape, "params": params, "metal_area_m2": None,
            "extent_m": None, "error": reason, "lst_averaged_fom_mk": None}
