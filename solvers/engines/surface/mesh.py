"""Triangle meshes of a design for the surface engine: the blade's solid panels joined by a
feed strip (structured, graded toward the panel edges where the current peaks), and the
ground plane (Shewchuk's Triangle, through the ``triangle`` package: quality triangles of
about ``spacing`` m on any outline, teeth included). Meshes of shapes symmetric about both
axes are built on one quadrant and mirrored, so the discrete model keeps the symmetry.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from groundplane.antenna import BladeDipole
from groundplane.design import Design
from groundplane.errors import SettingsError, SolveError
from groundplane.options import option
from groundplane.shapes import GroundPlane, smallest_interior_angle

from ..plate import PlateModel
from .grid import TriMesh


@dataclass(frozen=True)
class SurfaceSettings(PlateModel):
    """How a design is meshed into triangles for the surface engine (lengths in metres): the
    plate model every engine shares (:class:`~solvers.engines.plate.PlateModel`) and the
    surface engine's own feed, panel grading and solve method."""

    feed_width: float = option(0.04, "surface engine: width (m) of the strip that joins the panels across the gap "
                               "(the delta-gap feed sits on it at x = 0)")
    edge_grading: float = option(0.5, "surface engine: 0 = uniform panel cells, 1 = cosine spacing, denser at the "
                                 "panel edges")
    near_factor: float = 2.5
    method: str = option("fast", "surface engine: 'fast' (precorrected FFT + GMRES, O(N log N) per iteration) or "
                         "'dense' (the full matrix and its LU: the reference)", choices=("fast", "dense"))
    solve_every: int = option(1, "surface engine: solve every n-th frequency (and the last) and fill the rest by a "
                              "cubic spline of ln G per direction: 2 halves the solves (validated: FoM within 0.2 %, "
                              "gain within 0.002 dB, docs/speed.md; the beam's meta frequency_fill holds a leave-out "
                              "estimate; refused where the solved ones would be over 2 MHz apart); 1 solves every frequency",
                              keyed_at_default=False)  # added after the cache filled: 1 keeps the old keys

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (self.spacing > 0 and math.isfinite(self.spacing)):
            raise SettingsError(f"mesh spacing must be a positive number of metres, got {self.spacing}")
        if not (self.plate_height > 0 and math.isfinite(self.plate_height)):
            raise SettingsError(f"plate height must be > 0 m, got {self.plate_height}")
        nx, ny = self.blade_cells
        if nx < 2 or ny < 2:
            raise SettingsError(f"blade_cells {self.blade_cells}: need >= 2 cells each way")
        if not (0.0 <= self.edge_grading <= 1.0):
            raise SettingsError(f"edge_grading must be in [0, 1], got {self.edge_grading}")
        if not (self.feed_width > 0):
            raise SettingsError(f"feed_width must be > 0 m, got {self.feed_width}")
        if self.near_factor < 1.5:
            raise SettingsError("near_factor must be >= 1.5")
        if self.solve_every not in (1, 2):
            raise SettingsError(f"solve_every must be 1 or 2 (every frequency, or every other one filled: 3 moved "
                                f"a FoM by 2.7 %), got {self.solve_every}")
        if self.method not in ("fast", "dense"):
            raise SettingsError(f"method must be 'fast' or 'dense', got {self.method!r}")

    def label(self) -> str:
        """The model in words, for tables."""
        default = type(self).__dataclass_fields__["feed_width"].default
        feed = "" if self.feed_width == default else f", feed along {self.feed_width * 100:g} cm of the gap"
        return f"surface {self.spacing:g} m, sheet {self.plate_height * 100:g} cm up{feed}"



def graded(n: int, grading: float) -> np.ndarray:
    """n + 1 points on [0, 1]: uniform blended with cosine (Chebyshev-like) spacing."""
    t = np.linspace(0.0, 1.0, n + 1)
    return (1.0 - grading) * t + grading * 0.5 * (1.0 - np.cos(np.pi * t))


def _with_lines(nodes: np.ndarray, lines: list[float], tol: float) -> np.ndarray:
    """``nodes`` plus ``lines``, dropping nodes closer than ``tol`` to an added line."""
    keep = [x for x in nodes if all(abs(x - y) > tol for y in lines)]
    return np.unique(np.round(np.concatenate([keep, lines]), 12))


def grid_mesh(xs: np.ndarray, ys: np.ndarray, z: float, metal) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and triangles of the cells of a tensor grid whose centre ``metal(x, y)`` keeps.
    Each cell is split along the diagonal through its corner nearest the origin, so a grid
    symmetric about both axes gives a mesh symmetric about both axes."""
    nx, ny = len(xs), len(ys)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    nodes = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, z)], axis=1)
    idx = np.arange(gx.size).reshape(nx, ny)
    tris = []
    for i in range(nx - 1):
        for j in range(ny - 1):
            xc, yc = 0.5 * (xs[i] + xs[i + 1]), 0.5 * (ys[j] + ys[j + 1])
            if not metal(xc, yc):
                continue
            a, b, c, d = idx[i, j], idx[i + 1, j], idx[i + 1, j + 1], idx[i, j + 1]
            if xc * yc > 0:
                tris += [(a, b, c), (a, c, d)]
            else:
                tris += [(a, b, d), (b, c, d)]
    used = np.unique(np.asarray(tris))
    remap = -np.ones(len(nodes), int)
    remap[used] = np.arange(len(used))
    return nodes[used], remap[np.asarray(tris)]


def blade_mesh(antenna: BladeDipole, z: float, settings: SurfaceSettings) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The two solid panels and the feed strip at height ``z``: (nodes, tris, feed edges)."""
    nx, ny = settings.blade_cells
    half_gap, wf = antenna.gap / 2, settings.feed_width
    if wf > antenna.panel_width + 1e-9:  # equal: the strip fills the gap (an edge port along the panels)
        raise SettingsError(f"feed_width {wf} m must not be wider than the panels ({antenna.panel_width} m)")
    along = half_gap + antenna.panel_length * graded(nx, settings.edge_grading)
    xs = np.unique(np.round(np.concatenate([-along[::-1], [0.0], along]), 12))
    across = antenna.panel_width * (graded(ny, settings.edge_grading) - 0.5)
    cell = antenna.panel_width / ny
    ys = _with_lines(across, [-wf / 2, 0.0, wf / 2], 0.3 * min(cell, wf / 2))

    def metal(x: float, y: float) -> bool:
        return abs(x) > half_gap or abs(y) < wf / 2

    nodes, tris = grid_mesh(xs, ys, z, metal)
    on_feed = np.flatnonzero((np.abs(nodes[:, 0]) < 1e-12) & (np.abs(nodes[:, 1]) <= wf / 2 + 1e-12))
    on_feed = on_feed[np.argsort(nodes[on_feed, 1])]
    feed = np.stack([on_feed[:-1], on_feed[1:]], axis=1)
    return nodes, tris, feed


def strip_dipole_mesh(length: float, width: float, n_along: int, n_across: int = 1) -> TriMesh:
    """A flat strip dipole along x in free space, fed at x = 0 (the validation case)."""
    if n_along % 2:
        raise SettingsError("n_along must be even (the feed is at x = 0)")
    xs = np.linspace(-length / 2, length / 2, n_along + 1)
    ys = np.linspace(-width / 2, width / 2, n_across + 1)
    nodes, tris = grid_mesh(xs, ys, 0.0, lambda x, y: True)
    on_feed = np.flatnonzero(np.abs(nodes[:, 0]) < 1e-12)
    on_feed = on_feed[np.argsort(nodes[on_feed, 1])]
    return TriMesh(nodes, tris, np.stack([on_feed[:-1], on_feed[1:]], axis=1))


def _triangulate(poly, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Quality triangles (min angle 30 deg, about ``spacing`` on a side) filling ``poly``."""
    import triangle

    ring = np.round(np.asarray(poly.exterior.coords)[:-1], 9) + 0.0  # cut points land 1e-16 off the axes
    ring = ring[np.any(ring != np.roll(ring, 1, axis=0), axis=1)]  # and may repeat a vertex
    pts: list[np.ndarray] = []
    for a, b in zip(ring, np.roll(ring, -1, axis=0)):
        n = max(1, math.ceil(np.hypot(*(b - a)) / spacing - 1e-9))
        pts.append(a + np.outer(np.arange(n) / n, b - a))
    verts = np.concatenate(pts)
    segs = np.stack([np.arange(len(verts)), np.roll(np.arange(len(verts)), -1)], axis=1)
    max_area = math.sqrt(3) / 4 * spacing ** 2
    # Triangle's 30 deg quality refinement need not end on an outline with a sliver angle (it
    # guarantees only 20.7 deg): cap the points it may add far above any sane mesh, and refuse
    # an outline that reaches the cap instead of filling the memory (an as-built variant did)
    cap = int(50 * poly.area / max_area) + 10 * len(verts) + 1000
    out = triangle.triangulate({"vertices": verts, "segments": segs}, f"pq30a{max_area:.9g}S{cap}Q")
    if len(out["vertices"]) - len(verts) >= cap:
        angle, where = smallest_interior_angle(poly)
        raise SolveError(f"the outline has an angle too sharp for a quality mesh at {spacing:g} m (its smallest "
                         f"interior angle is {angle:.1f} deg) at ({where[0]:.3f}, {where[1]:.3f}) m; smooth the outline")
    return np.asarray(out["vertices"]), np.asarray(out["triangles"])


def plate_mesh(plane: GroundPlane, z: float, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """The ground plane's triangles at height ``z`` (a quadrant mirrored when it can be)."""
    from shapely.geometry import box

    outline = plane.outline()
    if all(plane.mirror_symmetry.values()):
        big = 2 * plane.extent + 1.0
        quadrant = outline.intersection(box(0.0, 0.0, big, big))
        if quadrant.geom_type != "Polygon":
            raise SolveError(f"{plane.describe()}: its first quadrant is not one piece ({quadrant.geom_type})")
        v, t = _triangulate(quadrant, spacing)
        parts_v, parts_t = [], []
        for k, (sx, sy) in enumerate(((1, 1), (-1, 1), (1, -1), (-1, -1))):
            parts_v.append(v * np.array([sx, sy]))
            parts_t.append(t + k * len(v))
        v, t = np.concatenate(parts_v), np.concatenate(parts_t)
        key = np.round(v, 9)
        uniq, inv = np.unique(key, axis=0, return_inverse=True)
        v, t = uniq, inv.ravel()[t]
    else:
        v, t = _triangulate(outline, spacing)
    return np.column_stack([v, np.full(len(v), z)]), t


def build_mesh(design: Design, settings: SurfaceSettings) -> TriMesh:
    """The whole design as one triangle mesh (the blade above the plate, if any)."""
    zp = settings.plate_height if design.plane is not None else 0.0
    nodes, tris, feed = blade_mesh(design.antenna, zp + design.antenna.height, settings)
    if design.plane is not None:
        pv, pt = plate_mesh(design.plane, zp, settings.spacing)
        tris = np.concatenate([tris, pt + len(nodes)])
        nodes = np.concatenate([nodes, pv])
    return TriMesh(nodes, tris, feed)
