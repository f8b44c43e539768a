"""The surface engine as a :class:`~solvers.engines.base.Solver`: a design meshed
into triangles (``mesh.py``), solved by the RWG EFIE over infinite PEC ground, over soil
(Sommerfeld half-space, ``halfspace.py``) or in free space (``operators.py``), one frequency per
worker process, with the same content-keyed, per-frequency resumable cache as NEC. No gain
calibration: gain = 4 pi U / P_in. Radiated over input power is recorded per frequency as
``energy_balance``: 1 for a lossless model (over PEC and in free space), the radiation
efficiency over soil (what the soil absorbs is lost)."""
from __future__ import annotations

import json
import math
from importlib import metadata
from typing import ClassVar

import numpy as np

from groundplane.design import Design, Soil
from groundplane.errors import SettingsError, SolveError

from ..base import Plan, Solver, register_engine
from ..patterns import to_one_degree, upper_mean_gain
from ..workers import available_memory_bytes
from .dense import solve
from .farfield import gain_pattern
from .grid import TriMesh
from .mesh import SurfaceSettings, build_mesh
from .operators import Problem
from .space import MirrorSymmetry, rwg_basis

MODEL_VERSION = 4  # bump when the model changes: the cache key includes it
# 2: energy_balance (radiated / input power) recorded instead of the upper-hemisphere mean gain
# 3: quadrature points exactly at their triangle's height (a self pair's 1e-17 m "distance"
#    had wiped out self terms on some meshes); close pairs' outer rule on 16 sub-triangles
# 4: soil (Sommerfeld half-space); PEC and free-space answers unchanged
FAR_FIELD_STEP = 3  # deg; interpolated bicubically to 1 deg (as NEC's far field)
MAX_UNKNOWNS = 500_000  # 25x the largest plate of Table 3 at the default mesh
# memory_estimate of square-10 at 1 m over soil: 0.68 / 2.31 / 7.95 GiB at blade cells (12, 10) / (24, 20) /
# (36, 30): ~500 B for each (blade triangle)^2 beyond the default blade's
BLADE_BYTES_PER_PAIR = 512
FAST_BYTES_PER_UNKNOWN = 110_000  # a fast solve's worker: square-30 at 0.5 m estimated 2.14 GiB for 20364 unknowns
BASE_BYTES = 400 * 2**20


def DENSE_BYTES(n: int) -> int:  # noqa: N802 - a formula, named as the dense solve's memory
    """A dense solve's matrices (Z and the fill's products, complex doubles) for ``n`` unknowns."""
    return 16 * (2 * n * n + 2 * n * n)


def check_memory(n_unknowns: int, n_triangles: int, processes: int, label: str, reduced: bool = False) -> None:
    """Refuse, before any work, a dense solve whose matrices do not fit in memory: Z is N x N
    and the assembly keeps three T x N products (complex doubles). A ``reduced`` (mirror-
    symmetric) solve fills a quarter of the rows; half the full figure bounds it (the measured
    peaks behind that bound: docs/surface-engine.md)."""
    need = 16 * (n_unknowns ** 2 * 2 + 3 * n_triangles * n_unknowns) * processes // (2 if reduced else 1)
    have = available_memory_bytes()
    if have is not None and need > 0.8 * have:
        raise SettingsError(f"{label}: {n_unknowns} unknowns need about {need / 2**30:.1f} GiB on {processes} "
                            f"process(es); {have / 2**30:.1f} GiB is available. Use a coarser --mesh or "
                            "--blade-cells, or fewer --workers.")


OVER_REFINED = 4.0  # plate triangles per the count its area needs at the spacing: the presets have 1.5-1.7


def finer_than_asked(mesh: TriMesh, spacing: float) -> str:
    """Why the plate's mesh has far more triangles than its area needs at ``spacing`` (a feature
    the mesher must follow, far narrower than the mesh), naming its smallest triangle; '' if not."""
    plate = mesh.centroids[:, 2] < 0.5 * spacing  # the blade stands 1 m up; the sheet mm above the soil
    needed = mesh.areas[plate].sum() / (np.sqrt(3) / 4 * spacing ** 2)
    if not plate.any() or plate.sum() <= OVER_REFINED * max(needed, 1.0):
        return ""
    i = np.flatnonzero(plate)[np.argmin(mesh.sizes[plate])]
    x, y = mesh.centroids[i, :2]
    return (f" Its plate takes {int(plate.sum())} triangles where its area needs about {needed:.0f} at {spacing:g} m: "
            f"a feature about {1000 * mesh.sizes[i]:.0f} mm across near ({x:.2f}, {y:.2f}) m, far narrower than the "
            "mesh, sets their size; widen or remove it (a coarser --mesh does not help).")


def check_fast_memory(prob: Problem, symmetry: MirrorSymmetry | None, processes: int, label: str,
                      spacing: float | None = None) -> None:
    """Refuse, before any work, a fast solve whose workers would not fit in memory (saying so
    when a feature far finer than the mesh ``spacing`` is what makes it large)."""
    from .pfft import memory_estimate

    need = memory_estimate(prob, symmetry) * processes
    have = available_memory_bytes()
    if have is not None and need > 0.8 * have:
        why = finer_than_asked(prob.mesh, spacing) if spacing else ""
        raise SettingsError(f"{label}: the fast solve of {prob.n} unknowns needs about {need / 2**30:.1f} GiB on "
                            f"{processes} process(es); {have / 2**30:.1f} GiB is available."
                            + (why or " Use a coarser --mesh, or fewer --workers."))


def _soil(design: Design) -> tuple[float, float] | None:
    return (design.ground.eps_r, design.ground.sigma) if isinstance(design.ground, Soil) else None


def solve_frequency(payload: tuple, freq_mhz: float) -> tuple[np.ndarray, dict[str, float]]:
    """Worker job: the gain pattern [91, n_phi] at one frequency, the input impedance and
    the energy balance (radiated / input power: 1 for a lossless model over PEC or in free
    space, the radiation efficiency over soil)."""
    mesh, ground, n_phi, near_factor, soil, method = payload
    extras: dict[str, float] = {}
    if method == "fast":  # the design's frequency-independent parts are kept across this worker's frequencies
        from .pfft import problem_of, solve_fast

        prob = problem_of(mesh, ground, near_factor, soil)
        sol, stats = solve_fast(prob, freq_mhz * 1e6, symmetric=n_phi == 91)
        extras = {"gmres_iterations": float(stats.iterations), "gmres_residual": stats.residual}
        mirrored = stats.mirrored
    else:
        prob = Problem(mesh, rwg_basis(mesh), ground, near_factor, soil)
        symmetry = MirrorSymmetry.of(mesh, prob.rwg) if n_phi == 91 else None  # exact, ~4x faster
        sol = solve(prob, freq_mhz * 1e6, symmetry)
        mirrored = symmetry is not None
    step = FAR_FIELD_STEP
    phis = np.arange(0.0, 91.0 if n_phi == 91 else 360.0, step)
    if ground != "free":
        g = to_one_degree(gain_pattern(prob, sol, np.arange(0.0, 91.0, step), phis, mirrored_currents=mirrored),
                          step, quadrant=n_phi == 91)
        balance = upper_mean_gain(g) / 2.0  # all the power that is not absorbed goes up
    else:  # free space: half the power goes down, so integrate the whole sphere
        both = gain_pattern(prob, sol, np.arange(0.0, 181.0, step), phis, mirrored_currents=mirrored)
        g = to_one_degree(both[: 90 // step + 1], step, quadrant=n_phi == 91)
        below = to_one_degree(both[::-1][: 90 // step + 1], step, quadrant=n_phi == 91)
        balance = (upper_mean_gain(g) + upper_mean_gain(below)) / 2.0
    if not np.all(np.isfinite(g)) or sol.input_power <= 0:
        raise SolveError(f"surface engine: non-physical solution at {freq_mhz} MHz (input power {sol.input_power:g} W)")
    zin = sol.input_impedance
    return g, {"input_impedance_re": float(zin.real), "input_impedance_im": float(zin.imag),
               "energy_balance": balance, **extras}


def solve_soils(payload: tuple, freq_mhz: float) -> list[tuple[np.ndarray, dict[str, float], float]]:
    """Worker job of a group plan: one design on several soils at one frequency, the design's
    model and the frequency's soil-independent terms built once (``pfft``'s caches)."""
    import time

    base, soils = payload
    mesh, ground, _, near_factor, _, method = base
    t_shared = time.perf_counter()
    if method == "fast" and ground == "soil":  # every soil's Sommerfeld tables (one J0 matrix) and reflected
        from .pfft import fast_model, frequency_terms, problem_of, reflected_near  # near terms (one pass) together

        prob = problem_of(mesh, ground, near_factor, soils[0])
        model = fast_model(prob, base[2] == 91)
        reflected_near(model, frequency_terms(model, freq_mhz * 1e6), soils)
    shared = (time.perf_counter() - t_shared) / len(soils)  # what the soils did together, in equal shares
    out = []
    for soil in soils:
        t0 = time.perf_counter()
        gain, extras = solve_frequency((*base[:4], soil, base[5]), freq_mhz)
        out.append((gain, extras, time.perf_counter() - t0 + shared))
    return out


@register_engine
class SurfaceSolver(Solver):
    """Solve designs over infinite PEC ground, soil or in free space with the surface-current
    (RWG) engine."""

    name: ClassVar[str] = "surface"
    settings_class: ClassVar[type] = SurfaceSettings
    model_version: ClassVar[int] = MODEL_VERSION
    grounds: ClassVar[tuple[str, ...]] = ("pec", "soil", "free")
    title: ClassVar[str] = "the surface engine (solid-sheet plate)"

    def engine_identity(self) -> dict[str, str]:
        deps = {}
        for dist in ("numpy", "scipy", "triangle"):
            try:
                deps[dist] = metadata.version(dist)
            except metadata.PackageNotFoundError:
                deps[dist] = "?"
        return {"engine": "groundplane-rwg", "version": str(MODEL_VERSION), **deps}

    def solve_every(self) -> int:
        return self.settings.solve_every

    def share_key(self, design: Design) -> str | None:
        """A fast solve over soil shares everything but the soil's values with the same design
        on other soils (the model and each frequency's direct and image terms)."""
        if self.settings.method != "fast" or design.ground_kind != "soil":
            return None
        ident = self.identity(design, np.array([1.0]))
        ident["design"]["ground"] = "soil"
        return json.dumps(ident, sort_keys=True)

    def plan_group(self, designs: list[Design]) -> Plan:
        plan = self.plan(designs[0])
        soils = [_soil(d) for d in designs]
        return Plan(solve_soils, (plan.payload, soils), plan.n_phi, plan.meta, f"{plan.label} on {len(soils)} soils")

    def estimated_unknowns(self, design: Design) -> int:
        """Unknowns of the design's model before it is meshed: the plate's area over the mesh's
        triangle (Triangle's quality meshes run 1.64x the equilateral count: sawtooth-20-16 and
        square-30 at 0.5 m) x 1.5 edges a triangle, and the blade's grid."""
        nx, ny = self.settings.blade_cells
        plate = design.plane.metal_area if design.plane is not None else 0.0
        triangles = 1.64 * plate / (math.sqrt(3) / 4 * self.settings.spacing ** 2) + 4 * nx * ny
        return int(1.5 * triangles)

    def precheck(self, design: Design) -> None:
        """Refuse, before meshing (which alone took minutes and gigabytes at 1-5 cm), a model
        whose estimated size does not fit in memory on this solve's processes."""
        n = self.estimated_unknowns(design)
        nx, ny = self.settings.blade_cells
        # the blade's triangles lie within one another's near zone (it spans ~1.3 m), so its near pairs
        # grow as the square of its cells, which the per-unknown figure (set at the default blade) misses:
        # --blade-cells 100 100 ran out of memory after 54 s inside the exact estimate's near search
        extra_pairs = max(0, (4 * nx * ny) ** 2 - (4 * 12 * 10) ** 2)
        per_unknown = (DENSE_BYTES(n) if self.settings.method == "dense" else
                       FAST_BYTES_PER_UNKNOWN * n + BLADE_BYTES_PER_PAIR * extra_pairs)
        need = (per_unknown + BASE_BYTES) * self.processes
        have = available_memory_bytes()
        if n > MAX_UNKNOWNS or (have is not None and need > 0.8 * have):
            raise SettingsError(f"{design.label()}: about {n:,} unknowns at {self.settings.spacing:g} m would need about "
                                f"{need / 2**30:.1f} GiB on {self.processes} process(es)"
                                + (f" ({have / 2**30:.1f} GiB available)" if have is not None else "")
                                + f"; at most {MAX_UNKNOWNS:,} unknowns are solved. Use a coarser --mesh or --blade-cells, or fewer "
                                "--workers.")

    def plan(self, design: Design) -> Plan:
        self.precheck(design)
        mesh: TriMesh = self.meshed(design, lambda: build_mesh(design, self.settings))
        rwg = self.meshed(design, lambda: rwg_basis(mesh))
        symmetric = self.quadrant(design)
        n_phi = 91 if symmetric else 360
        symmetry = MirrorSymmetry.of(mesh, rwg) if symmetric else None  # as each worker will find it
        if self.settings.method == "dense":
            check_memory(rwg.n, len(mesh.tris), self.processes, design.label(), symmetry is not None)
        else:
            check_fast_memory(Problem(mesh, rwg, design.ground_kind, self.settings.near_factor, _soil(design)),
                              symmetry, self.processes, design.label(), self.settings.spacing)
        what = design.plane.describe() if design.plane else "blade"
        where = {"pec": "over PEC", "soil": "over soil", "free": "in free space"}[design.ground_kind]
        label = f"{what} {where} ({rwg.n} unknowns)"
        meta = {"n_unknowns": rwg.n, "n_triangles": len(mesh.tris)}
        payload = (mesh, design.ground_kind, n_phi, self.settings.near_factor, _soil(design), self.settings.method)
        return Plan(solve_frequency, payload, n_phi, meta, label)
