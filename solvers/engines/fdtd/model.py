"""The FDTD referee's model of a design on a Yee grid, as a gprMax input file (pure geometry:
nothing here runs or imports gprMax). Lengths in metres; x is the excitation axis, z up.

The blade's feed is one x-directed cell edge (gprMax's one-cell voltage source) at the centre of
the panels, so the source sits on both of the panels' axes of symmetry (off-axis by half a cell,
the blade alone differed from the surface engine by 1.1 dB rms at 100 MHz: ``shared/referee``).
A zero-thickness PEC plate on a Yee grid acts about half a cell larger at its free edges, so the
panels are drawn that much smaller than the blade (``panel_cells``); the plane is the cells whose
centres lie inside its outline (the staircase keeps both mirror symmetries), and the metal area
that staircase holds is recorded beside the outline's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from groundplane.antenna import BladeDipole
from groundplane.design import Design, Soil
from groundplane.errors import SettingsError
from groundplane.options import option

C0 = 299_792_458.0
EPS0 = 8.8541878128e-12
FAR_FIELD_STEP = 3  # deg, as the other engines: interpolated bicubically to 1 deg
# what the last sampled row before the horizon is: gprMax's layered far field observes only
# through the open upper half-space, not along the interface itself
LAST_THETA_DEG = 87
PEC_UNSEEN = 1e-3  # the far field's soil is a layer over PEC: its round trip attenuates the PEC's echo this much
MAX_SOIL_LAYER_M = 200.0


@dataclass(frozen=True)
class FdtdSettings:
    """The FDTD referee's grid (gprMax): cell size, where the plate sits on the soil, the
    simulated time and the absorbing layers. A separate model from the MoM engines' plate mesh."""

    cell: float = option(0.05, "fdtd: Yee cell size (m); the plane is staircased to it (its metal area is recorded)")
    plate_position: str = option("on", "fdtd: the plate's PEC on the soil surface ('on') or one cell above it "
                                 "('above'): the surface engine's 5 mm sheet lies between the two",
                                 choices=("on", "above"))
    time_window_ns: float = option(0.0, "fdtd: simulated time (ns); 0: 200 ns + 2 R/c for metal reaching R m from "
                                   "the feed (the edge echoes must have rung down)")
    pml_cells: int = option(20, "fdtd: absorbing (PML) cells on each open face of the grid (10 left a 1e-3 ripple on "
                            "the gain spectrum that raised the blade-over-PEC FoM 9x: docs/fdtd.md)")

    def __post_init__(self) -> None:
        if not (isinstance(self.cell, (int, float)) and math.isfinite(self.cell) and 0.005 <= self.cell <= 0.25):
            raise SettingsError(f"fdtd cell must be 0.005-0.25 m, got {self.cell}: coarser does not resolve the "
                                "blade (0.96 m panels), finer is billions of cells on any plane")
        if self.plate_position not in ("on", "above"):
            raise SettingsError(f"fdtd plate_position must be 'on' or 'above', got {self.plate_position!r}")
        if not (math.isfinite(self.time_window_ns) and 0 <= self.time_window_ns <= 10_000):
            raise SettingsError(f"fdtd time_window_ns must be 0 (automatic) to 10000 ns, got {self.time_window_ns}")
        if not (isinstance(self.pml_cells, int) and 6 <= self.pml_cells <= 40):
            raise SettingsError(f"fdtd pml_cells must be 6-40, got {self.pml_cells}")

    def as_dict(self) -> dict[str, Any]:
        return {"cell": self.cell, "plate_position": self.plate_position, "time_window_ns": self.time_window_ns,
                "pml_cells": self.pml_cells}

    def label(self) -> str:
        """The model in words, for tables."""
        where = "on the soil" if self.plate_position == "on" else "one cell above the soil"
        return f"fdtd {self.cell * 100:g} cm cells, plate {where}"


def panel_cells(antenna: BladeDipole, dx: float) -> tuple[int, int, int]:
    """(cells along the axis, cells across it, cells of height) of the blade on the grid.

    Each panel's free edges are drawn half a cell inside the blade (a PEC sheet on the grid acts
    about half a cell larger there): along the axis one free edge (the inner one is the feed),
    across it two, kept to an even count so the feed lies on the axis of symmetry. This rule was
    read off the deployed plane's comparison (``shared/referee``: 0.95 x 1.20 m panels at 5 cm
    matched the 0.964 x 1.252 m blade best) and is checked on other cases in ``docs/fdtd.md``."""
    n_along = max(2, round(antenna.panel_length / dx - 0.5))
    n_across = 2 * max(1, round((antenna.panel_width / dx - 1.0) / 2))
    n_up = max(2, round(antenna.height / dx))
    return n_along, n_across, n_up


def soil_attenuation(soil: Soil, freq_hz: float) -> float:
    """Amplitude attenuation (Np/m) of a plane wave in the soil."""
    w = 2 * math.pi * freq_hz
    eps = soil.eps_r * EPS0
    loss = soil.sigma / (w * eps)
    return w * math.sqrt(4e-7 * math.pi * eps / 2) * math.sqrt(math.sqrt(1 + loss * loss) - 1)


def soil_layer_depth(soil: Soil, f_min_hz: float) -> float:
    """How deep the far field's soil layer goes before its PEC floor (gprMax's layered far field
    needs a lossless or PEC-terminated bottom): the depth whose round trip attenuates the floor's
    echo by ``PEC_UNSEEN`` at the lowest frequency, so the far field sees a half-space."""
    alpha = soil_attenuation(soil, f_min_hz)
    depth = math.log(1 / PEC_UNSEEN) / (2 * alpha) if alpha > 0 else math.inf
    if depth > MAX_SOIL_LAYER_M:
        need = "an endless layer" if math.isinf(depth) else f"{depth:.0f} m of soil at {f_min_hz / 1e6:g} MHz"
        raise SettingsError(f"soil eps_r={soil.eps_r} sigma={soil.sigma} S/m is too nearly lossless for the fdtd far "
                            f"field (its half-space is a layer over PEC, which would need {need} to hide the "
                            "floor); use sigma >= 0.001 S/m")
    return max(5.0, depth)


@dataclass
class FdtdModel:
    """A design on the grid: cells, metal and the gprMax input, for a set of frequencies."""

    dx: float
    n: tuple[int, int, int]  # cells of the domain in x, y, z
    feed: tuple[int, int, int]  # node of the source edge's start (it runs to i + 1)
    plates: list[tuple[float, float, float, float, float]] = field(default_factory=list)  # x1 y1 x2 y2 z
    ntff: tuple[float, ...] = ()
    soil: Soil | None = None
    soil_top: float = 0.0
    ground: str = "soil"
    pml: tuple[int, ...] = (10,) * 6
    metal_cells: int = 0
    window_s: float = 0.0
    quadrant: bool = False
    title: str = ""

    @property
    def n_cells(self) -> int:
        return int(np.prod(self.n))

    @property
    def dt(self) -> float:
        """gprMax's time step (the 3-D Courant limit)."""
        return 1.0 / (C0 * math.sqrt(3.0 / self.dx ** 2))

    @property
    def steps(self) -> int:
        return int(math.ceil(self.window_s / self.dt))

    @property
    def metal_area(self) -> float:
        """The staircased plane's metal (m^2): what the grid holds, not the outline."""
        return self.metal_cells * self.dx ** 2

    def ntff_patches(self) -> int:
        """Cells on the far-field surface (each carries six field DFTs per frequency)."""
        x1, y1, z1, x2, y2, z2 = self.ntff
        a, b, c = ((x2 - x1) / self.dx, (y2 - y1) / self.dx, (z2 - z1) / self.dx)
        return int(2 * (a * b + a * c + b * c))

    def far_field_directions(self) -> tuple[np.ndarray, np.ndarray]:
        """The theta and phi rows (deg) asked of gprMax's far field."""
        top = 180 if self.ground == "free" else LAST_THETA_DEG  # free space: both hemispheres (the power balance)
        th = np.arange(0, top + 1, FAR_FIELD_STEP, dtype=float)
        ph = np.arange(0, 91 if self.quadrant else 360, FAR_FIELD_STEP, dtype=float)
        return th, ph

    def input_file(self, freqs_mhz: list[float]) -> str:
        """The gprMax input for these frequencies (all from one run)."""
        dx = self.dx
        nx, ny, nz = self.n
        X, Y, Z = nx * dx, ny * dx, nz * dx
        i0, j0, k0 = self.feed
        f_hz = [f * 1e6 for f in freqs_mhz]
        fc = 0.8 * max(f_hz)  # a Gaussian pulse's spectrum, exp(-f^2 / (2 fc^2)), still > -4 dB at the top frequency
        lines = [f"#title: {self.title}", f"#domain: {X:.6g} {Y:.6g} {Z:.6g}", f"#dx_dy_dz: {dx:g} {dx:g} {dx:g}",
                 f"#time_window: {self.window_s:.6g}", "#pml_cells: " + " ".join(str(p) for p in self.pml)]
        if self.soil is not None:
            lines += [f"#material: {self.soil.eps_r:g} {self.soil.sigma:g} 1 0 soil",
                      f"#box: 0 0 0 {X:.6g} {Y:.6g} {self.soil_top:.6g} soil"]
        lines += [f"#plate: {x1:.6g} {y1:.6g} {z:.6g} {x2:.6g} {y2:.6g} {z:.6g} pec" for x1, y1, x2, y2, z in self.plates]
        xs, ys, zs = i0 * dx, j0 * dx, k0 * dx
        lines += [f"#waveform: gaussian 1 {fc:.6g} pulse",
                  f"#voltage_source: x {xs:.6g} {ys:.6g} {zs:.6g} 50 pulse 0 {self.window_s:.6g} feed 10",
                  "#ntff_surface: " + " ".join(f"{v:.6g}" for v in self.ntff) + " box1" + self._omitted()]
        freqs = " ".join(f"{f:.9g}" for f in f_hz)
        if self.ground == "soil":
            depth = soil_layer_depth(self.soil, min(f_hz))  # type: ignore[arg-type]
            lines += [f"#ntff_layered_background: bg z free_space {self.soil_top:.6g} soil "
                      f"{self.soil_top - depth:.6g} pec", f"#ntff_layered_frequency: box1 ff bg {freqs}"]
        elif self.ground == "pec":
            lines += ["#ntff_layered_background: bg z free_space 0 pec", f"#ntff_layered_frequency: box1 ff bg {freqs}"]
        else:
            lines += [f"#ntff_frequency: box1 ff {freqs}"]
        th, ph = self.far_field_directions()
        lines += ["#ntff_antenna_ports: ff feed",
                  f"#ntff_far_field_array: {th[0]:g} {th[-1]:g} {FAR_FIELD_STEP} {ph[0]:g} {ph[-1]:g} {FAR_FIELD_STEP} "
                  "ff pattern gain"]
        return "\n".join(lines) + "\n"

    def _omitted(self) -> str:
        return " z0" if self.ground == "pec" else ""

    def cost(self, n_freqs: int, cores: int) -> tuple[int, float]:
        """(bytes, seconds) the run is expected to take, from the cells, steps, far-field patches
        and directions (rates measured on this project's machines: ``docs/fdtd.md``)."""
        patches = self.ntff_patches()
        th, ph = self.far_field_directions()
        mem = BASE_BYTES + BYTES_PER_CELL * self.n_cells + 6 * patches * n_freqs * BYTES_PER_PATCH_FREQ
        core_scale = 2.0 / max(1, cores)
        stepping = self.steps * (self.n_cells / CELL_STEPS_PER_S + 6 * patches * n_freqs / DFT_UPDATES_PER_S)
        far = th.size * ph.size * n_freqs * patches / FAR_FIELD_TERMS_PER_S
        return int(mem), core_scale * (stepping + far)


# rates measured on this project's 2-core machines (docs/fdtd.md: the ladder and verdict runs)
BASE_BYTES = 350 * 2**20
BYTES_PER_CELL = 125
BYTES_PER_PATCH_FREQ = 16  # complex64 field and its normal derivative
CELL_STEPS_PER_S = 5.5e7
DFT_UPDATES_PER_S = 4e8
FAR_FIELD_TERMS_PER_S = 1.4e7


def _cells_inside(outline, i_range: np.ndarray, j_range: np.ndarray, dx: float):
    """Metal cells of the plane: those whose centres lie inside the outline, as a boolean [i, j]
    array over ``i_range`` x ``j_range`` (cells counted from the feed edge's start node, which is
    half a cell before the feed: cell i is centred at x = i dx, cell j at y = (j + 1/2) dx)."""
    import shapely

    xc = i_range * dx
    yc = (j_range + 0.5) * dx
    gx, gy = np.meshgrid(xc, yc, indexing="ij")
    return shapely.contains_xy(outline, gx, gy)


def _mirrored(mask: np.ndarray, symmetry: dict[str, bool]) -> np.ndarray:
    """The staircase of a mirror-symmetric plane made exactly symmetric: one half's cells copied
    to the other (a cell centre lying on the outline, as at a tooth's tip, would otherwise be
    decided by rounding, differently on each side). ``mask`` spans i in [-m, m], j in [-n-1, n]."""
    mask = mask.copy()
    m = mask.shape[0] // 2
    if symmetry.get("y"):  # x -> -x: cell i <-> -i
        mask[:m] = mask[:m:-1]
    if symmetry.get("x"):  # y -> -y: cell j <-> -j - 1
        h = mask.shape[1] // 2
        mask[:, :h] = mask[:, :h - 1:-1]
    return mask


def _rectangles(mask: np.ndarray) -> list[tuple[int, int, int, int]]:
    """The metal cells of ``mask`` [i, j] as few rectangles (i1, j1, i2, j2, cells inclusive):
    runs along i per row j, rows with the same runs merged (one #plate each)."""
    out: list[tuple[int, int, int, int]] = []
    open_runs: dict[tuple[int, int], int] = {}
    for j in range(mask.shape[1] + 1):
        col = mask[:, j] if j < mask.shape[1] else np.zeros(mask.shape[0], bool)
        edges = np.flatnonzero(np.diff(np.concatenate([[0], col.astype(np.int8), [0]])))
        runs = {(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2])}
        for run in list(open_runs):
            if run not in runs:
                out.append((run[0], open_runs.pop(run), run[1], j - 1))
        for run in runs:
            open_runs.setdefault(run, j)
    return out


def _heights(ground: str, settings: FdtdSettings, dx: float, gap: int, has_plane: bool) -> tuple[int, int, int, tuple]:
    """(soil surface, plate, far-field surface's bottom) in cells up the grid, and the PML per face:
    over soil the far-field surface dips into it; over PEC the grid's floor is the ground (no PML
    there, the surface open onto it); in free space the plate floats with air all round."""
    pml = settings.pml_cells
    below = max(3, math.ceil(0.3 / dx))  # the far-field surface's bottom, under the soil surface or the plate
    if ground == "soil":
        k_soil = pml + gap + below
        return k_soil, k_soil + (0 if settings.plate_position == "on" else 1), k_soil - below, (pml,) * 6
    if ground == "pec":
        return 0, max(1, round(0.005 / dx)) if has_plane else 0, 0, (pml, pml, 0, pml, pml, pml)
    k_plate = pml + gap + below
    return 0, k_plate, k_plate - below, (pml,) * 6


def estimated_cells(design: Design, settings: FdtdSettings) -> int:
    """The grid's cells from the outline's bounds alone (before anything is rasterised), within a
    few per cent of :func:`build_model`'s: what a memory check needs first."""
    dx = settings.cell
    x0, y0, x1, y1 = design.plane.outline().bounds if design.plane is not None else (-1.0, -0.7, 1.0, 0.7)
    edge = 2 * (settings.pml_cells + 3 + max(3, math.ceil(0.25 / dx)))
    nz = 2 * settings.pml_cells + 6 + max(3, math.ceil(0.3 / dx)) + max(4, math.ceil(0.5 / dx)) + \
        round(design.antenna.height / dx)
    return int(((x1 - x0) / dx + edge) * ((y1 - y0) / dx + edge) * nz)


def build_model(design: Design, settings: FdtdSettings, f_max_hz: float = 100e6, quadrant: bool = False) -> FdtdModel:
    """The design on the grid: the blade on its axis of symmetry, the plane staircased, the soil
    box, the far-field surface around the metal and the PML around that."""
    dx = settings.cell
    n_along, n_across, n_up = panel_cells(design.antenna, dx)
    if isinstance(design.ground, Soil):
        lam = C0 / (f_max_hz * math.sqrt(design.ground.eps_r))
        if dx > lam / 10:
            raise SettingsError(f"fdtd cell {dx:g} m is over a tenth of the wavelength in the soil at "
                                f"{f_max_hz / 1e6:g} MHz ({lam:.2f} m): use --cell {lam / 10:.3f} or finer")
    pad = max(3, math.ceil(0.25 / dx))  # metal to the far-field surface
    gap = 3  # far-field surface to the PML
    pml = settings.pml_cells
    # metal extent in cells about the feed edge's start node (i0, j0): panels first
    lo_i, hi_i = -n_along, 1 + n_along
    lo_j, hi_j = -n_across // 2, n_across // 2
    mask = None
    plane = design.plane
    if plane is not None:
        x0, y0, x1, y1 = plane.outline().bounds
        m = math.ceil(max(abs(x0), abs(x1)) / dx) + 2  # cells from the feed edge's start node, symmetric
        n = math.ceil(max(abs(y0), abs(y1)) / dx) + 2  # about the feed (cell i <-> -i, j <-> -j - 1)
        i_rng, j_rng = np.arange(-m, m + 1), np.arange(-n - 1, n + 1)
        mask = _mirrored(_cells_inside(plane.outline(), i_rng, j_rng, dx), plane.mirror_symmetry)
        if not mask.any():
            raise SettingsError(f"{design.label()}: no cell of {dx:g} m lies inside the plane's outline")
        ii, jj = np.nonzero(mask)
        lo_i, hi_i = min(lo_i, int(i_rng[ii.min()])), max(hi_i, int(i_rng[ii.max()]) + 1)
        lo_j, hi_j = min(lo_j, int(j_rng[jj.min()])), max(hi_j, int(j_rng[jj.max()]) + 1)
    edge = pml + gap + pad
    i0, j0 = edge - lo_i, edge - lo_j
    nx, ny = hi_i - lo_i + 2 * edge, hi_j - lo_j + 2 * edge
    ground = design.ground_kind
    soil = design.ground if isinstance(design.ground, Soil) else None
    k_soil, k_plate, k_ntff_lo, pml_t = _heights(ground, settings, dx, gap, plane is not None)
    above = max(4, math.ceil(0.5 / dx))  # the far-field surface's top, over the blade
    k_blade = k_plate + n_up
    nz = k_blade + above + gap + pml
    plates: list[tuple[float, float, float, float, float]] = []
    metal_cells = 0
    if mask is not None:
        for a, b, c, d in _rectangles(mask):
            ia, ib = int(i_rng[a]) + i0, int(i_rng[c]) + i0 + 1
            ja, jb = int(j_rng[b]) + j0, int(j_rng[d]) + j0 + 1
            plates.append((ia * dx, ja * dx, ib * dx, jb * dx, k_plate * dx))
        metal_cells = int(mask.sum())
    zb = k_blade * dx
    plates.append(((i0 - n_along) * dx, (j0 - n_across // 2) * dx, i0 * dx, (j0 + n_across // 2) * dx, zb))
    plates.append(((i0 + 1) * dx, (j0 - n_across // 2) * dx, (i0 + 1 + n_along) * dx, (j0 + n_across // 2) * dx, zb))
    ntff = ((pml + gap) * dx, (pml + gap) * dx, k_ntff_lo * dx,
            (nx - pml - gap) * dx, (ny - pml - gap) * dx, (k_blade + above) * dx)
    panel_tip = math.hypot((n_along + 1) * dx, n_across * dx / 2)
    reach = max(panel_tip, *(math.hypot(x, y) for x, y in plane.outline().exterior.coords)) if plane else panel_tip
    window = settings.time_window_ns * 1e-9 or 200e-9 + 2 * reach / C0
    title = f"groundplane fdtd model of {design.label()}"
    return FdtdModel(dx, (nx, ny, nz), (i0, j0, k_blade), plates, ntff, soil, k_soil * dx, ground, pml_t,
                     metal_cells, window, quadrant=quadrant, title=title)
