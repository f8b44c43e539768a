"""The FDTD referee as a :class:`~solvers.engines.base.Solver`: gprMax (a volume, time-domain
method sharing nothing with the two MoM engines) on a Yee grid, the soil as a lossy material in
the grid and as a layered background for the far-field transform. One run gives every
frequency (a ``broadband`` plan); gain = 4 pi U / accepted power at the port; the ground loss is
integrated here from the gain over the upper hemisphere (gprMax's own full-sphere
normalisation took over 40 min on the deployed plane: ``shared/referee``)."""
from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from groundplane.design import Design
from groundplane.errors import SettingsError, SolveError
from groundplane.sky import cache_dir

from ..base import Plan, Solver, register_engine
from ..patterns import to_one_degree, upper_mean_gain
from ..workers import available_memory_bytes
from . import run
from .model import BYTES_PER_CELL, FAR_FIELD_STEP, FdtdModel, FdtdSettings, build_model, estimated_cells

MODEL_VERSION = 1  # bump when the model changes: the cache key includes it


def _pattern(grid: np.ndarray, model: FdtdModel) -> tuple[np.ndarray, float]:
    """gprMax's 3-degree gain grid -> the 1-degree upper hemisphere, and the energy balance
    (radiated over accepted power: 1 for a lossless model, the radiation efficiency over soil).
    Over a ground the horizon row is 0: the blade's currents are horizontal, and a horizontal
    current's field vanishes along a perfect or lossy ground (its image cancels it there)."""
    quadrant = model.quadrant
    if model.ground == "free":
        upper = to_one_degree(grid[: 90 // FAR_FIELD_STEP + 1], FAR_FIELD_STEP, quadrant)
        lower = to_one_degree(grid[::-1][: 90 // FAR_FIELD_STEP + 1], FAR_FIELD_STEP, quadrant)
        return upper, (upper_mean_gain(upper) + upper_mean_gain(lower)) / 2.0
    rows = np.vstack([grid, np.zeros((1, grid.shape[1]))])  # 0..87 deg, then the horizon
    g = to_one_degree(rows, FAR_FIELD_STEP, quadrant)
    return g, upper_mean_gain(g) / 2.0


def check_memory(model: FdtdModel, n_freqs: int, label: str) -> tuple[int, float]:
    """Refuse, before gprMax starts, a grid that does not fit in memory; (bytes, seconds) expected."""
    need, secs = model.cost(n_freqs, os.cpu_count() or 1)
    have = available_memory_bytes()
    if have is not None and need > 0.8 * have:
        raise SettingsError(f"{label}: {model.n_cells / 1e6:.1f} M cells of {model.dx:g} m need about "
                            f"{need / 2**30:.1f} GiB; {have / 2**30:.1f} GiB is available. Use a coarser --cell.")
    return need, secs


def solve_run(payload: tuple, freqs: list[float]):
    """Broadband job: one gprMax run for ``freqs``; yields (freq, (gain, extras), seconds)."""
    model, label, root, progress = payload
    text = model.input_file(freqs)
    cores = os.cpu_count() or 1
    need, secs = check_memory(model, len(freqs), label)
    if progress:
        print(f"fdtd {label}: {model.n_cells / 1e6:.2f} M cells x {model.steps} steps, {len(freqs)} frequencies: "
              f"about {need / 2**30:.1f} GiB and {secs / 60:.0f} min on {cores} cores", file=sys.stderr, flush=True)
    scratch = root is None
    base = Path(tempfile.mkdtemp(prefix="gp-fdtd-")) if scratch else root
    run_dir = base if scratch else run.run_dir_for(base, text)
    t0 = time.perf_counter()
    out = run.run_gprmax(text, run_dir, label, model.steps, progress)  # a failed run keeps its folder (and log)
    fields = run.read_far_field(out, freqs)
    if scratch:
        import shutil

        shutil.rmtree(base, ignore_errors=True)
    each = (time.perf_counter() - t0) / len(freqs)
    results = []
    for f in freqs:
        grid, zin, valid = fields[f]
        if not valid or not np.all(np.isfinite(grid)):
            raise SolveError(f"{label}: gprMax's gain at {f:g} MHz is not valid (the source's spectrum or the "
                             "accepted power is too small there)")
        gain, balance = _pattern(np.clip(grid, 0.0, None), model)
        results.append((f, (gain, {"input_impedance_re": zin.real, "input_impedance_im": zin.imag,
                                   "energy_balance": balance}), each))
    if not scratch:
        run.remove_run(run_dir)  # the beam is cached frequency by frequency next; the bulky output goes
    yield from results


@register_engine
class FdtdSolver(Solver):
    """Solve designs with gprMax's FDTD over soil, PEC or in free space: the referee."""

    name: ClassVar[str] = "fdtd"
    settings_class: ClassVar[type] = FdtdSettings
    model_version: ClassVar[int] = MODEL_VERSION
    grounds: ClassVar[tuple[str, ...]] = ("soil", "pec", "free")
    title: ClassVar[str] = "gprMax FDTD (staircased plate, soil in the grid)"
    size_unit: ClassVar[str] = "cells"
    # the whole model is on the grid; 20 per free-space wavelength is ~9 in eps_r 5 soil (FDTD's usual
    # floor is 10 in the densest medium); 40 is the 7.5 cm cell the ladders converged at (docs/fdtd.md)
    cells_per_wavelength: ClassVar[tuple[float, float]] = (20.0, 40.0)

    def mesh_cell_m(self, design: Design) -> float | None:
        return float(self.settings.cell)

    def engine_identity(self) -> dict[str, str]:
        return run.engine_info()

    def known_differences(self) -> list[str]:
        return ["the plate and blade are staircased to the Yee grid, and the feed is a one-cell voltage source "
                "(its input impedance differs from the MoM engines' feeds by 20-35 ohm: `docs/fdtd.md`)"]

    def check(self, design: Design) -> None:
        super().check(design)
        run.check_engine()

    def model(self, design: Design, f_max_hz: float = 100e6) -> FdtdModel:
        """The design on the grid."""
        return self.meshed(design, lambda: build_model(design, self.settings, f_max_hz, self.quadrant(design)))

    def input_deck(self, design: Design, freqs_mhz) -> str:
        """The gprMax input file of the design's model (what ``--deck`` writes)."""
        freqs = [float(f) for f in freqs_mhz]
        return self.model(design, max(freqs) * 1e6).input_file(freqs)

    def why_unresolved(self, plane: Any) -> str | None:
        """A feature under two cells is not drawn by the staircase."""
        outline = plane.outline()
        thin = outline.buffer(-self.settings.cell).area
        if thin <= 0:
            return f"the plane is under two {self.settings.cell:g} m cells across"
        return None

    def plan(self, design: Design) -> Plan:
        cells = estimated_cells(design, self.settings)
        have = available_memory_bytes()
        if have is not None and BYTES_PER_CELL * cells > 0.8 * have:  # refused before anything is rasterised
            raise SettingsError(f"{design.label()}: about {cells / 1e6:.0f} M cells of {self.settings.cell:g} m need "
                                f"over {BYTES_PER_CELL * cells / 2**30:.0f} GiB; {have / 2**30:.1f} GiB is available. "
                                "Use a coarser --cell.")
        model = self.model(design)
        check_memory(model, 1, design.label())
        what = design.plane.describe() if design.plane else "blade"
        where = {"pec": "over PEC", "soil": "over soil", "free": "in free space"}[design.ground_kind]
        label = f"{what} {where} ({model.n_cells / 1e6:.2f} M cells)"
        meta = {"n_cells": model.n_cells, "time_steps": model.steps,
                "fdtd_metal_area_m2": model.metal_area if design.plane is not None else 0.0}
        root = cache_dir() / "fdtd" if self.use_cache else None
        return Plan(solve_run, (model, label, root, self.progress), 91 if model.quadrant else 360, meta, label,
                    broadband=True)
