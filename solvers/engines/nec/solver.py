"""NEC-2 solver: the blade dipole over a wire-grid ground plane on lossy soil
(Sommerfeld/Norton ground, GN 2), over infinite perfect ground (GN 1; the blade alone or
above a plate), or in free space (GN -1; the cross-engine case), as a Beam.

* Absolute gain: NEC's input power at this feed is too high for practical blade grids
  (mean gain over PEC below 2: ``groundplane study feed-calibration``; the level
  converges slowly with the blade mesh). With ``gain_calibration="pec"`` (the default)
  each frequency is also solved for the same blade over infinite PEC, where the truth is
  known (lossless: mean gain over the upper hemisphere = 2), and the gain is divided by
  kappa(f) = that mean / 2. This assumes the feed-model error is the same over soil as
  over PEC (same blade mesh, same feed); kappa is recorded in the beam metadata.
* The wire grid leaks power into the soil and its spacing biases the FoM:
  ``groundplane study mesh-convergence --engine nec`` measures by how much.
* Far field: theta 0-90, phi 0-359 at 1 deg, computed by NEC every ``far_field_step``
  deg (3 by default) and interpolated bicubically (the 1-deg far-field sum cost as much as
  fill + LU). For a candidate mirror-symmetric about both axes only phi 0-90 is computed
  and mirrored. Below the horizon nothing is returned.
* Symmetric candidates are solved as half a model plus NEC's 180-degree rotation (GR):
  see ``mesh.py``; the blade-over-PEC calibration is solved once per blade model and
  frequency and kept in the cache (``calibration/``).
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import replace
from pathlib import Path
from typing import ClassVar

import numpy as np

from groundplane.design import Design, InfinitePEC
from groundplane.errors import SettingsError
from groundplane.sky import cache_dir

from ..base import Plan, Solver, register_engine
from ..workers import available_memory_bytes
from . import engine
from .mesh import NecModel, NecSettings, build_model, estimated_segments, pec_reference_model

MODEL_VERSION = 2  # bump when the model changes: the cache key includes it
# 2: split feed (two half-gap segments, V/2 each) for the GR symmetry; far field on a coarse
#    grid interpolated to 1 deg; the blade turned (0.964 m along the axis, SPEC section 1);
#    symmetric plate meshes (node merging decided on the folded quadrant)


def matrix_bytes(n_segments: int, sections: int = 1) -> int:
    """NEC-2's interaction matrix: N^2 / sections complex doubles (the dominant memory)."""
    return 16 * n_segments ** 2 // sections


def check_memory(n_segments: int, sections: int, processes: int, label: str, estimated: bool = False) -> None:
    """Refuse, before any NEC work, a model whose matrices do not fit in memory (``estimated``:
    the segment count is the outline's estimate, before the mesh is built)."""
    each = matrix_bytes(n_segments, sections)
    have = available_memory_bytes()
    if have is not None and each * processes > 0.8 * have:
        what = f"about {n_segments} plate segments" if estimated else f"{n_segments} segments"
        raise SettingsError(
            f"{label}: {what} need about {each * processes / 2**30:.1f} GiB for NEC's matrices "
            f"on {processes} process(es) ({each / 2**30:.1f} GiB each); {have / 2**30:.1f} GiB is available. Use a "
            "coarser --mesh or fewer --workers.")


@register_engine
class NecSolver(Solver):
    """Solve designs with NEC-2 (pynec-accel) over soil, PEC or in free space; the antenna's
    extra parts as wire grids too. Results cached by content."""

    name: ClassVar[str] = "nec"
    settings_class: ClassVar[type] = NecSettings
    model_version: ClassVar[int] = MODEL_VERSION
    grounds: ClassVar[tuple[str, ...]] = ("soil", "pec", "free")
    antenna_parts: ClassVar[bool] = True

    def engine_identity(self) -> dict[str, str]:
        return engine.engine_info()

    def input_deck(self, design: Design, freqs_mhz) -> str:
        """The NEC-2 card deck of the design's model (what ``--deck`` writes)."""
        return build_model(design, self.settings).to_deck(list(freqs_mhz), design.label())

    title: ClassVar[str] = "NEC-2 (wire-grid plate)"
    size_unit: ClassVar[str] = "segments"

    def known_differences(self) -> list[str]:
        return ["the paper's FEKO plate is a solid sheet on the soil, ours a wire grid a few mm above it, which "
                "leaks more power into the soil and carries narrow-band structure (`results/plate_model.md`)"]

    def why_unresolved(self, plane) -> str | None:
        """The wire grid merges nodes within ``merge_fraction`` of a cell: an outline edge under
        half a cell is moved by the mesh, so the model is not the plane drawn."""
        v = np.asarray(plane.outline().exterior.coords)
        edge = float(np.hypot(*np.diff(v, axis=0).T).min())
        if edge < 0.5 * self.settings.spacing:
            return f"a {edge:.2f} m outline edge is under half a mesh cell ({0.5 * self.settings.spacing:g} m)"
        return None

    def check(self, design: Design) -> None:
        super().check(design)
        engine.check_engine(design.ground_kind, in_process=self.workers == 0)

    def plan(self, design: Design) -> Plan:
        if design.plane is not None:  # a mesh far too fine is refused before it is built (that alone can take hours)
            check_memory(estimated_segments(design.plane, self.settings.spacing), 2, self.processes, design.label(),
                         estimated=True)  # 2: even with NEC's rotational symmetry
        model = self.meshed(design, lambda: build_model(design, self.settings))
        check_memory(model.n_segments, model.sections, self.processes, design.label())
        n_phi = 91 if self.quadrant(design) else 360
        job = engine.NecJob(model, n_phi, self.settings.far_field_step)
        if self.settings.gain_calibration == "pec":
            if design.plane is None and isinstance(design.ground, InfinitePEC):  # the blade over PEC itself
                job = replace(job, calibration="self")
            else:
                ref = pec_reference_model(design, self.settings)
                job = replace(job, calibration="reference", reference=ref,
                              store=str(self._calibration_store(ref)) if self.use_cache else None)
        label = f"{design.plane.describe() if design.plane else 'blade over PEC'} ({model.n_segments} seg)"
        meta = {"n_segments": model.n_segments, "rotational_symmetry_sections": model.sections}
        return Plan(engine.solve_frequency, job, n_phi, meta, label)

    def _calibration_store(self, ref: NecModel) -> Path:
        """Where the blade-over-PEC calibration of this blade model is kept (by content)."""
        ident = {"model_version": MODEL_VERSION, "engine": self.engine_identity(), "deck": ref.to_deck([1.0]),
                 "far_field_step": self.settings.far_field_step}
        key = hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()[:32]
        return cache_dir() / "calibration" / key
