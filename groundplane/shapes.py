"""Parametric ground-plane outlines (SPEC section 2): exact 2-D polygons in metres,
centred on the feed (the origin), x along the antenna's excitation axis.

Each family is a subclass of :class:`GroundPlane` that registers itself under its
``kind`` and declares its parameters once, with :func:`param`: help text, optimiser
bounds, the values an integer parameter is searched over. It also declares its metal
area as a closed form valid for *any* parameters (the optimiser's constraint needs it
outside the valid region too) and its validity constraints. The CLI shape flags, the
sweep TOML and the optimiser are all generated from those declarations, so a new family
is one class (``groundplane.shapes.preset("square-10")`` gives a paper's plane; ``SHAPES``
every family)::

    class Ring(GroundPlane, kind="ring"):
        outer: float = param("outer radius (m)", bounds=(2.0, 20.0))
        ...
        def _vertices(self): ...
        @classmethod
        def area_of(cls, p): ...
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Callable, ClassVar, get_type_hints

import numpy as np
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient
from shapely.validation import explain_validity

from .errors import ShapeError
from .files import strict_json

__all__ = ["GroundPlane", "ShapeError", "Param", "param", "SHAPES", "PRESETS", "preset", "from_dict", "to_dict",
           "Square", "Plus", "Sawtooth", "Teeth", "TeethXY", "RegularPolygon", "Star", "PolygonPlane"]

SHAPES: dict[str, type["GroundPlane"]] = {}
"""Every registered shape family, by kind (filled by ``GroundPlane.__init_subclass__``)."""


MAX_COUNT = 1000  # teeth per side, polygon sides, star points: more is a typo (and millions of vertices)
MIN_EXTENT_M, MAX_EXTENT_M = 1.0, 1000.0  # tip to tip
MAX_VERTICES = 2_000  # a polygon outline's corners: as-built outlines have tens, a 1000-point star 2000; 9999 took
# fabricate over 120 s and a STEP export 93 s and 883 MB
MIN_ANGLE_DEG = 1e-3  # an outline vertex sharper than this folds back on itself (a cut's zero-width sliver)
# The outline's area may differ from the closed form by float noise and by the near-straight vertices an outline
# drops (each at most 1e-9 side^2 / 2: 2e-7 m^2 measured on a 13 m teeth-xy core); parts that really overlap differ
# by more than this square millimetre, and no mesh (cells of centimetres at the finest) could see less.
AREA_CHECK_M2 = 1e-6


def param(help: str, *, bounds: tuple[float, float] | None = None, values: tuple[int, ...] = (),
          minimum: float | None = 0.0, optimise: bool = True, default: Any = dataclasses.MISSING,
          parse: Callable[[str], Any] | None = None) -> Any:
    """Declare a shape parameter.

    Parameters
    ----------
    help : str
        What it is, with its unit; shown by ``--help``.
    bounds : (float, float), optional
        The optimiser's search range for a continuous parameter.
    values : tuple of int
        The values the optimiser enumerates for an integer parameter.
    minimum : float or None
        Values must exceed this (0: positive lengths); None accepts any finite value.
    optimise : bool
        False keeps the parameter at its default (or the CLI value) during a search.
    default
        Makes the parameter optional.
    parse : callable, optional
        Turns the command-line string into the value (for structured parameters).
    """
    meta = {"help": help, "bounds": bounds, "values": tuple(values), "minimum": minimum, "optimise": optimise,
            "parse": parse}
    return field(default=default, metadata={"shape_param": meta})


@dataclass(frozen=True)
class Param:
    """A family's parameter, as the CLI, the sweep TOML and the optimiser see it."""

    name: str
    type: type
    help: str
    bounds: tuple[float, float] | None
    values: tuple[int, ...]
    minimum: float | None
    optimise: bool
    required: bool
    parse: Callable[[str], Any] | None

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")


def _check_number(shape: str, p: Param, v: Any) -> None:
    if p.type is int:
        if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or (p.minimum is not None and v < p.minimum):
            floor = "" if p.minimum is None else f" >= {p.minimum:g}"
            raise ShapeError(f"{shape}: {p.name} must be a whole number{floor}, got {v!r}")
        return
    ok = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and math.isfinite(v)
    if not ok or (p.minimum is not None and v <= p.minimum):
        what = "a positive finite number of metres" if p.minimum == 0.0 else "a finite number"
        raise ShapeError(f"{shape}: {p.name} must be {what}, got {v!r}")


class GroundPlane:
    """Base of every ground-plane shape family.

    A subclass passes ``kind="name"`` and declares its parameters with :func:`param`; it is
    made a frozen dataclass and registered in :data:`SHAPES`. It must define
    ``_vertices()`` (counter-clockwise, metres) and may define ``area_of`` (closed-form
    metal area), ``constraints`` (validity, each value <= 0 when valid) and
    ``optimiser_start``.
    """

    kind: ClassVar[str] = ""

    def __init_subclass__(cls, kind: str | None = None, **kw: Any) -> None:
        super().__init_subclass__(**kw)
        if not kind:
            raise TypeError(f"{cls.__name__}: a shape family needs a kind, e.g. class {cls.__name__}(GroundPlane, "
                            f"kind='{cls.__name__.lower()}')")
        if kind in SHAPES:
            raise TypeError(f"{cls.__name__}: shape kind '{kind}' is already registered by {SHAPES[kind].__name__}")
        if cls._vertices is GroundPlane._vertices:
            raise TypeError(f"{cls.__name__}: a shape family must define _vertices() (its outline)")
        cls.kind = kind
        dataclass(frozen=True)(cls)
        missing = [f.name for f in fields(cls) if "shape_param" not in f.metadata]  # type: ignore[arg-type]
        if missing:
            raise TypeError(f"{cls.__name__}: declare every parameter with param(help, ...): {missing}")
        SHAPES[kind] = cls

    # ------------------------------------------------------------ declarations
    @classmethod
    def parameters(cls) -> list[Param]:
        """The family's parameters in declaration order."""
        hints = get_type_hints(cls)
        out = []
        for f in fields(cls):  # type: ignore[arg-type]
            m = f.metadata["shape_param"]
            t = hints[f.name]
            out.append(Param(f.name, t if t in (int, float) else object, m["help"], m["bounds"], m["values"],
                             m["minimum"], m["optimise"], f.default is dataclasses.MISSING, m["parse"]))
        return out

    @classmethod
    def area_of(cls, p: dict[str, Any]) -> float | None:
        """Closed-form metal area (m^2) of parameters ``p``, defined outside the valid
        region too; None where there is no closed form (the outline's area is used)."""
        return None

    @classmethod
    def constraints(cls, p: dict[str, Any]) -> list[tuple[float, str]]:
        """Validity constraints as (value, message): valid when every value <= 0."""
        return []

    @classmethod
    def member(cls, plane: "GroundPlane") -> "GroundPlane | None":
        """``plane`` as a member of this family when it is one (the optimiser's seeds); a family
        that holds other families' shapes exactly says so here."""
        return plane if isinstance(plane, cls) else None

    @classmethod
    def sample(cls, u: dict[str, float], integer: dict[str, int]) -> dict[str, float]:
        """The continuous parameters for unit-cube coordinates ``u`` (one in [0, 1] per parameter):
        a space-filling sample of the family. A family whose validity couples its parameters
        (teeth that must fit their side) maps the cube onto its valid region, so that a sample
        is rarely wasted; the default spans each parameter's bounds."""
        return {p.name: p.bounds[0] + u[p.name] * (p.bounds[1] - p.bounds[0])  # type: ignore[index]
                for p in cls.parameters() if p.bounds is not None and p.optimise}

    @classmethod
    def optimiser_start(cls, max_area: float, integer: dict[str, int]) -> dict[str, float]:
        """A valid starting point with metal area below ``max_area``: the family's
        parameters at the middle of their bounds, lengths scaled to 80 % of the budget."""
        x = {p.name: 0.5 * sum(p.bounds) for p in cls.parameters() if p.bounds is not None and p.optimise}
        area = cls.area_of({**x, **integer})
        if not area:
            return x
        s = math.sqrt(0.8 * max_area / area)
        return {k: v * s for k, v in x.items()}

    def __post_init__(self) -> None:
        name = type(self).__name__
        for p in self.parameters():
            if p.type in (int, float):
                _check_number(name, p, getattr(self, p.name))
            if p.type is int and getattr(self, p.name) > MAX_COUNT:  # before building millions of vertices
                raise ShapeError(f"{name}: {p.flag} {getattr(self, p.name)} is more than {MAX_COUNT}; no ground "
                                 "plane has that many")
        for value, message in self.constraints(self.params()):
            if value > 1e-9:
                raise ShapeError(f"{name}: {message}")
        self._validate_outline()

    # ------------------------------------------------------------------ outline
    def _vertices(self) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _validate_outline(self) -> None:
        poly = self.outline()
        if not poly.is_valid:
            raise ShapeError(f"{self.describe()}: the outline is not a simple polygon ({explain_validity(poly)})")
        if poly.area <= 0:
            raise ShapeError(f"{self.describe()}: the outline has zero area")
        angle, where = smallest_interior_angle(poly)
        if angle < MIN_ANGLE_DEG:  # shapely calls a zero-width spike valid; no mesh can follow it
            raise ShapeError(f"{self.describe()}: the outline folds back on itself at ({where[0]:.3f}, {where[1]:.3f}) "
                             f"m (an interior angle of {angle:.2g} deg)")
        if not MIN_EXTENT_M <= self.extent <= MAX_EXTENT_M:
            raise ShapeError(f"{self.describe()}: {self.extent:.3g} m tip to tip; a ground plane is "
                             f"{MIN_EXTENT_M:g}-{MAX_EXTENT_M:g} m (smaller than the blade, 1.25 m across, or "
                             "larger than a kilometre is a typo)")
        exact = self.area_of(self.params())
        if exact is not None and not math.isclose(exact, poly.area, rel_tol=1e-9, abs_tol=AREA_CHECK_M2):
            what = ("parts overlap each other or the plane" if poly.area < exact else
                    "the outline holds more metal than its parts (a lost or extra vertex)")
            raise ShapeError(f"{self.describe()}: {what}: outline area {poly.area:.9g} m^2, {exact:.9g} m^2 expected "
                             f"(a difference of {poly.area - exact:+.3g} m^2)")

    def outline(self) -> Polygon:
        """The outline as a shapely Polygon (metres, counter-clockwise, centred on the feed)."""
        return orient(Polygon(self._vertices()), sign=1.0)

    @property
    def metal_area(self) -> float:
        """Metal area in m^2 (closed form where there is one, else the outline's area)."""
        a = self.area_of(self.params())
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

    # ------------------------------------------------------------------ identity
    def params(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in fields(self)}  # type: ignore[arg-type]

    def key(self) -> str:
        """A stable content key: the shape kind and its parameters, canonical JSON, hashed."""
        return f"{self.kind}-" + hashlib.sha256(self.canonical().encode()).hexdigest()[:16]

    def outline_key(self) -> str:
        """A content key of the outline alone: one for every parameterisation of the same metal
        (a ``teeth-xy`` whose teeth have height 0 is the same plane whatever their base), which is
        all an engine meshes. Vertices to 1 um, counter-clockwise from the smallest (x, y).

        >>> Square(side=10).outline_key() == SHAPES["teeth-xy"].member(Square(side=10)).outline_key()
        True
        """
        v = np.round(np.asarray(self.outline().exterior.coords)[:-1], 6) + 0.0  # + 0.0: no -0.0 in the key
        start = min(range(len(v)), key=lambda i: (v[i, 0], v[i, 1]))
        ring = np.roll(v, -start, axis=0)
        return "outline-" + hashlib.sha256(json.dumps(ring.tolist()).encode()).hexdigest()[:16]

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


def smallest_interior_angle(poly: Polygon) -> tuple[float, tuple[float, float]]:
    """The outline's smallest interior angle (deg) and the vertex where it is."""
    v = np.asarray(orient(poly, sign=1.0).exterior.coords)[:-1]  # counter-clockwise
    a, b = v - np.roll(v, 1, axis=0), np.roll(v, -1, axis=0) - v
    turn = np.degrees(np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], np.einsum("ij,ij->i", a, b)))
    k = int(np.argmax(turn))  # the interior angle is 180 - the left turn
    return float(180.0 - turn[k]), (float(v[k, 0]), float(v[k, 1]))


def _is_mirror(poly: Polygon, sx: float, sy: float) -> bool:
    from shapely.affinity import scale

    m = scale(poly, xfact=sx, yfact=sy, origin=(0, 0))
    return poly.symmetric_difference(m).area <= 1e-9 * max(poly.area, 1.0)


# ------------------------------------------------------------------- families
class Square(GroundPlane, kind="square"):
    """A square of side ``side`` (m)."""

    side: float = param("side of the square (m)", bounds=(2.0, 40.0))

    def _vertices(self) -> np.ndarray:
        h = self.side / 2
        return np.array([[-h, -h], [h, -h], [h, h], [-h, h]])

    @classmethod
    def area_of(cls, p: dict[str, Any]) -> float:
        return p["side"] ** 2


class Plus(GroundPlane, kind="plus"):
    """Five equal squares of side ``arm`` in a cross (tip to tip 3 x arm)."""

    arm: float = param("side of each of the five squares of the cross (m); tip to tip is 3 x arm",
                       bounds=(1.0, 15.0))

    def _vertices(self) -> np.ndarray:
        a, b = self.arm / 2, 1.5 * self.arm
        return np.array([
            [a, -a], [b, -a], [b, a], [a, a], [a, b], [-a, b], [-a, a], [-b, a],
            [-b, -a], [-a, -a], [-a, -b], [a, -b],
        ])

    @classmethod
    def area_of(cls, p: dict[str, Any]) -> float:
        return 5 * p["arm"] ** 2


def _square_with_teeth(side: float, n: int, base: float, height: float, tip: float = 0.0) -> np.ndarray:
    """Counter-clockwise vertices of a square with ``n`` symmetric teeth per side, each
    centred in one of ``n`` equal segments of the side: triangles, or trapezoids whose tip is
    ``tip`` wide."""
    h = side / 2
    seg = side / n
    pts: list[tuple[float, float]] = []
    # side 0 runs along y = -h from x = -h to +h, outward normal -y; rotate for the others
    local: list[tuple[float, float]] = [(-h, 0.0)]
    for i in range(n):
        c = -h + (i + 0.5) * seg
        local += [(c - base / 2, 0.0), (c - tip / 2, height), (c + tip / 2, height), (c + base / 2, 0.0)]
    for k in range(4):
        ang = k * math.pi / 2
        ca, sa = math.cos(ang), math.sin(ang)
        for u, v in local:
            x, y = u, -h - v  # outward is -y on side 0
            pts.append((x * ca - y * sa, x * sa + y * ca))
    return _without_repeats(np.array(pts))


class Sawtooth(GroundPlane, kind="sawtooth"):
    """A central square of side ``side`` with ``teeth_per_side`` isosceles triangles (base
    ``tooth_base``, height ``tooth_height``) evenly spaced along each side: 4 x n in all."""

    side: float = param("side of the central square (m)", bounds=(4.0, 30.0))
    teeth_per_side: int = param("triangles on each side of the square (4 x this in all)",
                                values=(2, 3, 4, 5, 6), minimum=1)
    tooth_base: float = param("base of each triangle (m)", bounds=(0.5, 10.0))
    tooth_height: float = param("height of each triangle (m)", bounds=(0.5, 10.0))

    def _vertices(self) -> np.ndarray:
        return _square_with_teeth(self.side, int(self.teeth_per_side), self.tooth_base, self.tooth_height)

    @classmethod
    def area_of(cls, p: dict[str, Any]) -> float:
        return p["side"] ** 2 + 4 * p["teeth_per_side"] * 0.5 * p["tooth_base"] * p["tooth_height"]

    @classmethod
    def constraints(cls, p: dict[str, Any]) -> list[tuple[float, str]]:
        n, base, side = p["teeth_per_side"], p["tooth_base"], p["side"]
        return [(n * base - side,
                 f"{n} teeth of base {base:g} m need {n * base:g} m but a side is {side:g} m; use teeth_per_side "
                 f"<= {int(side // base)} or tooth_base <= {side / n:g} m")]

    @classmethod
    def optimiser_start(cls, max_area: float, integer: dict[str, int]) -> dict[str, float]:
        # half the budget in the square, teeth filling 80 % of each side, the rest in their height
        n = integer["teeth_per_side"]
        side = math.sqrt(0.5 * max_area)
        base = 0.8 * side / n
        return {"side": side, "tooth_base": base, "tooth_height": min(10.0, 0.3 * max_area / (2 * n * base))}

    @property
    def n_teeth(self) -> int:
        return 4 * int(self.teeth_per_side)


class Teeth(GroundPlane, kind="teeth"):
    """A central square of side ``side`` with ``teeth_per_side`` trapezoidal teeth on each
    side (base ``tooth_base``, height ``tooth_height``, tip ``tip_fraction`` x the base wide),
    evenly spaced: the optimiser's general family. The paper's shapes are members: a sawtooth
    has tip 0, a plus one tooth as wide and as tall as the side with tip 1, a square teeth of
    height 0 (:meth:`member`)."""

    side: float = param("side of the central square (m)", bounds=(4.0, 30.0))
    teeth_per_side: int = param("teeth on each side of the square (4 x this in all)", values=(1, 2, 3, 4, 5, 6),
                                minimum=1)
    tooth_base: float = param("base of each tooth along the side (m)", bounds=(0.5, 15.0))
    tooth_height: float = param("height of each tooth out from the side (m); 0: none", bounds=(0.0, 12.0),
                                minimum=None)
    tip_fraction: float = param("width of each tooth's tip as a fraction of its base: 0 a triangle, 1 a rectangle",
                                bounds=(0.0, 1.0), minimum=None)

    def _vertices(self) -> np.ndarray:
        v = _square_with_teeth(self.side, int(self.teeth_per_side), self.tooth_base, self.tooth_height,
                               self.tip_fraction * self.tooth_base)
        a, b = v - np.roll(v, 1, axis=0), np.roll(v, -1, axis=0) - v
        turn = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
        return v[turn > 1e-9 * self.side ** 2]  # a vertex on a straight edge (teeth of height 0) is no corner

    @classmethod
    def area_of(cls, p: dict[str, Any]) -> float:
        return p["side"] ** 2 + 4 * p["teeth_per_side"] * p["tooth_height"] * p["tooth_base"] * (1 + p["tip_fraction"]) / 2

    @classmethod
    def constraints(cls, p: dict[str, Any]) -> list[tuple[float, str]]:
        n, base, side, height, tip = p["teeth_per_side"], p["tooth_base"], p["side"], p["tooth_height"], p["tip_fraction"]
        return [(n * base - side, f"{n} teeth of base {base:g} m need {n * base:g} m but a side is {side:g} m"),
                (-height, f"tooth_height {height:g} m must be >= 0"),
                (-tip, f"tip_fraction {tip:g} must be >= 0"), (tip - 1, f"tip_fraction {tip:g} must be <= 1")]

    @classmethod
    def optimiser_start(cls, max_area: float, integer: dict[str, int]) -> dict[str, float]:
        # half the budget in the square, teeth filling 80 % of each side, the rest in their height
        n = integer["teeth_per_side"]
        side = min(30.0, math.sqrt(0.5 * max_area))
        base = 0.8 * side / n
        return {"side": side, "tooth_base": base, "tip_fraction": 0.5,
                "tooth_height": min(12.0, 0.3 * max_area / (4 * n * base * 0.75))}

    @classmethod
    def sample(cls, u: dict[str, float], integer: dict[str, int]) -> dict[str, float]:
        p = super().sample(u, integer)
        lo, hi = _bounds(cls, "tooth_base")
        p["tooth_base"] = lo + u["tooth_base"] * max(0.0, min(hi, p["side"] / integer["teeth_per_side"]) - lo)
        return p

    @classmethod
    def member(cls, plane: GroundPlane) -> "Teeth | None":
        """``plane`` as a member of this family, when it is one exactly (same outline)."""
        if isinstance(plane, Teeth):
            return plane
        if isinstance(plane, Sawtooth):
            return cls(plane.side, int(plane.teeth_per_side), plane.tooth_base, plane.tooth_height, 0.0)
        if isinstance(plane, Plus):
            return cls(plane.arm, 1, plane.arm, plane.arm, 1.0)
        if isinstance(plane, Square):
            return cls(plane.side, 1, 0.5 * plane.side, 0.0, 0.0)
        return None


def _bounds(cls: type[GroundPlane], name: str) -> tuple[float, float]:
    """A parameter's declared optimiser bounds."""
    return next(p.bounds for p in cls.parameters() if p.name == name)  # type: ignore[return-value]


def _without_repeats(ring: np.ndarray, tol: float = 1e-12) -> np.ndarray:
    """A closed ring's vertices without repeated points (square corners, teeth that touch), the
    last against the first by the same rule: a last vertex tens of microns from the first is a
    corner of the plane (a tooth ending just short of a corner), not the ring closing on itself."""
    keep = np.ones(len(ring), dtype=bool)
    keep[1:] = np.any(np.abs(np.diff(ring, axis=0)) > tol, axis=1)
    ring = ring[keep]
    return ring[:-1] if len(ring) > 1 and not np.any(np.abs(ring[0] - ring[-1]) > tol) else ring


def _tooth(centre: float, base: float, height: float, tip: float) -> list[tuple[float, float]]:
    """A symmetric tooth on a side, in (along, out) coordinates: its base corners and tip corners."""
    return [(centre - base / 2, 0.0), (centre - tip / 2, height), (centre + tip / 2, height), (centre + base / 2, 0.0)]


class TeethXY(GroundPlane, kind="teeth-xy"):
    """The optimiser's richest family: a square core of side ``side`` with its corners cut at 45
    deg by ``chamfer``; ``teeth_per_side`` trapezoidal teeth on each side, those on the two sides
    facing +-x (pointing along the excitation axis, the E-plane) and those facing +-y (the H-plane)
    each with their own base, height and tip fraction; and one tooth on each chamfered corner
    (``base_d``, ``height_d``, ``tip_d``; base or height 0: none). Crosses (one rectangular tooth a
    side, arms along and across the axis of their own length), tapered crosses, four- and
    eight-pointed stars on a chamfered core, sawtooth planes and squares are members; ``teeth``,
    ``sawtooth``, ``plus`` and ``square`` planes exactly (:meth:`member`). Teeth are centred in
    ``teeth_per_side`` equal segments of a side and must stay clear of the chamfers."""

    side: float = param("side of the square core (m)", bounds=(4.0, 30.0))
    teeth_per_side: int = param("teeth on each side (4 x this in all, besides the corner teeth)",
                                values=(1, 2, 3, 4), minimum=1)
    chamfer: float = param("the core's corners cut at 45 deg, this far along each side (m); 0: square corners",
                           bounds=(0.0, 10.0), minimum=None)
    base_x: float = param("base of each tooth on the sides facing +-x (along the excitation axis) (m)",
                          bounds=(0.5, 15.0))
    height_x: float = param("height of those teeth (m); 0: none", bounds=(0.0, 14.0), minimum=None)
    tip_x: float = param("their tip as a fraction of their base: 0 a triangle, 1 a rectangle", bounds=(0.0, 1.0),
                         minimum=None)
    base_y: float = param("base of each tooth on the sides facing +-y (across the axis) (m)", bounds=(0.5, 15.0))
    height_y: float = param("height of those teeth (m); 0: none", bounds=(0.0, 14.0), minimum=None)
    tip_y: float = param("their tip as a fraction of their base", bounds=(0.0, 1.0), minimum=None)
    base_d: float = param("base of the tooth on each chamfered corner (m); 0: none", bounds=(0.0, 14.0),
                          minimum=None)
    height_d: float = param("height of the corner teeth (m); 0: none", bounds=(0.0, 14.0), minimum=None)
    tip_d: float = param("the corner teeth's tip as a fraction of their base", bounds=(0.0, 1.0), minimum=None)

    def _vertices(self) -> np.ndarray:
        h, c, n = self.side / 2, self.chamfer, int(self.teeth_per_side)
        seg = self.side / n
        pts: list[tuple[float, float]] = []
        for k in range(4):  # side k: side 0 along y = -h (outward -y), the others turned k x 90 deg
            base, height, tip = ((self.base_y, self.height_y, self.tip_y) if k % 2 == 0 else
                                 (self.base_x, self.height_x, self.tip_x))
            local = [(-h + c, 0.0)]
            if height > 1e-12:
                for i in range(n):
                    local += _tooth(-h + (i + 0.5) * seg, base, height, tip * base)
            local.append((h - c, 0.0))
            ang = k * math.pi / 2
            ca, sa = math.cos(ang), math.sin(ang)
            for u, v in local:
                x, y = u, -h - v
                pts.append((x * ca - y * sa, x * sa + y * ca))
            if c > 1e-12 and self.base_d > 1e-12 and self.height_d > 1e-12:  # the corner tooth after side k
                edge = c * math.sqrt(2.0)
                for u, v in _tooth(edge / 2, self.base_d, self.height_d, self.tip_d * self.base_d):
                    # along the chamfer from (h - c, -h) toward (h, -h + c); outward (1, -1) / sqrt 2
                    x = h - c + (u + v) / math.sqrt(2.0)
                    y = -h + (u - v) / math.sqrt(2.0)
                    pts.append((x * ca - y * sa, x * sa + y * ca))
        out = _without_repeats(np.array(pts))
        a, b = out - np.roll(out, 1, axis=0), np.roll(out, -1, axis=0) - out
        turn = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
        return out[turn > 1e-9 * self.side ** 2]  # a vertex on a straight edge is no corner

    @classmethod
    def area_of(cls, p: dict[str, Any]) -> float:
        n = p["teeth_per_side"]
        def teeth(b, hgt, t):
            return hgt * b * (1 + t) / 2
        return (p["side"] ** 2 - 2 * p["chamfer"] ** 2 + 2 * n * teeth(p["base_x"], p["height_x"], p["tip_x"])
                + 2 * n * teeth(p["base_y"], p["height_y"], p["tip_y"])
                + 4 * teeth(p["base_d"], p["height_d"], p["tip_d"]))

    @classmethod
    def constraints(cls, p: dict[str, Any]) -> list[tuple[float, str]]:
        n, side, c = p["teeth_per_side"], p["side"], p["chamfer"]
        out = [(-c, f"chamfer {c:g} m must be >= 0"),
               (p["base_d"] - c * math.sqrt(2.0), f"corner teeth of base {p['base_d']:g} m do not fit a chamfer of "
                                                  f"{c * math.sqrt(2.0):.3g} m")]
        for axis in ("x", "y"):
            b = p[f"base_{axis}"]
            out.append((b + 2 * c - side / n, f"{n} teeth of base {b:g} m a side, clear of {c:g} m chamfers, need "
                                              f"{n * (b + 2 * c):g} m but a side is {side:g} m"))
        for name in ("height_x", "height_y", "base_d", "height_d", "tip_x", "tip_y", "tip_d"):
            out.append((-p[name], f"{name} {p[name]:g} must be >= 0"))
        for name in ("tip_x", "tip_y", "tip_d"):
            out.append((p[name] - 1, f"{name} {p[name]:g} must be <= 1"))
        return out

    @classmethod
    def optimiser_start(cls, max_area: float, integer: dict[str, int]) -> dict[str, float]:
        # half the budget in the core, teeth filling 80 % of each side, the rest in their height
        n = integer["teeth_per_side"]
        side = min(30.0, math.sqrt(0.5 * max_area))
        base = 0.8 * side / n
        height = min(14.0, 0.3 * max_area / (4 * n * base * 0.75))
        return {"side": side, "chamfer": 0.0, "base_x": base, "height_x": height, "tip_x": 0.5, "base_y": base,
                "height_y": height, "tip_y": 0.5, "base_d": 0.0, "height_d": 0.0, "tip_d": 0.5}

    @classmethod
    def sample(cls, u: dict[str, float], integer: dict[str, int]) -> dict[str, float]:
        """The cube onto the valid region: the chamfer leaves every tooth a base of at least the
        lower bound, each base fits its segment beside the chamfers, the corner tooth its chamfer."""
        p = super().sample(u, integer)
        seg = p["side"] / integer["teeth_per_side"]
        base_lo, base_hi = _bounds(cls, "base_x")
        p["chamfer"] = u["chamfer"] * max(0.0, min(_bounds(cls, "chamfer")[1], (seg - base_lo) / 2))
        for axis in ("x", "y"):
            room = min(base_hi, seg - 2 * p["chamfer"])
            p[f"base_{axis}"] = base_lo + u[f"base_{axis}"] * max(0.0, room - base_lo)
        p["base_d"] = u["base_d"] * min(_bounds(cls, "base_d")[1], p["chamfer"] * math.sqrt(2.0))
        return p

    @classmethod
    def member(cls, plane: GroundPlane) -> "TeethXY | None":
        """``plane`` as a member of this family, when it is one exactly (same outline)."""
        if isinstance(plane, TeethXY):
            return plane
        t = Teeth.member(plane)
        if t is None:
            return None
        b, hgt, tip = t.tooth_base, t.tooth_height, t.tip_fraction
        return cls(t.side, int(t.teeth_per_side), 0.0, b, hgt, tip, b, hgt, tip, 0.0, 0.0, 0.0)


class RegularPolygon(GroundPlane, kind="polygon-n"):
    """A regular polygon of ``n_sides`` with circumradius ``radius`` (a disc as n grows),
    a flat side facing +x when ``rotation_deg`` is 0."""

    n_sides: int = param("number of sides of the regular polygon", values=(6, 8, 12), minimum=3)
    radius: float = param("circumradius of the regular polygon (m)", bounds=(1.0, 25.0))
    rotation_deg: float = param("rotation of the polygon (deg, counter-clockwise)", minimum=None, optimise=False,
                                default=0.0)

    def _vertices(self) -> np.ndarray:
        n = int(self.n_sides)
        a = np.radians(self.rotation_deg) + np.pi / n + 2 * np.pi * np.arange(n) / n
        return self.radius * np.column_stack([np.cos(a), np.sin(a)])

    @classmethod
    def area_of(cls, p: dict[str, Any]) -> float:
        n = int(p["n_sides"])
        return 0.5 * n * p["radius"] ** 2 * math.sin(2 * math.pi / n)


class Star(GroundPlane, kind="star"):
    """A star / serrated disc: ``n_points`` tips at ``outer_radius`` alternating with
    notches at ``inner_radius`` (first tip on +x)."""

    n_points: int = param("number of tips of the star", values=(8, 12, 16), minimum=3)
    outer_radius: float = param("radius of the star's tips (m)", bounds=(2.0, 25.0))
    inner_radius: float = param("radius of the star's notches (m), below outer_radius", bounds=(1.0, 20.0))

    def _vertices(self) -> np.ndarray:
        n = int(self.n_points)
        a = np.pi * np.arange(2 * n) / n
        r = np.where(np.arange(2 * n) % 2 == 0, self.outer_radius, self.inner_radius)
        return np.column_stack([r * np.cos(a), r * np.sin(a)])

    @classmethod
    def area_of(cls, p: dict[str, Any]) -> float:
        n = int(p["n_points"])
        return n * p["outer_radius"] * p["inner_radius"] * math.sin(math.pi / n)

    @classmethod
    def sample(cls, u: dict[str, float], integer: dict[str, int]) -> dict[str, float]:
        p = super().sample(u, integer)
        lo, hi = _bounds(cls, "inner_radius")
        p["inner_radius"] = lo + u["inner_radius"] * max(0.0, min(hi, 0.98 * p["outer_radius"]) - lo)
        return p

    @classmethod
    def constraints(cls, p: dict[str, Any]) -> list[tuple[float, str]]:
        return [(p["inner_radius"] - p["outer_radius"] + 1e-6,
                 f"inner_radius ({p['inner_radius']:g} m) must be smaller than outer_radius "
                 f"({p['outer_radius']:g} m)")]

    @classmethod
    def optimiser_start(cls, max_area: float, integer: dict[str, int]) -> dict[str, float]:
        n = integer["n_points"]
        outer = math.sqrt(0.8 * max_area / (n * 0.7 * math.sin(math.pi / n)))
        return {"outer_radius": outer, "inner_radius": 0.7 * outer}


def parse_vertices(text: str) -> tuple[tuple[float, float], ...]:
    """'x,y;x,y;...' (metres) -> vertex pairs."""
    try:
        pts = [tuple(float(c) for c in pt.split(",")) for pt in text.split(";") if pt.strip()]
    except ValueError:
        raise ShapeError(f"--vertices: expected 'x,y;x,y;...', got '{text}'") from None
    if any(len(p) != 2 for p in pts):
        raise ShapeError(f"--vertices: expected 'x,y;x,y;...', got '{text}'")
    return tuple(pts)  # type: ignore[return-value]


class PolygonPlane(GroundPlane, kind="polygon"):
    """Any simple polygon outline, given by its vertices (m) around the feed."""

    vertices: tuple = param("polygon vertices 'x,y;x,y;...' (m), the feed (origin) inside", optimise=False,
                            parse=parse_vertices)

    def __post_init__(self) -> None:
        try:
            v = np.asarray(self.vertices, dtype=float)
        except (TypeError, ValueError):
            raise ShapeError("PolygonPlane: vertices must be a list of (x, y) pairs in metres") from None
        if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 3:
            raise ShapeError(f"PolygonPlane: need at least 3 (x, y) vertices, got array of shape {v.shape}")
        if v.shape[0] > MAX_VERTICES:  # before shapely and the mesher spend minutes on it
            raise ShapeError(f"PolygonPlane: {v.shape[0]:,} vertices; at most {MAX_VERTICES:,} (an outline a field crew "
                             "can lay has tens)")
        if not np.all(np.isfinite(v)):
            raise ShapeError("PolygonPlane: vertices must be finite")
        object.__setattr__(self, "vertices", tuple((float(x), float(y)) for x, y in v))
        self._validate_outline()  # the checks every family's outline passes
        if not self.outline().contains(Polygon([(0, 0), (1e-6, 0), (0, 1e-6)]).centroid):
            raise ShapeError("PolygonPlane: the feed (origin) must lie inside the outline")

    def _vertices(self) -> np.ndarray:
        return np.asarray(self.vertices)

    def describe(self) -> str:
        """Short: an as-built outline has dozens of vertices (``to_dict`` holds them all)."""
        return f"PolygonPlane({len(self.vertices)} vertices, {self.metal_area:.2f} m^2, key {self.key().split('-', 1)[1][:8]})"


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
    """A design-study preset by name (``PRESETS``: the paper's squares, plus, sawtooth, ...).

    >>> p = preset("sawtooth-20-16")
    >>> round(p.metal_area)
    600
    """
    try:
        return PRESETS[name]
    except KeyError:
        raise ShapeError(f"unknown preset '{name}'; choose one of {', '.join(PRESETS)}") from None



def as_plane(plane: Any, where: str) -> "GroundPlane":
    """A public function's plane argument: a shape, or a preset's name; anything else refused
    (:class:`~groundplane.errors.ArgumentError`) naming the function."""
    if isinstance(plane, str):
        return preset(plane)
    if not isinstance(plane, GroundPlane):
        from .options import expect

        expect(plane, GroundPlane, "plane", where, "a ground-plane shape or a preset's name")
    return plane

def from_dict(d: dict[str, Any]) -> GroundPlane:
    """Build a shape from ``{"shape": kind, **params}`` (the sweep/optimiser format) or a preset."""
    if not isinstance(d, dict):
        raise ShapeError(f"a design is a table of 'shape' and its parameters (or 'preset'), got {type(d).__name__}")
    d = dict(d)
    if "preset" in d:
        extra = set(d) - {"preset"}
        if extra:
            raise ShapeError(f"preset takes no other keys; got {sorted(map(str, extra))}")
        if not isinstance(d["preset"], str):
            raise ShapeError(f"preset must be a name, got {type(d['preset']).__name__}")
        return preset(d["preset"])
    kind = d.pop("shape", None)
    if not isinstance(kind, str) or kind not in SHAPES:
        shown = kind if isinstance(kind, str) else f"a {type(kind).__name__}"
        raise ShapeError(f"unknown shape '{str(shown)[:40]}'; choose one of {', '.join(SHAPES)}")
    cls = SHAPES[kind]
    names = {p.name for p in cls.parameters()}
    unknown = set(d) - names
    if unknown:
        raise ShapeError(f"{cls.__name__}: unknown parameter(s) {sorted(unknown)}; expected {sorted(names)}")
    missing = [p.name for p in cls.parameters() if p.required and p.name not in d]
    if missing:
        raise ShapeError(f"{cls.__name__}: missing parameter(s) {missing}")
    if cls is PolygonPlane:
        v = d.get("vertices")
        if not isinstance(v, (list, tuple)) or not all(isinstance(p, (list, tuple)) for p in v):
            raise ShapeError("PolygonPlane: vertices must be a list of [x, y] pairs in metres")
        d["vertices"] = tuple(tuple(p) for p in v)
    return cls(**d)


def to_dict(shape: GroundPlane) -> dict[str, Any]:
    """``{"shape": kind, **params}``: the inverse of :func:`from_dict`."""
    d = shape.params()
    if isinstance(shape, PolygonPlane):
        d["vertices"] = [list(p) for p in shape.vertices]
    return {"shape": shape.kind, **d}


def from_file(path: str | Path) -> GroundPlane:
    """A design saved as JSON: ``{"shape": kind, **params}`` (:func:`to_dict`), ``{"preset": name}``,
    or an optimiser's ``best.json`` (its ``params``; the family from ``shape``, the ``search.json``
    beside it, or the class named in ``name``).

    >>> import json, tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "plane.json")
    >>> _ = open(path, "w").write(json.dumps({"shape": "square", "side": 12.0}))
    >>> from_file(path).metal_area
    144.0
    """
    path = Path(path)
    try:
        d = strict_json(path.read_text())
    except FileNotFoundError:
        raise ShapeError(f"{path}: no such design file") from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:  # JSONDecodeError, a 5000-digit number
        raise ShapeError(f"{path}: not a design file (not readable JSON: {str(exc)[:120]})") from None
    except RecursionError:
        raise ShapeError(f"{path}: not a design file (nested too deeply to be one)") from None
    if not isinstance(d, dict):
        if d is None:  # an optimiser's best.json when nothing met the constraints
            raise ShapeError(f"{path}: holds no design (null: the search found none that meets its constraints; "
                             "the closest is its front's answer-<A>.json, where the pareto front wrote one)")
        raise ShapeError(f"{path}: not a design file (expected a JSON object with 'shape' or 'preset')")
    try:
        return _design_of(d, path)
    except ShapeError as exc:
        raise ShapeError(str(exc) if str(exc).startswith(f"{path}:") else f"{path}: {exc}") from None


def _design_of(d: dict[str, Any], path: Path) -> GroundPlane:
    """The plane of a design file's JSON object (its three forms: see :func:`from_file`)."""
    if "shape" in d and "params" not in d or "preset" in d:
        return from_dict(d)
    if isinstance(d.get("params"), dict):
        kind = d.get("shape")
        search = path.with_name("search.json")
        if kind is None and search.exists():
            try:
                kind = json.loads(search.read_text()).get("shape")
            except (OSError, ValueError, AttributeError):
                kind = None
        if kind is None and isinstance(d.get("name"), str):
            by_class = {cls.__name__: k for k, cls in SHAPES.items()}
            kind = by_class.get(d["name"].split("(")[0])
        if kind is None:
            raise ShapeError(f"{path}: the design's family is not named ('shape', a search.json beside it, "
                             "or a 'name' like 'Teeth(...)')")
        if not isinstance(kind, str):
            raise ShapeError(f"{path}: 'shape' must be a family's name")
        return from_dict({"shape": kind, **d["params"]})
    raise ShapeError(f"{path}: not a design file (expected 'shape' with its parameters, 'preset', "
                     "or an optimiser's best.json with 'params')")
