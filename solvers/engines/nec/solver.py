"""NEC-2 solver: the blade dipole over a wire-grid ground plane on lossy soil
(Sommerfeld/Norton ground, GN 2) or over infinite perfect ground (GN 1), as a Beam.

* Absolute gain: NEC's input power at this feed is too high for practical blade grids
  (mean gain over PEC below 2: ``groundplane study feed-calibration``; the level
  converges slowly with the blade mesh). With ``gain_calibration="pec"`` (the default)
  each frequency is also solved for the same blade over infinite PEC, where the truth is
  known (lossless: mean gain over the upper hemisphere = 2), and the gain is divided by
  kappa(f) = that mean / 2. This assumes the feed-model error is the same over soil as
  over PEC (same blade mesh, same feed); kappa is recorded in the beam metadata.
* The wire grid leaks power into the soil and its spacing biases the FoM: see
  ``groundplane study mesh-convergence`` and ``results/mesh_convergence.md``.
* Far field: theta 0-90, phi 0-359 (1 deg). For a candidate mirror-symmetric about both
  axes only phi 0-90 is computed and mirrored. Below the horizon nothing is returned.
"""
from __future__ import annotations

from typing import ClassVar

from groundplane.design import Design, InfinitePEC
from groundplane.errors import SolveError

from ..base import FrequencySolver, Plan, register_engine
from . import engine
from .mesh import NecSettings, build_model, pec_reference_model

MODEL_VERSION = 1  # bump when the model changes: the cache key includes it


@register_engine
class NecSolver(FrequencySolver):
    """Solve designs with NEC-2 (pynec-accel); results cached by content."""

    name: ClassVar[str] = "nec"
    settings_class: ClassVar[type] = NecSettings
    model_version: ClassVar[int] = MODEL_VERSION
    allow_unverified_engine: bool = False

    def engine_identity(self) -> dict[str, str]:
        return engine.engine_info()

    def check(self, design: Design) -> None:
        ground = "pec" if isinstance(design.ground, InfinitePEC) else "soil"
        engine.check_engine(ground, allow_unverified=self.allow_unverified_engine, in_process=self.workers == 0)

    def plan(self, design: Design) -> Plan:
        try:
            model = build_model(design, self.settings)
        except SolveError:
            raise
        except Exception as exc:  # shapely/geometry trouble: name the candidate
            raise SolveError(f"{design.label()}: could not mesh the model ({exc})") from exc
        symmetric = design.plane is None or all(design.plane.mirror_symmetry.values())
        n_phi = 91 if symmetric else 360
        ref = None
        if self.settings.gain_calibration == "pec":
            ref = model if isinstance(design.ground, InfinitePEC) else pec_reference_model(design, self.settings)
        label = f"{design.plane.key() if design.plane else 'PEC'} ({model.n_segments} seg)"
        return Plan(engine.solve_frequency, (model, ref, n_phi), n_phi, {"n_segments": model.n_segments}, label)
