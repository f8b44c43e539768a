"""One candidate in, one scored row out: the unit every sweep, optimiser step and the
design-study reproduction is made of.

A candidate's beam comes from the NEC-2 solver (through its cache) or from a solver
export file (FEKO/CST/HFSS/npz), so exported designs join the same ranking. Scoring runs
in this process (healpy); NEC runs in worker processes (see solvers.nec.engine_call).
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
from groundplane.fom import FomSettings, figure_of_merit
from groundplane.shapes import GroundPlane, to_dict

RESIDUAL_LSTS_H = (2.0, 6.0, 12.0, 18.0)


@dataclass(frozen=True)
class Candidate:
    """A named ground plane (solved with NEC-2) or a beam file (loaded)."""

    name: str
    plane: GroundPlane | None = None
    beam_paths: tuple[str, ...] = ()
    beam_format: str = "auto"
    metal_area_m2: float | None = None  # for beam files whose shape we do not know

    def __post_init__(self) -> None:
        if (self.plane is None) == (not self.beam_paths):
            raise ValueError(f"candidate '{self.name}': give either a shape/preset or a beam file, not both or neither")

    def identity(self) -> dict[str, Any]:
        if self.plane is not None:
            return {"plane": to_dict(self.plane)}
        files = []
        for p in self.beam_paths:
            st = Path(p).stat() if Path(p).exists() else None
            files.append([str(p), st.st_size if st else None, st.st_mtime_ns if st else None])
        return {"beam_files": files, "format": self.beam_format}


@dataclass(frozen=True)
class EvalSettings:
    """How candidates are solved and scored (the same for every row of one sweep)."""

    soil: Soil = field(default_factory=Soil)
    mesh: Any = None  # solvers.nec.MeshSettings; None = its defaults
    freqs_mhz: tuple[float, ...] = tuple(np.arange(40.0, 101.0))
    fom: FomSettings = field(default_factory=FomSettings)
    nec_workers: int = 2

    def mesh_settings(self):
        from solvers.nec import MeshSettings

        return self.mesh if self.mesh is not None else MeshSettings()

    def identity(self) -> dict[str, Any]:
        return {
            "soil": [self.soil.eps_r, self.soil.sigma],
            "mesh": self.mesh_settings().as_dict(),
            "freqs": [round(float(f), 6) for f in self.freqs_mhz],
            "fom": self.fom.as_dict(),
        }


def row_key(candidate: Candidate, settings: EvalSettings) -> str:
    """A stable key for (candidate, settings): a sweep never scores the same pair twice."""
    blob = json.dumps({"c": candidate.identity(), "s": settings.identity()}, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:20]


def candidate_beam(candidate: Candidate, settings: EvalSettings, progress: bool = False) -> tuple[Beam, float]:
    """The candidate's beam (solved or loaded) and the seconds it took."""
    t0 = time.perf_counter()
    if candidate.plane is None:
        from solvers import load_beam

        return load_beam(list(candidate.beam_paths), candidate.beam_format), time.perf_counter() - t0
    from solvers.nec import NecSolver

    solver = NecSolver(mesh=settings.mesh_settings(), workers=settings.nec_workers, progress=progress)
    beam = solver.solve(Design(candidate.plane, settings.soil), settings.freqs_mhz)
    return beam, time.perf_counter() - t0


SMOOTHING_DEGREE = 12  # Chebyshev degree over the band: keeps structure down to a ~10 MHz period


def smoothed_fom_mk(beam: Beam, settings: EvalSettings) -> float | None:
    """LST-averaged FoM of the beam after ``Beam.frequency_smoothed(SMOOTHING_DEGREE)``;
    None when the band has too few frequencies for that fit."""
    if beam.freqs_mhz.size < 2 * SMOOTHING_DEGREE + 1:
        return None
    return float(figure_of_merit(beam.frequency_smoothed(SMOOTHING_DEGREE), settings.fom).lst_averaged_fom_mk)


def solver_cpu_s(beam: Beam) -> float | None:
    """NEC time summed over frequencies, from the beam's own timings (None for exports)."""
    secs = beam.meta.get("seconds_per_frequency")
    return None if secs is None else round(float(np.sum(secs)), 2)


def score(candidate: Candidate, beam: Beam, settings: EvalSettings, seconds: float) -> dict[str, Any]:
    """The result row of a candidate whose beam is known."""
    result = figure_of_merit(beam, settings.fom)
    fom_mk = float(result.lst_averaged_fom_mk)
    if not math.isfinite(fom_mk):
        raise ValueError(f"candidate '{candidate.name}': FoM is not finite")
    residuals = {}
    for h in RESIDUAL_LSTS_H:
        i = int(np.argmin(np.abs(result.lst_hours - h)))
        residuals[f"{h:g}"] = (result.residuals[:, i] * 1e3).round(4).tolist()
    plane = candidate.plane
    return {
        "name": candidate.name,
        "status": "ok",
        "shape": plane.kind if plane else "beam-file",
        "params": plane.params() if plane else {"beam": list(candidate.beam_paths)},
        "metal_area_m2": plane.metal_area if plane else candidate.metal_area_m2,
        "extent_m": plane.extent if plane else None,
        "lst_averaged_fom_mk": fom_mk,
        # diagnostic: the FoM once narrow-band structure (solver artefacts) is smoothed out
        # of G(nu); see results/spectral_artefacts.md
        "fom_smoothed_mk": smoothed_fom_mk(beam, settings),
        "fom_mk": (result.fom * 1e3).round(4).tolist(),
        "lst_hours": result.lst_hours.round(6).tolist(),
        "fit_freqs_mhz": result.freqs_mhz[result.fit_mask].tolist(),
        "residuals_mk": residuals,
        "solve_s": round(seconds, 2),
        # what the solve cost, from the beam's own per-frequency timings: a cache hit has
        # solve_s ~ 0 but still reports this (wall time is about this over the worker count)
        "solver_cpu_s": solver_cpu_s(beam),
        "n_segments": beam.meta.get("n_segments"),
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


def failed_row(candidate: Candidate, reason: str) -> dict[str, Any]:
    plane = candidate.plane
    return {
        "name": candidate.name,
        "status": "failed",
        "error": reason,
        "shape": plane.kind if plane else "beam-file",
        "params": plane.params() if plane else {"beam": list(candidate.beam_paths)},
        "metal_area_m2": plane.metal_area if plane else candidate.metal_area_m2,
        "extent_m": plane.extent if plane else None,
        "lst_averaged_fom_mk": None,
    }
