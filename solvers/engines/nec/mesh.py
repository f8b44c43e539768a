"""The NEC-2 model of a design as wires: plate wire grid, blade panels, feed, and the
NEC-2 input deck. Pure geometry (numpy, shapely): no NEC engine is needed here.

* Blade: each panel a rectangular wire grid (``blade_cells`` cells, 2 mm wires), fed
  across the 4.4 cm gap by two half-gap segments of the same radius meeting at x = 0,
  each driven with half the voltage. No balun, top plate or shield.
* Symmetry: every design whose plate is symmetric about both axes is also invariant under
  a 180 deg rotation about z. Such a model is given to NEC as one half plus a GR card
  (2 sections), which NEC solves exactly at about half the fill + LU cost. Only the feed
  crosses the rotation axis, hence the split feed: its two halves map onto each other (the
  copy runs the other way, so it is driven with -V/2). Plate wires are kept whole (a
  wire through the axis would have to be split, which changes the model). GX (mirror)
  symmetry is not used: pynec-accel 1.7.6 gets it wrong.
* Ground plane: a square grid of wires (spacing ``spacing``, lines at odd multiples of
  spacing/2 so the mesh is mirror-symmetric about both axes) clipped to the outline,
  plus wires along the outline itself (teeth included). All are noded with shapely so
  every crossing is a wire end; nodes closer than ``merge_fraction * spacing`` are merged
  to avoid ultra-short segments; grid lines within that distance of the outline's
  bounding box are dropped (they would only graze its extreme vertices), and a merged
  mesh in which wires overlap or touch away from their ends is re-noded. Every mesh is
  checked before NEC sees it (:func:`check_wire_grid`). The plate sits ``plate_height``
  above the soil (as low as NEC-2 allows: it cannot put wires on the interface, and they
  must stay 3 radii up; the defaults and why are with ``NecSettings``).
* An optional finer grid under the antenna (``refine_centre``) targets where the near
  field is strongest; it is off by default.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from groundplane.antenna import BladeDipole
from groundplane.design import Design, Soil
from groundplane.errors import SettingsError, SolveError
from groundplane.options import option
from groundplane.shapes import GroundPlane

from ..plate import PlateModel


@dataclass(frozen=True)
class NecSettings(PlateModel):
    """How a design is discretised for NEC-2 (lengths in metres)."""

    # The plate lies on the soil (SPEC section 2); NEC-2 needs its wires >= 3 radii above the
    # interface. Defaults chosen by `groundplane study plate-model` (results/plate_model.md),
    # not by the paper's numbers: the lowest height at which halving it again moves the FoM
    # of square-10 by about 5 %, with the thickest wire that height allows (r = h / 3;
    # thicker wires leak less into the soil).
    plate_wire_radius: float = option(0.0016, "plate wire radius (m)", flag="--wire-radius")
    blade_wire_radius: float = option(0.002, "blade wire radius (m)")
    merge_fraction: float = 0.3
    gain_calibration: str = option("pec", "absolute gain: 'pec' divides by the blade-over-PEC mean gain / 2 "
                                   "(see solvers/engines/nec/solver.py), 'none' uses NEC's input power",
                                   choices=("pec", "none"))
    # Optional finer grid under the antenna, where the near field is strongest and a coarse
    # grid leaks most power into the soil: spacing / FACTOR inside |x|, |y| <= HALF_WIDTH
    # (snapped out to a coarse grid line). (0, 1) = uniform grid.
    refine_centre: tuple[float, int] = option((0.0, 1), "a grid FACTOR times finer inside |x|,|y| <= HALF_WIDTH m",
                                              metavar=("HALF_WIDTH", "FACTOR"))

    rotational_symmetry: bool = option(True, "give NEC half the model and a 180 deg rotation (GR card) "
                                       "when the design allows: the same answer, ~2x faster")
    far_field_step: int = option(3, "far-field step (deg) NEC computes, interpolated (bicubic) to 1 deg; 1: no interpolation")

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (isinstance(self.far_field_step, int) and 1 <= self.far_field_step <= 10 and 90 % self.far_field_step == 0):
            raise SettingsError(f"far_field_step must be a whole number of degrees dividing 90 (1, 2, 3, 5, 6, 9, 10), "
                                f"got {self.far_field_step!r}")
        if not (self.spacing > 0 and math.isfinite(self.spacing)):
            raise SettingsError(f"mesh spacing must be a positive number of metres, got {self.spacing}")
        if not (0 < self.plate_wire_radius < self.spacing / 2):
            raise SettingsError(f"plate wire radius {self.plate_wire_radius} m must be in (0, spacing/2)")
        if self.plate_height < 3 * self.plate_wire_radius:
            raise SettingsError(
                f"plate height {self.plate_height} m must be at least 3 wire radii ({3 * self.plate_wire_radius} m) "
                "above the soil"
            )
        nx, ny = self.blade_cells
        if nx < 2 or ny < 2 or ny % 2:
            raise SettingsError(f"blade_cells {self.blade_cells}: need >= 2 cells, an even number across (feed at y = 0)")
        if not (0 < self.blade_wire_radius < 0.01):
            raise SettingsError(f"blade wire radius {self.blade_wire_radius} m must be in (0, 0.01)")
        if self.gain_calibration not in ("pec", "none"):
            raise SettingsError("gain_calibration must be 'pec' or 'none'")
        half, factor = self.refine_centre
        if not (isinstance(factor, int) and factor >= 1):
            raise SettingsError(f"refine_centre: FACTOR must be a whole number >= 1, got {factor!r}")
        if not (half >= 0 and math.isfinite(half)):
            raise SettingsError(f"refine_centre: HALF_WIDTH must be >= 0 m, got {half}")
        if self.refined and not (self.plate_wire_radius < self.spacing / factor / 2):
            raise SettingsError(f"plate wire radius {self.plate_wire_radius} m must be under half the refined "
                                f"spacing {self.spacing / factor:g} m")

    @property
    def refine_half_width(self) -> float:
        return float(self.refine_centre[0])

    @property
    def refine_factor(self) -> int:
        return int(self.refine_centre[1])

    @property
    def refined(self) -> bool:
        return self.refine_factor > 1 and self.refine_half_width > 0

    def label(self) -> str:
        """The model in words, for tables."""
        inner = (f", {self.spacing / self.refine_factor:g} m inside {self.refine_half_width:g} m" if self.refined
                 else "")
        return (f"NEC-2 wire grid {self.spacing:g} m{inner}, {self.plate_wire_radius * 1e3:g} mm wires, "
                f"{self.plate_height * 100:g} cm up")


# -------------------------------------------------------------------------- model
@dataclass
class Wire:
    """One straight NEC wire (GW card): tag, segments, end points (m), radius (m)."""

    tag: int
    n_seg: int
    p1: tuple[float, float, float]
    p2: tuple[float, float, float]
    radius: float


@dataclass
class NecModel:
    """Wires plus ground: what both the engine and a .nec deck are built from.

    With ``sections == 2`` the wires are one half of the structure and NEC adds the other
    half rotated 180 deg about z (GR card; the copy of tag t is tag t + ``len(wires)``).
    ``feeds`` are (tag, volts, copy) voltage sources on a wire's first segment; ``copy``
    marks a source on NEC's rotated copy of wire ``tag`` (see :meth:`sources`).
    """

    wires: list[Wire] = field(default_factory=list)
    feeds: list[tuple[int, float, bool]] = field(default_factory=list)
    ground: str = "soil"  # "soil" | "pec" | "free"
    eps_r: float = 3.5
    sigma: float = 0.02
    sections: int = 1

    @property
    def n_segments(self) -> int:
        return self.sections * sum(w.n_seg for w in self.wires)

    def sources(self) -> list[tuple[int, float]]:
        """(NEC tag, volts) of every source; a copy's tag is the original's plus the number
        of wires (GR's tag increment), so wires added after folding keep it right."""
        return [(tag + (len(self.wires) if copy else 0), volts) for tag, volts, copy in self.feeds]

    def add(self, p1: Sequence[float], p2: Sequence[float], radius: float, n_seg: int = 1) -> int:
        tag = len(self.wires) + 1
        self.wires.append(Wire(tag, n_seg, tuple(map(float, p1)), tuple(map(float, p2)), radius))
        return tag

    def to_deck(self, freqs_mhz: Sequence[float], comment: str = "") -> str:
        """The model as a NEC-2 input deck (GW/GE/GN/FR/EX/RP/EN), for other NEC tools."""
        lines = [f"CM groundplane NEC model: {comment}", "CE"]
        for w in self.wires:
            lines.append(
                f"GW {w.tag} {w.n_seg} " + " ".join(f"{v:.6f}" for v in (*w.p1, *w.p2)) + f" {w.radius:.6f}"
            )
        if self.sections > 1:
            lines.append(f"GR {len(self.wires)} {self.sections}")
        lines.append("GE 1")
        lines.append({"soil": f"GN 2 0 0 0 {self.eps_r:g} {self.sigma:g}", "pec": "GN 1", "free": "GN -1"}[self.ground])
        f = np.asarray(freqs_mhz, dtype=float)
        step = float(f[1] - f[0]) if f.size > 1 else 0.0
        lines.append(f"FR 0 {f.size} 0 0 {f[0]:g} {step:g}")
        lines += [f"EX 0 {tag} 1 0 {volts:g} 0" for tag, volts in self.sources()]
        lines.append("RP 0 91 360 1000 0 0 1 1")
        lines.append("EN")
        return "\n".join(lines) + "\n"


def add_blade(model: NecModel, antenna: BladeDipole, z: float, settings: NecSettings) -> None:
    """The two panels as wire grids at height ``z`` and the split feed (V/2 on each half)."""
    nx, ny = settings.blade_cells
    r = settings.blade_wire_radius
    ys = np.linspace(-antenna.panel_width / 2, antenna.panel_width / 2, ny + 1)
    for s in (1.0, -1.0):
        xs = s * (antenna.gap / 2 + np.linspace(0.0, antenna.panel_length, nx + 1))
        for x in xs:
            for j in range(ny):
                model.add((x, ys[j], z), (x, ys[j + 1], z), r)
        for y in ys:
            for i in range(nx):
                model.add((xs[i], y, z), (xs[i + 1], y, z), r)
    for x0, x1 in ((-antenna.gap / 2, 0.0), (0.0, antenna.gap / 2)):
        model.feeds.append((model.add((x0, 0.0, z), (x1, 0.0, z), r), 0.5, False))
    if antenna.parts is not None:
        add_parts(model, antenna, z, z - antenna.height, settings.blade_cells, r)


# The antenna's extra parts (groundplane.antenna.AntennaParts) as wire grids: the balun's outer
# conductors, a floating top plate, an open shield box and a feed spread along the gap.
PART_CELL = 0.05  # wire-grid cell (m) of the top plate and shield
PART_WIRE_RADIUS = 0.002  # as the blade's wires
BALUN_TUBE_RADIUS = 0.01  # the Roberts balun's brass outer conductor (19.05 mm inside, SPEC section 1)


def add_parts(model: NecModel, antenna: BladeDipole, z: float, ground_z: float, blade_cells: tuple[int, int],
              blade_wire_radius: float) -> None:
    """Add ``antenna.parts`` to a model whose panels are at ``z`` over a ground (or plate) at ``ground_z``."""
    parts = antenna.parts
    if parts is None:
        return
    if parts.balun:  # the outer conductors join the panels' inner edges to the ground
        for x in (antenna.gap / 2, -antenna.gap / 2):
            model.add((x, 0.0, ground_z), (x, 0.0, z), BALUN_TUBE_RADIUS, 10)
    if parts.feed_span:
        ys = np.linspace(-antenna.panel_width / 2, antenna.panel_width / 2, blade_cells[1] + 1)
        for y in ys[(np.abs(ys) > 1e-9) & (np.abs(ys) <= parts.feed_span / 2 + 1e-9)]:
            tag = model.add((-antenna.gap / 2, y, z), (antenna.gap / 2, y, z), blade_wire_radius)
            model.feeds.append((tag, 1.0, False))  # in parallel with the default feed at y = 0
    if parts.top_plate:
        side, gap = parts.top_plate
        _grid_patch(model, (-side / 2, -side / 2, z + gap), (side, 0, 0), (0, side, 0), PART_WIRE_RADIUS)
    if parts.shield:
        sx, sy, sh = parts.shield
        corners = [(sx / 2, sy / 2), (-sx / 2, sy / 2), (-sx / 2, -sy / 2), (sx / 2, -sy / 2)]
        for a, b in zip(corners, corners[1:] + corners[:1]):
            # each wall's vertical wires stand on the ground; its top corner wires are shared
            # with the next wall, so each wall leaves out its last column
            _wall(model, a, b, ground_z, sh)


def _grid_patch(model: NecModel, origin, u, v, radius: float) -> None:
    """A rectangular wire grid spanning ``origin + s u + t v`` (s, t in [0, 1]), cells about
    PART_CELL, every crossing a wire end (NEC joins wires only at their ends)."""
    origin, u, v = (np.asarray(a, dtype=float) for a in (origin, u, v))
    nu = max(2, int(np.ceil(np.linalg.norm(u) / PART_CELL)))
    nv = max(1, int(np.ceil(np.linalg.norm(v) / PART_CELL)))
    node = [[origin + i / nu * u + j / nv * v for j in range(nv + 1)] for i in range(nu + 1)]
    for i in range(nu + 1):
        for j in range(nv + 1):
            if i < nu:
                model.add(tuple(node[i][j]), tuple(node[i + 1][j]), radius)
            if j < nv:
                model.add(tuple(node[i][j]), tuple(node[i][j + 1]), radius)


def _wall(model: NecModel, a, b, ground_z: float, height: float) -> None:
    """A vertical wire-grid wall from corner ``a`` toward corner ``b`` (not including b's
    column, which the next wall adds), standing on the ground (wires along the ground left
    out: they would lie in it)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n = max(2, int(np.ceil(np.linalg.norm(b - a) / PART_CELL)))
    m = max(1, int(np.ceil(height / PART_CELL)))
    zs = ground_z + np.linspace(0.0, height, m + 1)
    cols = [a + (b - a) * i / n for i in range(n + 1)]
    for i in range(n):
        p, q = cols[i], cols[i + 1]
        for k in range(m):
            model.add((p[0], p[1], zs[k]), (p[0], p[1], zs[k + 1]), PART_WIRE_RADIUS)
        for zz in zs[1:]:
            model.add((p[0], p[1], zz), (q[0], q[1], zz), PART_WIRE_RADIUS)


def _rounded(p: Sequence[float]) -> tuple[float, ...]:
    return tuple(round(float(v), 7) + 0.0 for v in p)


def fold_rotation(model: NecModel) -> NecModel | None:
    """The same structure as one half plus NEC's 180 deg rotation about z (GR, 2 sections),
    or None when the wires are not invariant under that rotation (or a wire maps onto itself)."""
    if model.sections != 1 or len(model.wires) % 2:
        return None

    def rot(p: tuple[float, float, float]) -> tuple[float, float, float]:
        return (-p[0], -p[1], p[2])

    index = {frozenset((_rounded(w.p1), _rounded(w.p2))): i for i, w in enumerate(model.wires)}
    image = []
    for i, w in enumerate(model.wires):
        j = index.get(frozenset((_rounded(rot(w.p1)), _rounded(rot(w.p2)))))
        if j is None or j == i or model.wires[j].n_seg != w.n_seg or model.wires[j].radius != w.radius:
            return None
        image.append(j)

    def kept(w: Wire) -> bool:
        mx, my = (w.p1[0] + w.p2[0]) / 2, (w.p1[1] + w.p2[1]) / 2
        return mx > 1e-9 or (abs(mx) <= 1e-9 and my > 1e-9)

    half = NecModel(ground=model.ground, eps_r=model.eps_r, sigma=model.sigma, sections=2)
    new_tag = {}
    for i, w in enumerate(model.wires):
        if kept(w):
            new_tag[i] = half.add(w.p1, w.p2, w.radius, w.n_seg)
    if 2 * len(half.wires) != len(model.wires):
        return None
    for tag, volts, _ in model.feeds:
        i = tag - 1
        if i in new_tag:
            half.feeds.append((new_tag[i], volts, False))
            continue
        k = model.wires[image[i]]  # NEC's copy of k runs rot(k.p1) -> rot(k.p2)
        same_way = _rounded(rot(k.p1)) == _rounded(model.wires[i].p1)
        half.feeds.append((new_tag[image[i]], volts if same_way else -volts, True))
    return half


# ------------------------------------------------------------------- plate mesh
def _grid_lines(bounds: tuple[float, float, float, float], spacing: float, margin: float,
                refine_half_width: float, refine_factor: int) -> list:
    """Whole grid lines over the bounding box (and the finer centre grid, if any)."""
    from shapely.geometry import LineString

    x0, y0, x1, y1 = bounds

    def offsets(lo: float, hi: float) -> np.ndarray:
        k = np.arange(math.floor(lo / spacing - 0.5), math.ceil(hi / spacing + 0.5) + 1)
        v = (k + 0.5) * spacing
        return v[(v > lo + margin) & (v < hi - margin)]

    lines = [LineString([(x, y0 - 1), (x, y1 + 1)]) for x in offsets(x0, x1)]
    lines += [LineString([(x0 - 1, y), (x1 + 1, y)]) for y in offsets(y0, y1)]
    if refine_factor > 1 and refine_half_width > 0:
        # snap the region out to the next coarse line; fine lines subdivide the coarse cells
        h = (math.ceil(refine_half_width / spacing - 0.5) + 0.5) * spacing
        k = np.arange(-math.ceil(h / spacing) - 1, math.ceil(h / spacing) + 1)
        fine = ((k + 0.5) * spacing)[:, None] + np.arange(1, refine_factor)[None, :] * spacing / refine_factor
        fine = fine.ravel()[np.abs(fine.ravel()) < h - 1e-9]
        lines += [LineString([(v, -h), (v, h)]) for v in fine]
        lines += [LineString([(-h, v), (h, v)]) for v in fine]
        lines += [LineString([(-h, v), (h, v)]) for v in (-h, h)] + [LineString([(v, -h), (v, h)]) for v in (-h, h)]
    return lines


def _noded_edges_inside(lines: list, poly, spacing: float) -> np.ndarray:
    """Node whole grid lines against the outline (true crossings node robustly, clipped
    ends would not), then keep the pieces that lie inside or on the outline: [n, 2, 2]."""
    from shapely.geometry import MultiLineString, Point
    from shapely.ops import unary_union

    net = unary_union(lines + [poly.exterior])
    geoms = net.geoms if isinstance(net, MultiLineString) else [net]
    inside = poly.buffer(1e-7 * spacing)
    edges = []
    for g in geoms:
        c = np.asarray(g.coords)
        for a, b in zip(c[:-1], c[1:]):
            if inside.contains(Point((a + b) / 2)):
                edges.append((a, b))
    return np.asarray(edges, dtype=float)


def _merge_close_nodes(e: np.ndarray, poly, tol: float, symmetric: bool = False) -> np.ndarray:
    """Merge nodes closer than ``tol`` (union-find over a KD-tree's pairs); outline nodes
    survive (corners and tooth tips above all), so edges keep following the outline.

    ``symmetric`` (an outline symmetric about both axes): the merge is decided on the nodes
    folded into the first quadrant (|x|, |y|) and unfolded again, so the mesh keeps the
    outline's symmetry exactly (a merge decided on the whole plane breaks ties by index
    order and leaves sawtooth meshes lopsided, which the quadrant mirror and NEC's
    rotational symmetry would then misrepresent)."""
    from scipy.spatial import cKDTree
    from shapely.geometry import Point

    nodes, inv = np.unique(np.round(e.reshape(-1, 2), 9), axis=0, return_inverse=True)
    if symmetric:
        sign = np.where(nodes < -1e-12, -1.0, 1.0)
        work, wmap = np.unique(np.round(np.abs(nodes), 9), axis=0, return_inverse=True)
    else:
        sign, work, wmap = np.ones_like(nodes), nodes, np.arange(len(nodes))
    parent = np.arange(len(work))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    pairs = np.array(sorted(cKDTree(work).query_pairs(tol)), dtype=int).reshape(-1, 2)
    on_outline = np.array([poly.exterior.distance(Point(p)) < 1e-9 for p in work])
    order = np.argsort(np.hypot(*(work[pairs[:, 0]] - work[pairs[:, 1]]).T), kind="stable") if len(pairs) else []
    for i, j in pairs[order]:
        ri, rj = find(int(i)), find(int(j))
        # merge only if the two surviving nodes are themselves close: no chains across the mesh
        if ri != rj and np.hypot(*(work[ri] - work[rj])) < tol:
            keep, drop = (ri, rj) if on_outline[ri] or not on_outline[rj] else (rj, ri)
            if on_outline[ri] and on_outline[rj] and _is_corner(poly, work[rj]):
                keep, drop = rj, ri
            parent[drop] = keep
    roots = np.array([find(i) for i in range(len(work))])
    moved = work[roots[wmap]] * sign  # each node's merged position, unfolded to its own quadrant
    idx = np.unique(np.round(moved, 9), axis=0, return_inverse=True)
    pos, where = idx[0], idx[1].ravel()
    ends = where[inv.ravel()].reshape(-1, 2)
    ends = ends[ends[:, 0] != ends[:, 1]]
    ends = np.unique(np.sort(ends, axis=1), axis=0)
    return pos[ends]


def _renoded(merged: np.ndarray) -> np.ndarray:
    """Moving nodes can lay one wire along another or through another's end (narrow teeth
    at a coarse mesh); re-noding the merged set with GEOS splits those into shared-end pieces."""
    from shapely.geometry import LineString, MultiLineString
    from shapely.ops import unary_union

    if not len(_wire_grid_defects(merged)[0]):
        return merged
    renoded = unary_union(list(map(LineString, merged)))
    geoms = renoded.geoms if isinstance(renoded, MultiLineString) else [renoded]
    out = [(a, b) for g in geoms for a, b in zip(np.asarray(g.coords)[:-1], np.asarray(g.coords)[1:])]
    e = np.round(np.asarray(out, dtype=float), 9)
    return e[np.hypot(*(e[:, 1] - e[:, 0]).T) > 1e-9]


def plate_edges(plane: GroundPlane, spacing: float, merge_fraction: float = 0.3,
                refine_half_width: float = 0.0, refine_factor: int = 1) -> np.ndarray:
    """Wire-grid edges [n, 2, 2] (metres) meshing the outline: grid lines clipped to it plus
    the outline, noded so every crossing is an edge end, close nodes merged; optionally a
    grid ``refine_factor`` times finer inside the central square of half-width
    ``refine_half_width`` (its border is a coarse grid line, so fine lines end on a wire)."""
    poly = plane.outline()
    # Grid lines closer to the bounding box than the merge tolerance only touch the outline at
    # its extreme vertices (a tooth tip, a corner) and would leave a wire running through that
    # vertex ("WIRE #5 INTERSECTS WIRE #6" on sawtooth-15-12 at 1 m, whose tips sit on a grid
    # line); every crossing they make would be merged away anyway, so they are dropped.
    lines = _grid_lines(poly.bounds, spacing, merge_fraction * spacing, refine_half_width, refine_factor)
    edges = _noded_edges_inside(lines, poly, spacing)
    refined = refine_factor > 1 and refine_half_width > 0
    symmetric = all(plane.mirror_symmetry.values())
    merged = _merge_close_nodes(edges, poly, merge_fraction * spacing / (refine_factor if refined else 1), symmetric)
    return _renoded(merged)


def _wire_grid_defects(edges: np.ndarray, tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j) of wires that cross, overlap or touch away from a shared end."""
    import shapely
    from shapely.strtree import STRtree

    edges = np.asarray(edges, dtype=float)
    lines = shapely.linestrings(edges)
    i, j = STRtree(lines).query(lines, predicate="intersects")
    keep = i < j
    i, j = i[keep], j[keep]
    inter = shapely.intersection(lines[i], lines[j])
    point = shapely.get_type_id(inter) == 0  # anything else (line, multipoint) is an overlap
    p = shapely.get_coordinates(inter[point])  # one coordinate per single-point intersection

    def at_end(ends: np.ndarray) -> np.ndarray:
        return np.min(np.hypot(*(ends - p[:, None, :]).transpose(2, 0, 1)), axis=1) < tol

    ok = np.zeros(len(i), dtype=bool)
    ok[point] = at_end(edges[i[point]]) & at_end(edges[j[point]])
    return i[~ok], j[~ok]


GROUND_PLANE_FRACTION = 1e-3  # NEC-2 (CONECT): a segment whose ends are both within this x its length of z = 0 lies in the ground


def estimated_segments(plane: GroundPlane, spacing: float) -> int:
    """The plate's segment count before meshing (a square grid holds 2 / spacing m of wire per
    m^2, one segment per spacing): a mesh too fine to fit is refused before it is built."""
    return int(2 * plane.metal_area / spacing ** 2)


def check_wire_grid(edges: np.ndarray, label: str = "plate") -> None:
    """Raise SolveError unless wires meet only at shared ends: NEC refuses a wire crossing or
    touching another's interior, and says only "WIRE #5 INTERSECTS WIRE #6"; this names where."""
    i, j = _wire_grid_defects(edges)
    if len(i):
        a, b = edges[i[0]], edges[j[0]]
        raise SolveError(
            f"{label}: {len(i)} pair(s) of plate wires meet away from their ends, e.g. "
            f"({a[0][0]:.3f},{a[0][1]:.3f})-({a[1][0]:.3f},{a[1][1]:.3f}) and "
            f"({b[0][0]:.3f},{b[0][1]:.3f})-({b[1][0]:.3f},{b[1][1]:.3f}) m; NEC would refuse this mesh"
        )


def _is_corner(poly, p: np.ndarray) -> bool:
    """Is ``p`` a vertex of the outline (a tooth tip or corner must not move)?"""
    v = np.asarray(poly.exterior.coords)
    return bool(np.min(np.hypot(*(v - p).T)) < 1e-9)


def build_model(design: Design, settings: NecSettings) -> NecModel:
    """The full NEC model of a design: the blade over a plate on soil, above perfect ground or
    in free space (the last two are the cross-engine cases), or the blade alone."""
    if design.plane is None:  # (Design refuses soil without a plate)
        return _blade_alone(design, settings, design.ground_kind)
    if isinstance(design.ground, Soil):
        model = NecModel(ground="soil", eps_r=design.ground.eps_r, sigma=design.ground.sigma)
    else:
        model = NecModel(ground=design.ground_kind)
    zp = settings.plate_height
    edges = plate_edges(design.plane, settings.spacing, settings.merge_fraction, settings.refine_half_width,
                        settings.refine_factor)
    check_wire_grid(edges, f"{design.label()} at a {settings.spacing:g} m mesh")
    longest = 0.0
    for (ax, ay), (bx, by) in edges:
        length = math.hypot(bx - ax, by - ay)
        n = max(1, math.ceil(length / settings.spacing - 1e-9))
        longest = max(longest, length / n)
        model.add((ax, ay, zp), (bx, by, zp), settings.plate_wire_radius, n)
    if model.ground != "free" and zp <= GROUND_PLANE_FRACTION * longest:
        raise SettingsError(
            f"{design.label()}: NEC-2 takes a wire lower than 1/{1 / GROUND_PLANE_FRACTION:.0f} of its segment length "
            f"to lie in the ground plane, and the plate's longest segment is {longest:.3g} m at {zp:g} m up: use "
            f"--mesh below {zp / GROUND_PLANE_FRACTION:.3g} m or a higher --plate-height")
    add_blade(model, design.antenna, zp + design.antenna.height, settings)
    return _folded(model, settings)


def pec_reference_model(design: Design, settings: NecSettings) -> NecModel:
    """The design's blade alone over infinite PEC (the reference case and the gain calibration)."""
    return _blade_alone(design, settings, "pec")


def _blade_alone(design: Design, settings: NecSettings, ground: str) -> NecModel:
    model = NecModel(ground=ground)
    add_blade(model, design.antenna, design.antenna.height, settings)
    return _folded(model, settings)


def _folded(model: NecModel, settings: NecSettings) -> NecModel:
    """The model folded for NEC's rotational symmetry when the settings ask and it allows."""
    return (fold_rotation(model) if settings.rotational_symmetry else None) or model
