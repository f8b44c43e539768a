"""Parametric ground-plane outlines (SPEC section 2): exact 2-D polygons in metres,
centred on the feed (the origin), x along the antenna's excitation axis.

Every shape validates its parameters on construction and says what to change; every
shape has ``outline()``, ``metal_area`` (m^2), ``extent`` (tip to tip, m), ``edge_count``,
``mirror_symmetry`` and a stable ``key()`` for caching.
"""
from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, fields
from typing import Any, ClassVar

import numpy as np
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient
from shapely.validation import explain_validity


class ShapeError(ValueError):
    """Impossible ground-plane geometry."""


def _positive(shape: str, **values: float) -> None:
    for name, v in values.items():
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v) or v <= 0:
            raise ShapeError(f"{shape}: {name} must be a positive finite number of metres, got {v!r}")


class GroundPlane:
    """Base of every ground-plane shape. Subclasses are frozen dataclasses that define
    ``_vertices()`` (counter-clockwise, metres) and, where a closed form exists, ``_area()``."""

    kind: ClassVar[str] = "polygon"

    def _vertices(self) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _area(self) -> float | None:
        return None

    def _validate_outline(self) -> None:
        poly = self.outline()
        if not poly.is_valid:
            raise ShapeError(f"{self.describe()}: the outline is not a simple polygon ({explain_validity(poly)})")
        exact = self._area()
        if exact is not None and not math.isclose(exact, poly.area, rel_tol=1e-9, abs_tol=1e-9):
            raise ShapeError(
                f"{self.describe()}: teeth overlap each other or the plane (outline area {poly.area:.6g} m^2 "
                f"!= {exact:.6g} m^2 expected)"
            )

    def outline(self) -> Polygon:
        """The outline as a shapely Polygon (metres, counter-clockwise, centred on the feed)."""
        return orient(Polygon(self._vertices()), sign=1.0)

    @property
    def metal_area(self) -> float:
        """Metal area in m^2 (closed form where there is one, else the outline's area)."""
        a = self._area()
        return float(a if a is not None else self.outline().area)

    @property
    def extent(self) -> float:
        """Tip-to-tip size (m): the larger side of the outline's bounding box."""
        x0, y0, x1, y1 = self.outline().bounds
        return float(max(x1 - x0, y1 - y0))

    @property
    def edge_count(self) -> int:
        """Number of straight edges of the outline (collinear runs counted once)."""
        v = np.asarray(self.outline().exterior.coords)[:-1]
        prev, nxt = np.roll(v, 1, axis=0), np.roll(v, -1, axis=0)
        cross = (v[:, 0] - prev[:, 0]) * (nxt[:, 1] - v[:, 1]) - (v[:, 1] - prev[:, 1]) * (nxt[:, 0] - v[:, 0])
        return int(np.sum(np.abs(cross) > 1e-12))

    @property
    def mirror_symmetry(self) -> dict[str, bool]:
        """Mirror symmetry about the x axis (y -> -y) and the y axis (x -> -x)."""
        return {"x": _is_mirror(self.outline(), 1.0, -1.0), "y": _is_mirror(self.outline(), -1.0, 1.0)}

    def params(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in fields(self)}  # type: ignore[arg-type]

    def key(self) -> str:
        """A stable content key: the shape kind and its parameters, canonical JSON, hashed."""
        return f"{self.kind}-" + hashlib.sha256(self.canonical().encode()).hexdigest()[:16]

    def canonical(self) -> str:
        def norm(v: Any) -> Any:
            if isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool):
                return round(float(v), 9)  # Square(10) and Square(10.0) are one design
            if isinstance(v, (list, tuple)):
                return [norm(x) for x in v]
            return v

        return json.dumps({"kind": self.kind, **{k: norm(v) for k, v in self.params().items()}}, sort_keys=True)

    def describe(self) -> str:
        return f"{type(self).__name__}(" + ", ".join(f"{k}={v!r}" for k, v in self.params().items()) + ")"

    def summary(self) -> dict[str, Any]:
        return {
            "shape": self.kind,
            "params": self.params(),
            "metal_area_m2": self.metal_area,
            "extent_m": self.extent,
            "edge_count": self.edge_count,
            "mirror_symmetry": self.mirror_symmetry,
            "key": self.key(),
        }


def _is_mirror(poly: Polygon, sx: float, sy: float) -> bool:
    from shapely.affinity import scale

    m = scale(poly, xfact=sx, yfact=sy, origin=(0, 0))
    return poly.symmetric_difference(m).area <= 1e-9 * max(poly.area, 1.0)


@dataclass(frozen=True)
class Square(GroundPlane):
    """A square of side ``side`` (m)."""

    side: float
    kind: ClassVar[str] = "square"

    def __post_init__(self) -> None:
        _positive("Square", side=self.side)

    def _vertices(self) -> np.ndarray:
        h = self.side / 2
        return np.array([[-h, -h], [h, -h], [h, h], [-h, h]])

    def _area(self) -> float:
        return self.side**2


@dataclass(frozen=True)
class Plus(GroundPlane):
    """Five equal squares of side ``arm`` in a cross (tip to tip 3 x arm)."""

    arm: float
    kind: ClassVar[str] = "plus"

    def __post_init__(self) -> None:
        _positive("Plus", arm=self.arm)

    def _vertices(self) -> np.ndarray:
        a, b = self.arm / 2, 1.5 * self.arm
        return np.array([
            [a, -a], [b, -a], [b, a], [a, a], [a, b], [-a, b], [-a, a], [-b, a],
            [-b, -a], [-a, -a], [-a, -b], [a, -b],
        ])

    def _area(self) -> float:
        return 5 * self.arm**2


def _square_with_teeth(side: float, n: int, base: float, height: float) -> np.ndarray:
    """Counter-clockwise vertices of a square with ``n`` isosceles teeth per side, each
    centred in one of ``n`` equal segments of the side."""
    h = side / 2
    seg = side / n
    pts: list[tuple[float, float]] = []
    # side 0 runs along y = -h from x = -h to +h, outward normal -y; rotate for the others
    local: list[tuple[float, float]] = [(-h, 0.0)]
    for i in range(n):
        c = -h + (i + 0.5) * seg
        local += [(c - base / 2, 0.0), (c, height), (c + base / 2, 0.0)]
    for k in range(4):
        ang = k * math.pi / 2
        ca, sa = math.cos(ang), math.sin(ang)
        for u, v in local:
            x, y = u, -h - v  # outward is -y on side 0
            pts.append((x * ca - y * sa, x * sa + y * ca))
    out = np.array(pts)
    keep = np.ones(len(out), dtype=bool)  # drop repeated points (teeth that touch)
    keep[1:] = np.any(np.abs(np.diff(out, axis=0)) > 1e-12, axis=1)
    out = out[keep]
    if np.allclose(out[0], out[-1]):
        out = out[:-1]
    return out


@dataclass(frozen=True)
class Sawtooth(GroundPlane):
    """A central square of side ``side`` with ``teeth_per_side`` isosceles triangles (base
    ``tooth_base``, height ``tooth_height``) evenly spaced along each side: 4 x n in all."""

    side: float
    teeth_per_side: int
    tooth_base: float
    tooth_height: float
    kind: ClassVar[str] = "sawtooth"

    def __post_init__(self) -> None:
        _positive("Sawtooth", side=self.side, tooth_base=self.tooth_base, tooth_height=self.tooth_height)
        n = self.teeth_per_side
        if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1:
            raise ShapeError(f"Sawtooth: teeth_per_side must be a whole number >= 1, got {n!r}")
        if n * self.tooth_base > self.side * (1 + 1e-12):
            raise ShapeError(
                f"Sawtooth: {n} teeth of base {self.tooth_base:g} m need {n * self.tooth_base:g} m but a side is "
                f"{self.side:g} m; use teeth_per_side <= {int(self.side // self.tooth_base)} or "
                f"tooth_base <= {self.side / n:g} m"
            )
        self._validate_outline()

    def _vertices(self) -> np.ndarray:
        return _square_with_teeth(self.side, int(self.teeth_per_side), self.tooth_base, self.tooth_height)

    def _area(self) -> float:
        return self.side**2 + 4 * self.teeth_per_side * 0.5 * self.tooth_base * self.tooth_height

    @property
    def n_teeth(self) -> int:
        return 4 * int(self.teeth_per_side)


@dataclass(frozen=True)
class RegularPolygon(GroundPlane):
    """A regular polygon of ``n_sides`` with circumradius ``radius`` (a disc as n grows),
    a flat side facing +x when ``rotation_deg`` is 0."""

    n_sides: int
    radius: float
    rotation_deg: float = 0.0
    kind: ClassVar[str] = "polygon-n"

    def __post_init__(self) -> None:
        _positive("RegularPolygon", radius=self.radius)
        if not isinstance(self.n_sides, (int, np.integer)) or self.n_sides < 3:
            raise ShapeError(f"RegularPolygon: n_sides must be a whole number >= 3, got {self.n_sides!r}")
        if not math.isfinite(self.rotation_deg):
            raise ShapeError("RegularPolygon: rotation_deg must be finite")

    def _vertices(self) -> np.ndarray:
        n = int(self.n_sides)
        a = np.radians(self.rotation_deg) + np.pi / n + 2 * np.pi * np.arange(n) / n
        return self.radius * np.column_stack([np.cos(a), np.sin(a)])

    def _area(self) -> float:
        n = int(self.n_sides)
        return 0.5 * n * self.radius**2 * math.sin(2 * math.pi / n)


@dataclass(frozen=True)
class Star(GroundPlane):
    """A star / serrated disc: ``n_points`` tips at ``outer_radius`` alternating with
    notches at ``inner_radius`` (first tip on +x)."""

    n_points: int
    outer_radius: float
    inner_radius: float
    kind: ClassVar[str] = "star"

    def __post_init__(self) -> None:
        _positive("Star", outer_radius=self.outer_radius, inner_radius=self.inner_radius)
        if not isinstance(self.n_points, (int, np.integer)) or self.n_points < 3:
            raise ShapeError(f"Star: n_points must be a whole number >= 3, got {self.n_points!r}")
        if self.inner_radius >= self.outer_radius:
            raise ShapeError(
                f"Star: inner_radius ({self.inner_radius:g} m) must be smaller than outer_radius "
                f"({self.outer_radius:g} m)"
            )

    def _vertices(self) -> np.ndarray:
        n = int(self.n_points)
        a = np.pi * np.arange(2 * n) / n
        r = np.where(np.arange(2 * n) % 2 == 0, self.outer_radius, self.inner_radius)
        return np.column_stack([r * np.cos(a), r * np.sin(a)])

    def _area(self) -> float:
        n = int(self.n_points)
        return n * self.outer_radius * self.inner_radius * math.sin(math.pi / n)


@dataclass(frozen=True)
class PolygonPlane(GroundPlane):
    """Any simple polygon outline, given by its vertices (m) around the feed."""

    vertices: tuple[tuple[float, float], ...]
    kind: ClassVar[str] = "polygon"

    def __post_init__(self) -> None:
        try:
            v = np.asarray(self.vertices, dtype=float)
        except (TypeError, ValueError):
            raise ShapeError("PolygonPlane: vertices must be a list of (x, y) pairs in metres") from None
        if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 3:
            raise ShapeError(f"PolygonPlane: need at least 3 (x, y) vertices, got array of shape {v.shape}")
        if not np.all(np.isfinite(v)):
            raise ShapeError("PolygonPlane: vertices must be finite")
        object.__setattr__(self, "vertices", tuple((float(x), float(y)) for x, y in v))
        poly = Polygon(v)
        if not poly.is_valid:
            raise ShapeError(f"PolygonPlane: outline is not a simple polygon: {explain_validity(poly)}")
        if poly.area <= 0:
            raise ShapeError("PolygonPlane: outline has zero area")
        if not poly.contains(Polygon([(0, 0), (1e-6, 0), (0, 1e-6)]).centroid):
            raise ShapeError("PolygonPlane: the feed (origin) must lie inside the outline")

    def _vertices(self) -> np.ndarray:
        return np.asarray(self.vertices)


SHAPES: dict[str, type[GroundPlane]] = {
    "square": Square,
    "plus": Plus,
    "sawtooth": Sawtooth,
    "polygon-n": RegularPolygon,
    "star": Star,
    "polygon": PolygonPlane,
}

# The design-study rows of the paper (Table 3) and the deployed "extended" plane.
PRESETS: dict[str, GroundPlane] = {
    "square-10": Square(10.0),
    "square-20": Square(20.0),
    "square-30": Square(30.0),
    "plus-15": Plus(5.0),
    "plus-30": Plus(10.0),
    "sawtooth-10-8": Sawtooth(10.0, 2, 5.0, 5.0),
    "sawtooth-15-12": Sawtooth(15.0, 3, 5.0, 5.0),
    "sawtooth-20-16": Sawtooth(20.0, 4, 5.0, 5.0),
    "sawtooth-20-20": Sawtooth(20.0, 5, 4.0, 5.0),
    "extended": Sawtooth(20.0, 4, 4.8, 5.0),
}


def preset(name: str) -> GroundPlane:
    try:
        return PRESETS[name]
    except KeyError:
        raise ShapeError(f"unknown preset '{name}'; choose one of {', '.join(PRESETS)}") from None


def from_dict(d: dict[str, Any]) -> GroundPlane:
    """Build a shape from ``{"shape": kind, **params}`` (the sweep/optimiser format) or a preset."""
    d = dict(d)
    if "preset" in d:
        return preset(d["preset"])
    kind = d.pop("shape", None)
    if kind not in SHAPES:
        raise ShapeError(f"unknown shape '{kind}'; choose one of {', '.join(SHAPES)}")
    cls = SHAPES[kind]
    names = {f.name for f in fields(cls)}  # type: ignore[arg-type]
    unknown = set(d) - names
    if unknown:
        raise ShapeError(f"{cls.__name__}: unknown parameter(s) {sorted(unknown)}; expected {sorted(names)}")
    if cls is PolygonPlane:
        d["vertices"] = tuple(tuple(p) for p in d.get("vertices", ()))
    try:
        return cls(**d)
    except TypeError as exc:
        raise ShapeError(f"{cls.__name__}: {exc}") from None


def to_dict(shape: GroundPlane) -> dict[str, Any]:
    d = asdict(shape)  # type: ignore[call-overload]
    if isinstance(shape, PolygonPlane):
        d["vertices"] = [list(p) for p in shape.vertices]
    return {"shape": shape.kind, **d}
