"""From design to field: a ground plane cut from welded wire-mesh sheets.

EDGES's planes are galvanised steel mesh (5 cm grid, welded at every crossing; the paper's
section 2) laid in overlapping sheets; the deployed plane's teeth are 4.8 m wide instead of
the designed 5 m "due to the size of the mesh sheets". :func:`plan_sheets` lays a grid of
sheets over the outline (both orientations, grid aligned to a corner or centred; the plan
with the fewest bought sheets, then the least waste), cuts each sheet to the outline, and
cuts the small pieces (tooth tips) out of earlier sheets' offcuts where they fit (any of the
eight rotations and flips: the mesh's square grid makes them all alike). The layout covers the
outline with no gap by construction (each grid cell's piece is the cell clipped to the outline)
and the tests check it. The nesting is a greedy first fit, written here because no packaging
library nests arbitrary polygons into arbitrary offcuts; it is a plan a crew can follow, not a
proven optimum.
"""
from __future__ import annotations

import json
import math
import textwrap
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import LineString, Polygon, box
from shapely.ops import unary_union

from .errors import UserInputError
from .options import option
from .shapes import GroundPlane

STEEL_DENSITY = 7850.0  # kg/m^3, carbon steel (the zinc of galvanising adds ~2 %, not counted)
TOL = 1e-6  # m: geometric tolerance of the cuts
MIN_OFFCUT_AREA = 0.01  # m^2: smaller scraps are not kept for reuse


MIN_SHEET_M, MAX_SHEET_M = 0.5, 20.0  # a stock sheet a crew can carry; 1e9 m sheets planned a 2.2e18 kg purchase
MAX_GRID_M, MAX_WIRE_M = 0.5, 0.02
MAX_SHEETS = 20_000  # the 30 m plane takes ~70 stock sheets


@dataclass(frozen=True)
class MeshSheet:
    """A stock sheet of welded wire mesh, laid with ``overlap`` metres shared between
    neighbours. The paper gives the 5 cm grid and galvanised steel; the 2.4 x 6.0 m sheet (a
    common stock size; the paper's 4.8 m teeth are two of its widths), the 0.10 m overlap (two
    grid cells) and the 3 mm wire are our assumptions, hence options."""

    size: tuple[float, float] = option((2.4, 6.0), "stock mesh sheet width and length (m); a common stock size, "
                                       "not published", flag="--sheet", metavar=("WIDTH", "LENGTH"))
    overlap: float = option(0.10, "overlap between neighbouring sheets (m); two grid cells, not published")
    grid: float = option(0.05, "mesh grid pitch (m): EDGES's 5 cm")
    wire_diameter: float = option(0.003, "wire diameter (m); not published")

    def __post_init__(self) -> None:
        for name, v in (("width", self.width), ("length", self.length), ("grid", self.grid),
                        ("wire_diameter", self.wire_diameter)):
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise UserInputError(f"sheet {name} must be a positive number of metres, got {v!r}")
        if not (math.isfinite(self.overlap) and self.overlap >= 0):
            raise UserInputError(f"sheet overlap must be >= 0 m, got {self.overlap!r}")
        if self.overlap >= min(self.width, self.length):
            raise UserInputError(f"the overlap ({self.overlap:g} m) must be smaller than the sheet "
                                 f"({self.width:g} x {self.length:g} m)")
        if self.grid >= min(self.width, self.length):
            raise UserInputError(f"the mesh grid ({self.grid:g} m) must be smaller than the sheet "
                                 f"({self.width:g} x {self.length:g} m)")
        if self.wire_diameter >= self.grid:
            raise UserInputError(f"the wire diameter ({self.wire_diameter:g} m) must be smaller than the grid "
                                 f"({self.grid:g} m)")
        if not (MIN_SHEET_M <= min(self.width, self.length) and max(self.width, self.length) <= MAX_SHEET_M):
            raise UserInputError(f"--sheet {self.width:g} {self.length:g}: a stock mesh sheet is {MIN_SHEET_M:g}-"
                                 f"{MAX_SHEET_M:g} m a side (2.4 x 6.0 m is common)")
        if self.grid > MAX_GRID_M or self.wire_diameter > MAX_WIRE_M:
            raise UserInputError(f"--grid {self.grid:g} / --wire-diameter {self.wire_diameter:g}: a welded mesh's pitch "
                                 f"is at most {MAX_GRID_M:g} m and its wire at most {MAX_WIRE_M * 1000:g} mm")

    @property
    def width(self) -> float:
        return float(self.size[0])

    @property
    def length(self) -> float:
        return float(self.size[1])

    def as_dict(self) -> dict[str, float]:
        return {"width": self.width, "length": self.length, "overlap": self.overlap, "grid": self.grid,
                "wire_diameter": self.wire_diameter}

    @property
    def mass_per_m2(self) -> float:
        """kg per m^2 of mesh: two wires (one each way) per grid cell width."""
        return 2.0 / self.grid * math.pi * self.wire_diameter ** 2 / 4 * STEEL_DENSITY

    @property
    def area(self) -> float:
        return self.width * self.length


@dataclass
class Piece:
    """One piece of mesh as laid: ``in_plane`` where it lies (plane coordinates, metres),
    cut from sheet ``sheet``'s own frame (0..length along x, 0..width along y) as ``in_sheet``,
    either from a new sheet or from an offcut of one (``from_offcut``)."""

    label: str
    sheet: int
    in_plane: Polygon
    in_sheet: Polygon
    full: bool
    from_offcut: bool
    rotation_deg: float = 0.0  # sheet frame -> plane: rotate (after a flip), then translate
    flipped: bool = False
    cuts: list[LineString] = field(default_factory=list)  # cut lines in the sheet's frame

    @property
    def cut_length(self) -> float:
        return sum(c.length for c in self.cuts)


@dataclass
class SheetPlan:
    """How to build ``plane`` from ``sheet``s: the pieces and what they cost."""

    plane: GroundPlane
    sheet: MeshSheet
    pieces: list[Piece]
    bought: int
    orientation: str  # "long side along x" | "long side along y"
    offcuts_left: list[tuple[int, Polygon]]

    @property
    def sheets_full(self) -> int:
        return sum(1 for p in self.pieces if p.full)

    @property
    def sheets_cut(self) -> int:
        return self.bought - self.sheets_full

    @property
    def laid_area(self) -> float:
        """Mesh laid in the plane, overlaps counted twice (they are two layers of mesh)."""
        return sum(p.in_plane.area for p in self.pieces)

    @property
    def waste_percent(self) -> float:
        bought = self.bought * self.sheet.area
        return 100.0 * (bought - self.laid_area) / bought if bought else 0.0

    @property
    def seam_length(self) -> float:
        """Length of the joins between pieces (each overlap strip or butt joint counted once)."""
        inside = self.plane.outline().buffer(-10 * TOL)
        return sum(p.in_plane.exterior.intersection(inside).length for p in self.pieces) / 2

    @property
    def cut_length(self) -> float:
        return sum(p.cut_length for p in self.pieces)

    def summary(self) -> dict[str, Any]:
        """The plan's numbers (``plan.json``)."""
        m = self.sheet.mass_per_m2
        return {"design": self.plane.describe(), "metal_area_m2": self.plane.metal_area, "sheet": self.sheet.as_dict(),
                "orientation": self.orientation, "sheets_bought": self.bought, "sheets_full": self.sheets_full,
                "sheets_cut": self.sheets_cut, "pieces": len(self.pieces),
                "pieces_from_offcuts": sum(p.from_offcut for p in self.pieces),
                "laid_area_m2": self.laid_area, "waste_percent": self.waste_percent,
                "seam_length_m": self.seam_length, "cut_length_m": self.cut_length,
                "mass_kg": self.laid_area * m, "mass_bought_kg": self.bought * self.sheet.area * m,
                "mass_per_m2_kg": m, "steel_density_kg_m3": STEEL_DENSITY}


# ------------------------------------------------------------------ layout
def _polygons(geom) -> list[Polygon]:
    """The polygons of a shapely result (pieces thinner than the tolerance dropped)."""
    parts = [geom] if isinstance(geom, Polygon) else list(getattr(geom, "geoms", []))
    return [p for p in parts if isinstance(p, Polygon) and p.area > TOL]


def _cut_lines(piece: Polygon, stock: Polygon) -> list[LineString]:
    """The piece's edges that are not already edges of the stock it is cut from."""
    rest = piece.exterior.difference(stock.exterior.buffer(10 * TOL))
    lines = [rest] if isinstance(rest, LineString) else list(getattr(rest, "geoms", []))
    return [ln for ln in lines if isinstance(ln, LineString) and ln.length > 100 * TOL]


_ORIENTATIONS = [(r, f) for f in (False, True) for r in (0.0, 90.0, 180.0, 270.0)]


def _oriented(p: Polygon, rotation: float, flipped: bool) -> Polygon:
    q = affinity.scale(p, -1.0, 1.0, origin=(0, 0)) if flipped else p
    return affinity.rotate(q, rotation, origin=(0, 0))


def _orientations(piece: Polygon) -> list[tuple[float, bool, Polygon, tuple, np.ndarray]]:
    """The piece in each rotation and flip, with its box and corners: made once per piece, not once
    for every offcut it is tried in."""
    out = []
    for rotation, flipped in _ORIENTATIONS:
        q = _oriented(piece, rotation, flipped)
        out.append((rotation, flipped, q, q.bounds, np.asarray(q.exterior.coords[:-1])))
    return out


def _fit(piece: Polygon, offcut: Polygon, turns: list | None = None) -> tuple[Polygon, float, bool] | None:
    """``piece`` placed inside ``offcut`` (vertex on vertex, any rotation or flip), or None;
    ``turns``: the piece's :func:`_orientations`, when the caller has them."""
    if piece.area > offcut.area:
        return None
    ox0, oy0, ox1, oy1 = offcut.bounds
    room = None
    corners = np.asarray(offcut.exterior.coords[:-1])
    for rotation, flipped, q, (x0, y0, x1, y1), own in turns or _orientations(piece):
        if x1 - x0 > ox1 - ox0 + TOL or y1 - y0 > oy1 - oy0 + TOL:
            continue
        # every vertex-on-vertex move at once; only those that keep the piece's box inside the offcut's
        # and its corners inside are tried as polygons (in the loops' old order: the same placement,
        # found without n^2 polygon moves: a 1000-point star took 66 s, ~n^2 in its points)
        dx = corners[None, :, 0] - own[:, None, 0]
        dy = corners[None, :, 1] - own[:, None, 1]
        ok = ((x0 + dx >= ox0 - 10 * TOL) & (x1 + dx <= ox1 + 10 * TOL)
              & (y0 + dy >= oy0 - 10 * TOL) & (y1 + dy <= oy1 + 10 * TOL))
        for i, j in zip(*np.nonzero(ok)):
            if room is None:
                room = offcut.buffer(10 * TOL)
                shapely.prepare(room)
            if not shapely.contains_xy(room, own[:, 0] + dx[i, j], own[:, 1] + dy[i, j]).all():
                continue  # a corner outside: no polygon built to learn it
            placed = affinity.translate(q, dx[i, j], dy[i, j])
            if room.contains(placed):
                return placed, rotation, flipped
    return None


def _to_plane(in_sheet: Polygon, in_plane: Polygon, rotation: float, flipped: bool) -> tuple[float, float]:
    """The translation that takes the oriented sheet-frame piece onto the plane piece."""
    a = _oriented(in_sheet, rotation, flipped).centroid
    b = in_plane.centroid
    return b.x - a.x, b.y - a.y


def _layout(plane: GroundPlane, sheet: MeshSheet, along_y: bool, centred: bool) -> SheetPlan:
    outline = plane.outline()
    x0, y0, x1, y1 = outline.bounds
    sx, sy = (sheet.width, sheet.length) if along_y else (sheet.length, sheet.width)
    px, py = sx - sheet.overlap, sy - sheet.overlap
    nx = max(1, math.ceil((x1 - x0 - sheet.overlap) / px - 1e-9))
    ny = max(1, math.ceil((y1 - y0 - sheet.overlap) / py - 1e-9))
    if centred:  # the grid symmetric about the centre: its cells overhang both sides equally
        x0 -= (nx * px + sheet.overlap - (x1 - x0)) / 2
        y0 -= (ny * py + sheet.overlap - (y1 - y0)) / 2
    cells = []
    for i in range(nx):
        for j in range(ny):
            cell = box(x0 + i * px, y0 + j * py, x0 + i * px + sx, y0 + j * py + sy)
            parts = _polygons(cell.intersection(outline))
            if parts:
                cells.append((cell, parts))
    # full sheets first, then the cut cells from the largest piece down: big cuts make the
    # offcuts that small pieces (tooth tips) are cut from
    cells.sort(key=lambda c: -sum(p.area for p in c[1]))
    rot = 90.0 if along_y else 0.0
    pieces: list[Piece] = []
    offcuts: list[tuple[int, Polygon]] = []
    bought = 0
    for cell, parts in cells:
        full = len(parts) == 1 and parts[0].area >= cell.area * (1 - 1e-9)
        placed = None if full else _place_all(parts, offcuts)
        if placed is not None:
            offcuts, fits = placed
            for part, (n, in_sheet, stock, r, f) in zip(parts, fits):
                sub = sum(p.sheet == n for p in pieces)
                pieces.append(Piece(f"{n}{chr(ord('a') + sub)}", n, part, in_sheet, False, True, r, f,
                                    _cut_lines(in_sheet, stock)))
            continue
        bought += 1
        # the sheet's own frame: 0..length along x, 0..width along y; the cell is that frame
        # rotated (long side along y) and moved to the cell's corner
        frame = box(0, 0, sheet.length, sheet.width)
        cx, cy = cell.bounds[0], cell.bounds[1]
        rest = frame
        for part in parts:
            local = affinity.translate(part, -cx, -cy)
            if along_y:  # plane cell (x: width, y: length) -> sheet frame (x: length, y: width)
                local = affinity.translate(affinity.rotate(local, -90.0, origin=(0, 0)), 0, sheet.width)
            pieces.append(Piece(str(bought), bought, part, local, full, False, rot, False,
                                [] if full else _cut_lines(local, frame)))
            rest = rest.difference(local)
        offcuts += [(bought, p) for p in _polygons(rest) if p.area >= MIN_OFFCUT_AREA]
    return SheetPlan(plane, sheet, pieces, bought, "long side along y" if along_y else "long side along x",
                     offcuts)


def _place_all(parts: list[Polygon], offcuts: list[tuple[int, Polygon]]):
    """Every part of one cell cut from the offcuts (smallest offcut that holds it), or None
    when any part does not fit (then the cell gets its own sheet)."""
    pool = list(offcuts)
    fits = []
    for part in parts:
        local = affinity.translate(part, -part.centroid.x, -part.centroid.y)
        turns = _orientations(local)
        for idx in sorted(range(len(pool)), key=lambda i: pool[i][1].area):
            n, stock = pool[idx]
            hit = _fit(local, stock, turns)
            if hit is not None:  # hit: plane -> sheet is flip f, then rotate r; sheet -> plane is
                in_sheet, r, f = hit  # flip f then rotate r when flipped, rotate -r when not
                fits.append((n, in_sheet, stock, r if f else (-r) % 360.0, f))
                pool[idx:idx + 1] = [(n, p) for p in _polygons(stock.difference(in_sheet)) if p.area >= MIN_OFFCUT_AREA]
                break
        else:
            return None
    return pool, fits


def plan_sheets(plane: GroundPlane, sheet: MeshSheet, progress: bool = False) -> SheetPlan:
    """The plan with the fewest bought sheets (then the least waste) of four layouts: long
    side along x or y, grid from the outline's corner or centred on it. Refused before any work
    when the plane would need more than MAX_SHEETS sheets (0.15 m sheets on a 30 m square ran
    for minutes)."""
    x0, y0, x1, y1 = plane.outline().bounds
    step = (sheet.width - sheet.overlap) * (sheet.length - sheet.overlap)
    cells = (x1 - x0 + sheet.length) * (y1 - y0 + sheet.length) / step
    if cells > MAX_SHEETS:
        raise UserInputError(f"{plane.describe()}: about {cells:,.0f} sheets of {sheet.width:g} x {sheet.length:g} m "
                             f"would cover it; a plan holds at most {MAX_SHEETS:,} (use larger sheets)")
    from .progress import Progress

    # an outline of hundreds of corners takes a minute or more (its pieces tried in every offcut): said
    bar = Progress(4, f"fabricate {plane.describe()[:60]}", "layouts") if progress else None
    plans = []
    for along_y in (False, True):
        for centred in (False, True):
            plans.append(_layout(plane, sheet, along_y, centred))
            if bar:
                bar.update(1, f"{plans[-1].bought} sheets")
    if bar:
        bar.close()
    return min(plans, key=lambda p: (p.bought, p.waste_percent, p.seam_length))


# ------------------------------------------------------------------ buildable designs
SNAPPED_LENGTHS = {"square": (), "plus": (), "sawtooth": ("tooth_base",), "teeth": ("tooth_base",)}


def snap_to_sheet(plane: GroundPlane, sheet: MeshSheet) -> tuple[GroundPlane, dict[str, tuple[float, float]]]:
    """The nearest design whose teeth are cut from whole half-widths of a sheet (as EDGES did:
    5 m -> 4.8 m, two 2.4 m sheets), and what moved ``{param: (designed, snapped)}``. A tooth
    whose base is n half-widths is cut from sheets laid side by side with its two slanted cuts;
    straight sides (the square's, the plus's arms) are one straight trim whatever their length,
    so they stay as designed."""
    from .shapes import from_dict, to_dict

    if plane.kind not in SNAPPED_LENGTHS:
        raise UserInputError(f"--snap-to-sheet knows the {', '.join(SNAPPED_LENGTHS)} families, not {plane.kind}")
    step = sheet.width / 2
    d = to_dict(plane)
    moved = {}
    for name in SNAPPED_LENGTHS[plane.kind]:
        v = d[name]
        n = max(1, round(v / step))
        while n > 1 and d.get("teeth_per_side", 1) * n * step > d["side"] + 1e-9:  # the teeth must still fit
            n -= 1
        if abs(n * step - v) > 1e-9:
            moved[name] = (v, n * step)
            d[name] = n * step
    return from_dict(d), moved


# ------------------------------------------------------------------ outputs
def write_dxf(plan: SheetPlan, path: Path) -> None:
    """The metal outline 1:1 in metres with the sheet layout, cut lines and sheet numbers on
    their own layers (OUTLINE, SHEETS, CUTS, LABELS)."""
    import ezdxf
    from ezdxf import units

    doc = ezdxf.new("R2010", setup=True)
    doc.units = units.M
    for name, colour in (("OUTLINE", 7), ("SHEETS", 5), ("CUTS", 1), ("LABELS", 3)):
        doc.layers.add(name, color=colour)
    msp = doc.modelspace()
    msp.add_lwpolyline(list(plan.plane.outline().exterior.coords)[:-1], close=True, dxfattribs={"layer": "OUTLINE"})
    height = 0.12 * min(plan.sheet.width, plan.sheet.length)
    for p in plan.pieces:
        msp.add_lwpolyline(list(p.in_plane.exterior.coords)[:-1], close=True, dxfattribs={"layer": "SHEETS"})
        for line in _plane_cuts(p):
            msp.add_lwpolyline(list(line.coords), dxfattribs={"layer": "CUTS"})
        c = p.in_plane.representative_point()
        msp.add_text(p.label, height=height, dxfattribs={"layer": "LABELS"}).set_placement((c.x, c.y))
    doc.saveas(path)


def _plane_cuts(p: Piece) -> list[LineString]:
    """A piece's cut lines where they lie in the plane."""
    dx, dy = _to_plane(p.in_sheet, p.in_plane, p.rotation_deg, p.flipped)
    out = []
    for c in p.cuts:
        q = affinity.scale(c, -1.0, 1.0, origin=(0, 0)) if p.flipped else c
        out.append(affinity.translate(affinity.rotate(q, p.rotation_deg, origin=(0, 0)), dx, dy))
    return out


def dxf_outline_area(path: Path) -> float:
    """The area of the closed polylines on the OUTLINE layer of a DXF (m^2 when its units are metres)."""
    import ezdxf

    doc = ezdxf.readfile(path)
    polys = [Polygon([tuple(v[:2]) for v in e.get_points("xy")]) for e in doc.modelspace().query('LWPOLYLINE[layer=="OUTLINE"]')]
    return sum(p.area for p in polys)


def cutlist_rows(plan: SheetPlan) -> list[dict[str, Any]]:
    """One row per piece: where it comes from, where it goes, how it is cut."""
    rows = []
    for p in plan.pieces:
        c = p.in_plane.centroid
        rows.append({"piece": p.label, "sheet": p.sheet,
                     "source": f"offcut of sheet {p.sheet}" if p.from_offcut else "new sheet",
                     "full_sheet": "yes" if p.full else "no", "area_m2": round(p.in_plane.area, 4),
                     "plane_centre_x_m": round(c.x, 3), "plane_centre_y_m": round(c.y, 3),
                     "rotation_deg": p.rotation_deg, "flipped": "yes" if p.flipped else "no",
                     "cut_length_m": round(p.cut_length, 3),
                     "outline_in_sheet_m": "; ".join(f"{x:.3f} {y:.3f}" for x, y in p.in_sheet.exterior.coords[:-1])})
    return rows


def plan_figure(plan: SheetPlan, path: Path) -> None:
    """A drawing a crew can work from: the outline, every piece with its sheet number, the
    cut lines in red, overall dimensions; the cut sheets' cutting diagrams beside it."""
    from .cad import dimension, plot_outline
    from .plots import finish_figure, pyplot

    plt = pyplot()
    cut_sheets = sorted({p.sheet for p in plan.pieces if not p.full})
    ncol = min(4, max(1, len(cut_sheets)))
    nrow = math.ceil(len(cut_sheets) / ncol) if cut_sheets else 0
    fig = plt.figure(figsize=(8 + 2.2 * ncol, max(8.0, 1.3 * nrow + 1)))
    grid = fig.add_gridspec(max(1, nrow), 2, width_ratios=[8, 2.2 * ncol])
    ax = fig.add_subplot(grid[:, 0])
    plot_outline(plan.plane, ax, antenna=None, color="0.85", zorder=1)
    for p in plan.pieces:
        px, py = p.in_plane.exterior.xy
        ax.plot(px, py, color="tab:blue" if not p.from_offcut else "tab:green", lw=0.6, zorder=2)
        c = p.in_plane.representative_point()
        ax.text(c.x, c.y, p.label, ha="center", va="center", fontsize=6, zorder=4)
        for line in _plane_cuts(p):
            lx, ly = line.xy
            ax.plot(lx, ly, color="tab:red", lw=1.0, zorder=3)
    dimension(ax, plan.plane.outline().bounds, pad_fraction=0.06)
    s = plan.summary()
    ax.set_title(f"{textwrap.fill(plan.plane.describe(), 80)}\n{s['sheets_bought']} sheets of {plan.sheet.width:g} x "
                 f"{plan.sheet.length:g} m: {s['sheets_full']} whole, {s['sheets_cut']} cut; "
                 f"{s['pieces_from_offcuts']} pieces from offcuts (green)\nwaste {s['waste_percent']:.1f} %, "
                 f"seams {s['seam_length_m']:.1f} m, cuts {s['cut_length_m']:.1f} m (red), "
                 f"mesh {s['mass_kg']:.0f} kg laid", fontsize=9)
    for k, n in enumerate(cut_sheets):
        sub = fig.add_subplot(grid[k // ncol, 1]) if ncol == 1 else None
        if sub is None:
            inner = grid[k // ncol, 1].subgridspec(1, ncol)
            sub = fig.add_subplot(inner[0, k % ncol])
        sub.plot(*box(0, 0, plan.sheet.length, plan.sheet.width).exterior.xy, color="k", lw=0.8)
        for p in plan.pieces:
            if p.sheet == n:
                sub.fill(*p.in_sheet.exterior.xy, color="tab:green" if p.from_offcut else "tab:blue", alpha=0.35)
                c = p.in_sheet.representative_point()
                sub.text(c.x, c.y, p.label, ha="center", va="center", fontsize=6)
                for line in p.cuts:
                    sub.plot(*line.xy, color="tab:red", lw=1.0)
        sub.set_title(f"sheet {n}", fontsize=7)
        sub.set_aspect("equal")
        sub.set_xticks([]), sub.set_yticks([])
    finish_figure(fig, path)


def check_layout(plan: SheetPlan) -> float:
    """Area (m^2) of the outline that no piece covers: 0 for a good plan."""
    return plan.plane.outline().difference(unary_union([p.in_plane for p in plan.pieces])).area


def write_plan(plan: SheetPlan, out: Path, command: str = "") -> dict[str, Any]:
    """``outline.dxf``, ``plan.png``, ``plan.svg``, ``cutlist.csv`` and ``plan.json`` (with the
    ``command`` that made them) in ``out``."""
    from .files import atomic_path, write_csv

    out.mkdir(parents=True, exist_ok=True)
    with atomic_path(out / "outline.dxf", suffix=".tmp.dxf") as tmp:
        write_dxf(plan, tmp)
    for suffix in ("png", "svg"):
        plan_figure(plan, out / f"plan.{suffix}")  # written atomically by finish_figure
    write_csv(out / "cutlist.csv", cutlist_rows(plan))
    summary = plan.summary()
    summary["uncovered_m2"] = check_layout(plan)
    if command:
        summary["command"] = command
    with atomic_path(out / "plan.json", suffix=".tmp.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=1))
    return summary

