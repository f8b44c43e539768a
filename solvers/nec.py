"""NEC-2 solver adapter: the blade dipole over a wire-grid ground plane on lossy soil
(Sommerfeld/Norton ground, GN 2) or over infinite perfect ground (GN 1), returning a Beam.

Modelling choices (and why):

* Engine: ``pynec-accel`` 1.7.6 (module ``PyNEC``). ``PyNEC``/``necpp`` 2.3.4 give wrong
  currents for wires a few cm above Sommerfeld soil (shared/nec/NOTES.md); pynec-accel
  matches Fortran NEC-2 there but is wrong *with GX symmetry*, so GX is never used and
  a request for it is refused. A golden test (half-wave dipole 5 cm over MRO soil,
  Fortran NEC-2: -3.22 dBi at zenith) runs before the first soil solve in a process and a
  wrong engine is refused.
* Blade: each panel a rectangular wire grid (``blade_cells`` cells, 2 mm wires), fed by
  one segment of the same radius across the 4.4 cm gap. No balun, top plate or shield:
  a grounded balun (two 1 cm tubes under the feed) moves the FoM over PEC from 126.7 to
  129.8 mK and a 24 x 18 blade to 129.5 mK, so neither explains the gap to the paper's
  61.8 mK (widths within 0.4 deg; results/blade_over_pec.md, from
  ``python -m solvers.studies blade-over-pec``).
* Absolute gain: NEC's input power at this feed is too high for practical blade grids
  (mean gain over PEC below 2: results/feed_calibration.md, from
  ``python -m solvers.studies feed-calibration``; the level converges slowly with the
  blade mesh). With ``gain_calibration="pec"`` (the
  default) each frequency is also solved for the same blade over infinite PEC, where the
  truth is known (lossless: mean gain over the upper hemisphere = 2), and the gain is
  divided by kappa(f) = that mean / 2. This assumes the feed-model error is the same over
  soil as over PEC (same blade mesh, same feed); kappa is recorded in the beam metadata.
* Ground plane: a square grid of wires (spacing ``spacing``, lines at odd multiples of
  spacing/2 so the mesh is mirror-symmetric about both axes) clipped to the outline,
  plus wires along the outline itself (teeth included). All are noded with shapely so
  every crossing is a wire end; nodes closer than ``merge_fraction * spacing`` are merged
  to avoid ultra-short segments; grid lines within that distance of the outline's
  bounding box are dropped (they would only graze its extreme vertices), and a merged
  mesh in which wires overlap or touch away from their ends is re-noded. Every mesh is
  checked before NEC sees it (``check_wire_grid``). The plate sits ``plate_height``
  (5 cm) above the soil: NEC-2 cannot put wires on the interface; wires must stay 3 radii
  up, which caps the radius (thicker wires would leak less).
* The grid leaks: at 1 m spacing ~20 % of the power goes into the soil through it and the
  FoM is biased high (results/mesh_convergence.md, results/feko_40mhz.md). An optional
  finer grid under the antenna (``refine_half_width``, ``refine_factor``) targets where
  the near field is strongest; it is off by default (it raises the efficiency, 0.930 ->
  0.976 on square-10 at 0.5 m, but the FoM went 366.5 -> 377.4 mK).
* Far field: theta 0-90, phi 0-359 (1 deg). For a candidate mirror-symmetric about both
  axes only phi 0-90 is computed and mirrored. Below the horizon nothing is returned.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field
from typing import Any, Iterable, Sequence

import numpy as np

from groundplane.antenna import BladeDipole
from groundplane.beam import Beam
from groundplane.design import Design, InfinitePEC, Soil
from groundplane.shapes import GroundPlane

MODEL_VERSION = 1  # bump when the model changes: the cache key includes it
C_MHZ_M = 299.792458


class EngineError(RuntimeError):
    """The NEC engine is missing, known to be wrong for this case, or failed its golden test."""


class SolveError(RuntimeError):
    """A solve failed; names the candidate and the reason."""


@dataclass(frozen=True)
class MeshSettings:
    """Discretisation of the model (all lengths in metres)."""

    spacing: float = 0.5
    plate_wire_radius: float = 0.01
    plate_height: float = 0.05
    blade_cells: tuple[int, int] = (12, 10)
    blade_wire_radius: float = 0.002
    merge_fraction: float = 0.3
    gain_calibration: str = "pec"  # "pec" or "none"
    # Optional finer grid under the antenna, where the near field is strongest and a coarse
    # grid leaks most power into the soil: spacing / refine_factor inside |x|, |y| <=
    # refine_half_width (snapped out to a coarse grid line). 0 / 1 = uniform grid.
    refine_half_width: float = 0.0
    refine_factor: int = 1

    def __post_init__(self) -> None:
        if not (self.spacing > 0 and math.isfinite(self.spacing)):
            raise ValueError(f"mesh spacing must be a positive number of metres, got {self.spacing}")
        if not (0 < self.plate_wire_radius < self.spacing / 2):
            raise ValueError(f"plate wire radius {self.plate_wire_radius} m must be in (0, spacing/2)")
        if self.plate_height < 3 * self.plate_wire_radius:
            raise ValueError(
                f"plate height {self.plate_height} m must be at least 3 wire radii ({3 * self.plate_wire_radius} m) "
                "above the soil"
            )
        nx, ny = self.blade_cells
        if nx < 2 or ny < 2 or ny % 2:
            raise ValueError(f"blade_cells {self.blade_cells}: need >= 2 cells, an even number across (feed at y = 0)")
        if self.gain_calibration not in ("pec", "none"):
            raise ValueError("gain_calibration must be 'pec' or 'none'")
        if not (isinstance(self.refine_factor, int) and self.refine_factor >= 1):
            raise ValueError(f"refine_factor must be an integer >= 1, got {self.refine_factor!r}")
        if not (self.refine_half_width >= 0 and math.isfinite(self.refine_half_width)):
            raise ValueError(f"refine_half_width must be >= 0 m, got {self.refine_half_width}")
        if self.refined and not (self.plate_wire_radius < self.spacing / self.refine_factor / 2):
            raise ValueError(f"plate wire radius {self.plate_wire_radius} m must be under half the refined "
                             f"spacing {self.spacing / self.refine_factor:g} m")

    @property
    def refined(self) -> bool:
        return self.refine_factor > 1 and self.refine_half_width > 0

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["blade_cells"] = list(self.blade_cells)
        if not self.refined:  # a uniform grid keeps the cache keys it had before refinement existed
            d.pop("refine_half_width")
            d.pop("refine_factor")
        return d


# ------------------------------------------------------------------------- engine
def engine_info() -> dict[str, str]:
    """Which distribution provides the PyNEC module, and its version."""
    from importlib import metadata

    for dist in ("pynec-accel", "PyNEC", "pynec"):
        try:
            return {"engine": dist.lower(), "version": metadata.version(dist)}
        except metadata.PackageNotFoundError:
            continue
    raise EngineError("no NEC-2 engine: install pynec-accel==1.7.6 (pip install -e . does)")


_VERIFIED = ("pynec-accel", "1.7.6")
_GOLDEN_OK: dict[str, float] = {}


def golden_dipole_zenith_gain(height: float = 0.05) -> float:
    """Zenith gain (dBi) of the NOTES.md golden case: half-wave dipole at 75 MHz, radius
    1 cm, 11 segments, ``height`` m over eps_r 3.5, sigma 0.02 S/m (Fortran: -3.22 dBi at 5 cm)."""
    from PyNEC import nec_context

    c = nec_context()
    g = c.get_geometry()
    half = 0.25 * C_MHZ_M / 75.0
    g.wire(1, 11, -half, 0.0, height, half, 0.0, height, 0.01, 1.0, 1.0)
    c.geometry_complete(1)
    c.gn_card(2, 0, 3.5, 0.02, 0, 0, 0, 0)
    c.fr_card(0, 1, 75.0, 0)
    c.ex_card(0, 1, 6, 0, 1.0, 0, 0, 0, 0, 0)
    c.rp_card(0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0)
    return float(np.asarray(c.get_radiation_pattern(0).get_gain())[0, 0])


def engine_call(fn, *args):
    """Run ``fn(*args)`` in a fresh spawned process. PyNEC (pynec-accel) and healpy each
    bundle a libgomp; loading both in one process fails ("cannot allocate memory in static
    TLS block"), so NEC always runs in worker processes, never beside the sky code."""
    import multiprocessing as mp

    with ProcessPoolExecutor(max_workers=1, mp_context=mp.get_context("spawn"), initializer=_worker_init) as pool:
        return pool.submit(fn, *args).result()


def golden_zenith_gain_isolated(height: float = 0.05) -> float:
    """The golden test, run in an engine process."""
    return engine_call(golden_dipole_zenith_gain, height)


def check_engine(ground: str, use_gx: bool = False, allow_unverified: bool = False,
                 in_process: bool = False) -> dict[str, str]:
    """Refuse an engine/option combination known to be wrong; run the golden test once
    (in an engine process, or here with ``in_process`` where NEC runs in this process)."""
    info = engine_info()
    if use_gx and (info["engine"], info["version"]) == _VERIFIED:
        raise EngineError("pynec-accel 1.7.6 is wrong with GX symmetry (5.62 vs 3.85 dBi in NOTES.md); not used")
    if ground == "soil":
        if (info["engine"], info["version"]) != _VERIFIED and not allow_unverified:
            raise EngineError(
                f"{info['engine']} {info['version']} is not verified for wires near Sommerfeld soil "
                "(PyNEC/necpp 2.3.4 are known wrong there); install pynec-accel==1.7.6"
            )
        key = f"{info['engine']}-{info['version']}"
        if key not in _GOLDEN_OK:
            got = golden_dipole_zenith_gain(0.05) if in_process else golden_zenith_gain_isolated(0.05)
            if abs(got - (-3.22)) > 0.05:
                raise EngineError(
                    f"{key} failed the golden test: dipole 5 cm over soil gives {got:.2f} dBi at zenith, "
                    "Fortran NEC-2 gives -3.22 dBi"
                )
            _GOLDEN_OK[key] = got
    return info


# -------------------------------------------------------------------------- model
@dataclass
class Wire:
    tag: int
    n_seg: int
    p1: tuple[float, float, float]
    p2: tuple[float, float, float]
    radius: float


@dataclass
class NecModel:
    """Wires plus ground: what both PyNEC and a .nec deck are built from."""

    wires: list[Wire] = field(default_factory=list)
    feed_tag: int = 0
    ground: str = "soil"  # "soil" | "pec"
    eps_r: float = 3.5
    sigma: float = 0.02

    @property
    def n_segments(self) -> int:
        return sum(w.n_seg for w in self.wires)

    def add(self, p1: Sequence[float], p2: Sequence[float], radius: float, n_seg: int = 1) -> int:
        tag = len(self.wires) + 1
        self.wires.append(Wire(tag, n_seg, tuple(map(float, p1)), tuple(map(float, p2)), radius))
        return tag

    def build(self, freq_mhz: float):
        """A PyNEC context with geometry, ground, frequency and excitation set."""
        from PyNEC import nec_context

        c = nec_context()
        g = c.get_geometry()
        for w in self.wires:
            g.wire(w.tag, w.n_seg, *w.p1, *w.p2, w.radius, 1.0, 1.0)
        c.geometry_complete(1)
        if self.ground == "soil":
            c.gn_card(2, 0, self.eps_r, self.sigma, 0, 0, 0, 0)
        else:
            c.gn_card(1, 0, 0, 0, 0, 0, 0, 0)
        c.fr_card(0, 1, float(freq_mhz), 0)
        c.ex_card(0, self.feed_tag, 1, 0, 1.0, 0, 0, 0, 0, 0)
        return c

    def to_deck(self, freqs_mhz: Sequence[float], comment: str = "") -> str:
        """The model as a NEC-2 input deck (GW/GE/GN/FR/EX/RP/EN), for other NEC tools."""
        lines = [f"CM groundplane NEC model: {comment}", "CE"]
        for w in self.wires:
            lines.append(
                f"GW {w.tag} {w.n_seg} " + " ".join(f"{v:.6f}" for v in (*w.p1, *w.p2)) + f" {w.radius:.6f}"
            )
        lines.append("GE 1")
        if self.ground == "soil":
            lines.append(f"GN 2 0 0 0 {self.eps_r:g} {self.sigma:g}")
        else:
            lines.append("GN 1")
        f = np.asarray(freqs_mhz, dtype=float)
        step = float(f[1] - f[0]) if f.size > 1 else 0.0
        lines.append(f"FR 0 {f.size} 0 0 {f[0]:g} {step:g}")
        lines.append(f"EX 0 {self.feed_tag} 1 0 1 0")
        lines.append("RP 0 91 360 1000 0 0 1 1")
        lines.append("EN")
        return "\n".join(lines) + "\n"


def add_blade(model: NecModel, antenna: BladeDipole, z: float, mesh: MeshSettings) -> int:
    """The two panels as wire grids at height ``z`` and the feed segment; returns the feed tag."""
    nx, ny = mesh.blade_cells
    r = mesh.blade_wire_radius
    ys = np.linspace(-antenna.panel_width / 2, antenna.panel_width / 2, ny + 1)
    for s in (1.0, -1.0):
        xs = s * (antenna.gap / 2 + np.linspace(0.0, antenna.panel_length, nx + 1))
        for x in xs:
            for j in range(ny):
                model.add((x, ys[j], z), (x, ys[j + 1], z), r)
        for y in ys:
            for i in range(nx):
                model.add((xs[i], y, z), (xs[i + 1], y, z), r)
    feed = model.add((-antenna.gap / 2, 0.0, z), (antenna.gap / 2, 0.0, z), r)
    model.feed_tag = feed
    return feed


def plate_edges(plane: GroundPlane, spacing: float, merge_fraction: float = 0.3,
                refine_half_width: float = 0.0, refine_factor: int = 1) -> np.ndarray:
    """Wire-grid edges [n, 2, 2] (metres) meshing the outline: grid lines clipped to it plus
    the outline, noded so every crossing is an edge end, close nodes merged; optionally a
    grid ``refine_factor`` times finer inside the central square of half-width
    ``refine_half_width`` (its border is a coarse grid line, so fine lines end on a wire)."""
    from scipy.spatial import cKDTree
    from shapely.geometry import LineString, MultiLineString, Point
    from shapely.ops import unary_union

    poly = plane.outline()
    x0, y0, x1, y1 = poly.bounds

    # Grid lines closer to the bounding box than the merge tolerance only touch the outline at
    # its extreme vertices (a tooth tip, a corner) and would leave a wire running through that
    # vertex ("WIRE #5 INTERSECTS WIRE #6" on sawtooth-15-12 at 1 m, whose tips sit on a grid
    # line); every crossing they make would be merged away anyway, so they are dropped.
    margin = merge_fraction * spacing

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
    # Node whole grid lines against the outline (true crossings node robustly, clipped
    # ends would not), then keep the pieces that lie inside or on the outline.
    net = unary_union(lines + [poly.exterior])
    geoms = net.geoms if isinstance(net, MultiLineString) else [net]
    inside = poly.buffer(1e-7 * spacing)
    edges = []
    for g in geoms:
        c = np.asarray(g.coords)
        for a, b in zip(c[:-1], c[1:]):
            if inside.contains(Point((a + b) / 2)):
                edges.append((a, b))
    e = np.asarray(edges, dtype=float)  # [n, 2, 2]
    # merge nodes closer than merge_fraction * spacing (union-find over a KD-tree's pairs)
    nodes, inv = np.unique(np.round(e.reshape(-1, 2), 9), axis=0, return_inverse=True)
    parent = np.arange(len(nodes))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    tol = merge_fraction * spacing / (refine_factor if refine_factor > 1 and refine_half_width > 0 else 1)
    pairs = np.array(sorted(cKDTree(nodes).query_pairs(tol)), dtype=int).reshape(-1, 2)
    on_outline = np.array([poly.exterior.distance(Point(p)) < 1e-9 for p in nodes])
    order = np.argsort(np.hypot(*(nodes[pairs[:, 0]] - nodes[pairs[:, 1]]).T)) if len(pairs) else []
    for i, j in pairs[order]:
        ri, rj = find(int(i)), find(int(j))
        # merge only if the two surviving nodes are themselves close: no chains across the mesh
        if ri != rj and np.hypot(*(nodes[ri] - nodes[rj])) < tol:
            # the outline node survives, so edges keep following the outline
            keep, drop = (ri, rj) if on_outline[ri] or not on_outline[rj] else (rj, ri)
            if on_outline[ri] and on_outline[rj] and _is_corner(poly, nodes[rj]):
                keep, drop = rj, ri
            parent[drop] = keep
    roots = np.array([find(i) for i in range(len(nodes))])
    idx = roots[inv.ravel()].reshape(-1, 2)
    idx = idx[idx[:, 0] != idx[:, 1]]
    idx = np.unique(np.sort(idx, axis=1), axis=0)
    merged = nodes[idx]
    # Moving nodes can lay one wire along another or through another's end (narrow teeth at a
    # coarse mesh); re-noding the merged set with GEOS splits those into shared-end pieces.
    if not len(_wire_grid_defects(merged)[0]):
        return merged
    renoded = unary_union(list(map(LineString, merged)))
    geoms = renoded.geoms if isinstance(renoded, MultiLineString) else [renoded]
    out = [(a, b) for g in geoms for a, b in zip(np.asarray(g.coords)[:-1], np.asarray(g.coords)[1:])]
    e = np.round(np.asarray(out, dtype=float), 9)
    return e[np.hypot(*(e[:, 1] - e[:, 0]).T) > 1e-9]


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


def build_model(design: Design, mesh: MeshSettings) -> NecModel:
    """The full NEC model of a design."""
    if isinstance(design.ground, InfinitePEC):
        model = NecModel(ground="pec")
        if design.plane is not None:
            raise SolveError(f"{design.label()}: a plate on infinite PEC ground does nothing; drop the shape")
        add_blade(model, design.antenna, design.antenna.height, mesh)
        return model
    assert isinstance(design.ground, Soil)
    model = NecModel(ground="soil", eps_r=design.ground.eps_r, sigma=design.ground.sigma)
    zp = mesh.plate_height
    edges = plate_edges(design.plane, mesh.spacing, mesh.merge_fraction, mesh.refine_half_width, mesh.refine_factor)
    check_wire_grid(edges, f"{design.label()} at a {mesh.spacing:g} m mesh")
    for (ax, ay), (bx, by) in edges:
        length = math.hypot(bx - ax, by - ay)
        model.add((ax, ay, zp), (bx, by, zp), mesh.plate_wire_radius, max(1, math.ceil(length / mesh.spacing - 1e-9)))
    add_blade(model, design.antenna, zp + design.antenna.height, mesh)
    return model


def pec_reference_model(design: Design, mesh: MeshSettings) -> NecModel:
    """The same blade over infinite PEC (for the gain calibration)."""
    model = NecModel(ground="pec")
    add_blade(model, design.antenna, design.antenna.height, mesh)
    return model


# -------------------------------------------------------------------------- solve
def _pattern(model: NecModel, freq_mhz: float, n_phi: int) -> np.ndarray:
    """Linear power gain [theta 0..90, phi 0..n_phi-1] (1-degree steps) at one frequency."""
    c = model.build(freq_mhz)
    c.rp_card(0, 91, n_phi, 0, 0, 0, 0, 0.0, 0.0, 1.0, 1.0, 0, 0)
    db = np.asarray(c.get_radiation_pattern(0).get_gain(), dtype=float)
    if db.shape != (91, n_phi) or not np.all(np.isfinite(db)):
        raise SolveError(f"NEC returned a pattern of shape {db.shape} with non-finite values at {freq_mhz} MHz")
    g = 10.0 ** (db / 10.0)
    g[db <= -990] = 0.0  # NEC's "no field" marker (theta = 90 over ground)
    return g


def _upper_mean_gain(g: np.ndarray, n_phi: int) -> float:
    """Mean of G over the upper hemisphere for a [91, n_phi] 1-degree pattern covering phi
    0..n_phi-1 (a quarter, mirrored, when n_phi = 91)."""
    full = mirror_quadrant(g) if n_phi == 91 else g
    b = Beam([1.0], np.arange(91.0), np.arange(360.0), full[None])
    w = b.solid_angle_weights()
    return float((full * w).sum() / w.sum())


def mirror_quadrant(q: np.ndarray) -> np.ndarray:
    """phi 0..90 of a pattern symmetric about both planes -> phi 0..359."""
    full = np.empty(q.shape[:-1] + (360,))
    full[..., 0:91] = q
    full[..., 91:181] = q[..., 89::-1][..., :90]  # phi 91..180 = 180 - phi in 89..0
    full[..., 181:271] = q[..., 1:91]  # phi 181..270 = phi - 180 in 1..90
    full[..., 271:360] = q[..., 89:0:-1]  # phi 271..359 = 360 - phi in 89..1
    return full


def _solve_one(args: tuple) -> tuple[float, np.ndarray, float, float]:
    """Worker: one frequency. Returns (freq, gain [91, n_phi], kappa, seconds).

    ``ref_model`` is the blade over PEC for the gain calibration, ``model`` itself when the
    design *is* the blade over PEC (solved once), or None for no calibration."""
    model, ref_model, freq, n_phi = args
    t0 = time.perf_counter()
    g = _pattern(model, freq, n_phi)
    kappa = 1.0
    if ref_model is not None:
        gp = g if ref_model is model else _pattern(ref_model, freq, n_phi)
        kappa = _upper_mean_gain(gp, n_phi) / 2.0
        if not (0.3 < kappa < 3.0):
            raise SolveError(f"gain calibration factor {kappa:.3f} at {freq} MHz is implausible")
        g = g / kappa
    return freq, g, kappa, time.perf_counter() - t0


def _worker_init() -> None:
    # one OpenMP thread per process: frequencies run in parallel processes instead
    os.environ["OMP_NUM_THREADS"] = "1"
    os.environ["OPENBLAS_NUM_THREADS"] = "1"


def parse_freqs(spec: str) -> np.ndarray:
    """'40:100:1' (inclusive) or '50,75,100' -> MHz array."""
    try:
        if ":" in spec:
            lo, hi, step = (float(v) for v in spec.split(":"))
            if step <= 0 or hi < lo:
                raise ValueError
            return np.round(np.arange(lo, hi + step / 2, step), 9)
        return np.array([float(v) for v in spec.split(",")])
    except ValueError:
        raise ValueError(f"--freqs: expected LO:HI:STEP or a comma list of MHz, got '{spec}'") from None


@dataclass
class NecSolver:
    """Solve designs with NEC-2; results cached by content (design, engine, mesh, freqs)."""

    mesh: MeshSettings = field(default_factory=MeshSettings)
    workers: int = 2  # processes; 0 runs NEC in this process (only if healpy is not loaded)
    progress: bool = True
    use_cache: bool = True
    allow_unverified_engine: bool = False

    name = "nec2"

    def cache_key(self, design: Design, freqs_mhz: np.ndarray) -> str:
        info = engine_info()
        ident = {
            "model_version": MODEL_VERSION,
            "design": json.loads(design.canonical()),
            "engine": info,
            "mesh": self.mesh.as_dict(),
            "freqs_mhz": [round(float(f), 9) for f in freqs_mhz],
        }
        return hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()[:32]

    def cached(self, design: Design, freqs_mhz: Iterable[float] = np.arange(40.0, 101.0)) -> Beam | None:
        """The cached beam of this solve, or None; never solves."""
        from .cache import BeamCache

        return BeamCache().get(self.cache_key(design, np.asarray(list(freqs_mhz), dtype=float)))

    def solve(self, design: Design, freqs_mhz: Iterable[float] = np.arange(40.0, 101.0)) -> Beam:
        from .cache import BeamCache

        freqs = np.asarray(list(freqs_mhz), dtype=float)
        if freqs.size == 0 or np.any(freqs <= 0):
            raise ValueError("frequencies must be positive MHz")
        ground = "pec" if isinstance(design.ground, InfinitePEC) else "soil"
        cache = BeamCache()
        key = self.cache_key(design, freqs)
        if self.use_cache:
            hit = cache.get(key)
            if hit is not None:
                return hit  # the engine was checked when this entry was solved
        info = check_engine(ground, allow_unverified=self.allow_unverified_engine, in_process=self.workers == 0)
        try:
            model = build_model(design, self.mesh)
        except SolveError:
            raise
        except Exception as exc:  # shapely/geometry trouble: name the candidate
            raise SolveError(f"{design.label()}: could not mesh the model ({exc})") from exc
        symmetric = design.plane is None or all(design.plane.mirror_symmetry.values())
        n_phi = 91 if symmetric else 360
        ref = None
        if self.mesh.gain_calibration == "pec":
            ref = model if ground == "pec" else pec_reference_model(design, self.mesh)
        done = cache.partial(key) if self.use_cache else {}
        todo = [f for f in freqs if float(f) not in done]
        results: dict[float, tuple[np.ndarray, float, float]] = dict(done)
        bar = None
        if self.progress:
            from tqdm import tqdm

            bar = tqdm(total=freqs.size, initial=freqs.size - len(todo), unit="freq",
                       desc=f"NEC {design.plane.key() if design.plane else 'PEC'} ({model.n_segments} seg)")
        jobs = [(model, ref, float(f), n_phi) for f in todo]
        pool = None
        try:
            if self.workers >= 1:  # NEC in worker processes (see engine_call); 0 = in-process
                import multiprocessing as mp

                pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=mp.get_context("spawn"),
                                           initializer=_worker_init)
                outputs = pool.map(_solve_one, jobs)
            else:
                outputs = map(_solve_one, jobs)
            for f, g, kappa, secs in outputs:  # each frequency is saved as soon as it is done
                results[f] = (g, kappa, secs)
                if self.use_cache:
                    cache.put_partial(key, f, g, kappa, secs)
                if bar:
                    bar.update(1)
        except SolveError as exc:
            raise SolveError(f"{design.label()}: {exc}") from exc
        except Exception as exc:
            raise SolveError(f"{design.label()}: NEC solve failed ({type(exc).__name__}: {exc})") from exc
        finally:
            if pool is not None:
                pool.shutdown(cancel_futures=True)
            if bar:
                bar.close()
        gains = np.stack([results[float(f)][0] for f in freqs])
        if n_phi == 91:
            gains = mirror_quadrant(gains)
        kappas = [results[float(f)][1] for f in freqs]
        beam = Beam(
            freqs, np.arange(91.0), np.arange(360.0), gains,
            {
                "source": f"NEC-2 solve of {design.label()}",
                "solver": "nec2",
                "engine": info,
                "design": json.loads(design.canonical()),
                "mesh": self.mesh.as_dict(),
                "n_segments": model.n_segments,
                "mirror_symmetric_solve": symmetric,
                "gain_calibration_kappa": kappas,
                "seconds_per_frequency": [results[float(f)][2] for f in freqs],
                "cache_key": key,
            },
        )
        if self.use_cache:
            cache.put(key, beam)
        return beam
