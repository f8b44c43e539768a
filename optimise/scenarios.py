"""Scenarios: the uncertainty a design must survive, declared once and used by every command
that scores a design (``score``, ``sweep``, ``optimise``, ``study tolerance``).

A scenario set is a list of members; each member is a set of overrides of the settings a
design is solved with (the soil's eps_r and sigma, any field of the engine's model: feed
width, plate height, ...) and/or an as-built variant of the plane (a missing sheet-plan piece,
centimetre corner errors, the antenna off centre or turned). A design is solved on every member
(the soils of one model together: ``Solver.solve_many``), each member scored alike, and the
set's aggregate (mean, worst, or the mean of the worst k) is the design's FoM. Constraints
beside the metal: the largest ground loss over the fit band on every soil member, and the
spread of the loss across the soil members at any frequency (the calibration risk).

Built-in sets: ``nominal`` (the settings as given), ``soil`` (the paper's section-5 corners,
eps_r 2.5 / 5 x sigma 0.005 / 0.05 S/m, and MRO), ``model`` (the feed 4 cm and 125.2 cm wide x
the plate 2.5 and 10 mm above MRO soil), ``as-built`` (the tolerance study's variants) and
``field`` (soil + model + as-built). Any other: a TOML file (:func:`load_set`)::

    name = "wet season"
    aggregate = "worst"          # mean | worst | worst-K (the mean of the worst K)
    [[member]]
    name = "wet"
    eps_r = 5.0
    sigma = 0.05
    [[member]]
    name = "plate 1 cm up, dry"
    eps_r = 2.5
    sigma = 0.005
    plate_height = 0.01
    [[member]]
    name = "a sheet missing"
    as_built = "missing-sheet"   # or corners:ERR_M:DRAW, turned:DEG, offset:DX_M:DY_M, tooth-base:DELTA_M
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable

import numpy as np

from groundplane import paper
from groundplane.design import Design, Soil
from groundplane.errors import ConfigError, SettingsError, ShapeError, SolveError, UserInputError
from groundplane.options import check_name
from groundplane.shapes import GroundPlane, PolygonPlane, from_dict, to_dict

from .evaluate import Candidate, EvalSettings, failed_row, row_head, score

SOIL_CORNERS: tuple[tuple[float, float], ...] = ((2.5, 0.005), (2.5, 0.05), (5.0, 0.005), (5.0, 0.05))
MODEL_FEED_WIDTHS_M = (0.04, 1.252)  # the delta gap's strip: 4 cm (the default), or the whole 125.2 cm panel edge
MODEL_PLATE_HEIGHTS_M = (0.0025, 0.010)  # the sheet 2.5 and 10 mm above the soil (5 mm by default)
CORNER_ERRORS_M = (0.05, 0.10)
TURN_DEG = 2.0
OFFSET_M = 0.10
TOOTH_BASE_ERROR_M = 0.2
FRAGILE = 0.25  # a member that moves the FoM by more than this (relative) makes the design fragile on its axis
DEFAULT_MAX_LOSS = 0.005
MAX_MEMBERS = 100  # members of one scenario set: each is a solve of every design


# ------------------------------------------------------------------ as built
class NotApplicable(ConfigError):
    """An as-built variant the design has no part for (tooth bases of a square, a sheet it has
    not): the member is skipped for that design, and the row says so."""


def _polygon(poly) -> PolygonPlane:
    return PolygonPlane(tuple(poly.exterior.coords)[:-1])


def moved_corners(plane: GroundPlane, err: float, draw: int, tries: int = 1000) -> PolygonPlane:
    """The outline with each corner moved by a uniform random amount in [-err, err] m in x and y:
    the ``draw``-th (from 1) of a sequence seeded by the error, so a rerun builds the same plane;
    a draw that folds the outline over itself is drawn again."""
    from shapely.geometry import Polygon

    outline = np.asarray(plane.outline().exterior.coords)[:-1]
    rng = np.random.default_rng(int(round(err * 1000)))
    plane_out = None
    for _ in range(draw):
        for _ in range(tries):
            moved = outline + rng.uniform(-err, err, outline.shape)
            if Polygon(moved).is_valid:
                plane_out = PolygonPlane(tuple(map(tuple, moved)))
                break
        else:
            raise SolveError(f"as built: no valid outline in {tries} draws of +-{err:g} m corner errors")
    return plane_out  # type: ignore[return-value]


def missing_sheet(plane: GroundPlane, sheet=None) -> tuple[str, PolygonPlane] | None:
    """The plane without the piece of one sheet at its edge: of the sheet plan's pieces on the
    outline holding at least half a sheet, the largest (then the farthest from the centre) whose
    removal leaves one piece of metal around the feed; None if there is none. What is left
    narrower than the mesh's grid cell (a sliver along the cut) goes too."""
    from shapely.geometry import Polygon

    from groundplane.fabricate import MeshSheet, plan_sheets

    sheet = sheet or MeshSheet()
    outline = plane.outline()
    plan = plan_sheets(plane, sheet)
    edge = [p for p in plan.pieces if p.in_plane.area >= 0.5 * sheet.area
            and p.in_plane.exterior.intersection(outline.exterior).length > 0.1]
    edge.sort(key=lambda p: (-round(p.in_plane.area, 6), -p.in_plane.centroid.distance(outline.centroid),
                             p.in_plane.centroid.x, p.in_plane.centroid.y))
    half = sheet.grid / 2
    for p in edge:
        rest = outline.difference(p.in_plane).buffer(-half, join_style="mitre").buffer(half, join_style="mitre")
        if isinstance(rest, Polygon) and not rest.interiors and rest.contains(outline.centroid):
            c = p.in_plane.centroid
            return (f"sheet {p.label} ({p.in_plane.area:.1f} m^2 at x {c.x:+.1f}, y {c.y:+.1f} m) missing",
                    _polygon(rest.simplify(1e-6)))
    return None


AS_BUILT_LIMITS = {"turned": 180.0, "offset": 10.0, "tooth-base": 10.0}  # |deg|, |m|, |m|: an error, not a redesign


def as_built_values(spec: str) -> tuple[str, list[float]]:
    """(kind, its numbers) of an as-built spec, refused (:class:`ConfigError`) when they are no
    build error (``turned:1e308`` was a math domain error deep in shapely) before any design is seen."""
    kind, *args = spec.split(":")
    try:
        vals = [float(a) for a in args]
    except ValueError:
        raise ConfigError(f"as_built '{spec}': the values after '{kind}:' must be numbers") from None
    want = {"missing-sheet": 0, "corners": 2, "turned": 1, "offset": 2, "tooth-base": 1}
    if kind not in want:
        raise ConfigError(f"as_built '{spec}': choose missing-sheet, corners:ERR_M:DRAW, turned:DEG, offset:DX_M:DY_M "
                          "or tooth-base:DELTA_M")
    if len(vals) != want[kind] or not all(math.isfinite(v) for v in vals):
        raise ConfigError(f"as_built '{spec}': {kind} takes {want[kind]} finite number(s)")
    if kind == "corners" and not (0 < vals[0] < 1 and vals[1] >= 1 and vals[1] == int(vals[1])):
        raise ConfigError(f"as_built '{spec}': an error of 0-1 m and a draw number from 1")
    limit = AS_BUILT_LIMITS.get(kind)
    if limit is not None and any(abs(v) > limit for v in vals):
        unit = "deg" if kind == "turned" else "m"
        raise ConfigError(f"as_built '{spec}': {kind} by at most {limit:g} {unit} (a build error, not another design)")
    return kind, vals


def as_built(plane: GroundPlane, spec: str) -> tuple[GroundPlane, str]:
    """(the plane as built, what was done) for an as-built spec: ``missing-sheet``,
    ``corners:ERR_M:DRAW``, ``turned:DEG`` (the antenna turned: the plane turned the other way
    under it), ``offset:DX_M:DY_M`` (the antenna off centre: the plane moved under it) or
    ``tooth-base:DELTA_M`` (every tooth base, of families that have one, off by DELTA)."""
    from shapely import affinity

    kind, vals = as_built_values(spec)
    if kind == "missing-sheet":
        found = missing_sheet(plane)
        if found is None:
            raise NotApplicable(f"as_built 'missing-sheet': {plane.describe()} has no edge piece of at least half a "
                                "sheet")
        return found[1], found[0]
    if kind == "corners":
        err, draw = vals
        return moved_corners(plane, err, int(draw)), f"corners moved by up to +-{err * 100:g} cm (draw {int(draw)})"
    if kind == "turned":
        return _polygon(affinity.rotate(plane.outline(), -vals[0], origin=(0, 0))), f"antenna turned {vals[0]:+g} deg"
    if kind == "offset":
        dx, dy = vals
        return (_polygon(affinity.translate(plane.outline(), -dx, -dy)),
                f"antenna {dx * 100:+g} cm along x, {dy * 100:+g} cm along y off centre")
    d = to_dict(plane)
    keys = [k for k in ("tooth_base", "base_x", "base_y") if k in d]
    if not keys:
        raise NotApplicable(f"as_built '{spec}': a {d['shape']} has no tooth base")
    try:
        return from_dict({**d, **{k: d[k] + vals[0] for k in keys}}), f"tooth bases {vals[0]:+g} m"
    except ShapeError as exc:  # teeth that would overlap (bases filling the side already): not buildable so
        raise NotApplicable(f"as_built '{spec}': {exc}") from None


# ------------------------------------------------------------------ members
@dataclass(frozen=True)
class Member:
    """One scenario: a name, overrides of the soil and the engine's model (by option key:
    ``eps_r``, ``sigma``, ``feed_width``, ``plate_height``, ...), and an as-built spec."""

    name: str
    overrides: tuple[tuple[str, Any], ...] = ()
    as_built: str | None = None

    def __post_init__(self) -> None:
        if self.as_built is not None:  # its numbers refused when the set is read, not at the first design
            try:
                as_built_values(self.as_built)
            except ConfigError as exc:
                raise ConfigError(f"member '{self.name}': {exc}") from None

    @property
    def soil_only(self) -> bool:
        """Only the soil differs from the nominal model (the members the loss constraints read)."""
        return self.as_built is None and all(k in ("eps_r", "sigma") for k, _ in self.overrides)

    @property
    def axis(self) -> str:
        """Which uncertainty the member samples: nominal, soil, model or as built."""
        if self.as_built is not None:
            return "as built"
        keys = {k for k, _ in self.overrides}
        if not keys:
            return "nominal"
        return "soil" if keys <= {"eps_r", "sigma"} else "model"

    def settings(self, base: EvalSettings) -> EvalSettings:
        """``base`` with this member's overrides (refused by name when the engine has no such field)."""
        from groundplane.options import coerce, options

        soil, model = base.soil, base.model
        values = dict(self.overrides)
        if "eps_r" in values or "sigma" in values:
            soil_opts = {o.key: o for o in options(Soil)}
            given = {k: coerce(soil_opts[k], values.pop(k), f"scenario '{self.name}': ") for k in ("eps_r", "sigma")
                     if k in values}
            try:
                soil = replace(soil, **given)
            except SettingsError as exc:
                raise ConfigError(f"scenario '{self.name}': {exc}") from None
        opts = {o.key: o for o in options(type(model))}
        for key, value in values.items():
            if key not in opts:
                raise ConfigError(f"scenario '{self.name}': the {base.engine} engine's model has no '{key}' (it takes "
                                  f"{', '.join(sorted(opts))}, eps_r and sigma)")
            try:
                model = replace(model, **{opts[key].name: coerce(opts[key], value, f"scenario '{self.name}': ")})
            except SettingsError as exc:
                raise ConfigError(f"scenario '{self.name}': {exc}") from None
        return replace(base, soil=soil, model=model)

    def plane(self, plane: GroundPlane) -> tuple[GroundPlane, str | None]:
        """The plane this member solves (as built, with what was done), or the plane itself;
        :class:`NotApplicable` when the design has no part the variant changes."""
        if self.as_built is None:
            return plane, None
        return as_built(plane, self.as_built)

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, **dict(self.overrides), **({"as_built": self.as_built} if self.as_built else {})}


AGGREGATES = ("mean", "worst")


def aggregate(values: list[float], how: str) -> float:
    """mean, worst, or worst-K: the mean of the K worst (highest) FoMs."""
    v = sorted(values, reverse=True)
    if how == "mean":
        return float(np.mean(v))
    if how == "worst":
        return float(v[0])
    return float(np.mean(v[:worst_k(how)]))


def worst_k(how: str) -> int:
    """K of an aggregate ``worst-K`` (refused unless K is a whole number >= 1)."""
    try:
        k = int(how.split("-", 1)[1]) if how.startswith("worst-") else 0
    except ValueError:
        k = 0
    if k < 1:
        raise UserInputError(f"--aggregate {how}: choose mean, worst or worst-K (K a whole number >= 1)")
    return k


def check_aggregate(how: str, members: int) -> None:
    """Refuse an aggregate the set cannot take (worst-K of fewer than K members)."""
    if how in AGGREGATES:
        return
    k = worst_k(how)
    if k > members:
        raise UserInputError(f"--aggregate {how}: the set has {members} member(s)")


@dataclass(frozen=True)
class ScenarioSet:
    """A named list of members and how their FoMs make one (``aggregate``)."""

    name: str
    members: tuple[Member, ...]
    aggregate: str = "worst"

    def __post_init__(self) -> None:
        check_name(self.name, "a scenario set's name")
        if not self.members:
            raise ConfigError(f"scenario set '{self.name}' has no members")
        if len(self.members) > MAX_MEMBERS:  # 5000 ran until killed
            raise ConfigError(f"scenario set '{self.name}': {len(self.members):,} members, so every design is solved "
                              f"{len(self.members):,} times; at most {MAX_MEMBERS} (split the question into sets)")
        for m in self.members:
            check_name(m.name, f"scenario set '{self.name}': a member's name")
        names = [m.name for m in self.members]
        if len(set(names)) != len(names):
            raise ConfigError(f"scenario set '{self.name}': member names must be unique")
        check_aggregate(self.aggregate, len(self.members))

    def with_aggregate(self, how: str | None) -> "ScenarioSet":
        return self if how is None else replace(self, aggregate=how)

    def soil_members(self) -> list[Member]:
        """The members the loss constraints read: those that change only the soil (all members
        when none does)."""
        return [m for m in self.members if m.soil_only] or list(self.members)

    def identity(self) -> dict[str, Any]:
        """What a search's objective is (recorded with its history; a resume refuses another)."""
        return {"set": self.name, "aggregate": self.aggregate, "members": [m.as_dict() for m in self.members]}


def _soil_members() -> tuple[Member, ...]:
    corners = tuple(Member(f"eps_r {e:g}, sigma {s:g}", (("eps_r", e), ("sigma", s))) for e, s in SOIL_CORNERS)
    mro = Member(f"MRO (eps_r {paper.MRO_EPS_R:g}, sigma {paper.MRO_SIGMA_S_PER_M:g})",
                 (("eps_r", paper.MRO_EPS_R), ("sigma", paper.MRO_SIGMA_S_PER_M)))
    return corners + (mro,)


def _model_members() -> tuple[Member, ...]:
    mro = (("eps_r", paper.MRO_EPS_R), ("sigma", paper.MRO_SIGMA_S_PER_M))
    return tuple(Member(f"feed {w * 100:g} cm, plate {h * 1000:g} mm up", mro + (("feed_width", w), ("plate_height", h)))
                 for w in MODEL_FEED_WIDTHS_M for h in MODEL_PLATE_HEIGHTS_M)


def _as_built_members() -> tuple[Member, ...]:
    out = [Member(f"tooth bases {d:+g} m", (), f"tooth-base:{d:g}") for d in (-TOOTH_BASE_ERROR_M, TOOTH_BASE_ERROR_M)]
    out += [Member(f"corners +-{e * 100:g} cm", (), f"corners:{e:g}:1") for e in CORNER_ERRORS_M]
    out += [Member("a sheet missing", (), "missing-sheet")]
    out += [Member(f"antenna turned {t:+g} deg", (), f"turned:{t:g}") for t in (-TURN_DEG, TURN_DEG)]
    out += [Member(f"antenna {OFFSET_M * 100:g} cm off centre along {a}", (), f"offset:{dx:g}:{dy:g}")
            for a, dx, dy in (("x", OFFSET_M, 0.0), ("y", 0.0, OFFSET_M))]
    return tuple(out)


BUILT_IN: dict[str, Callable[[], ScenarioSet]] = {
    "nominal": lambda: ScenarioSet("nominal", (Member("nominal"),)),
    "soil": lambda: ScenarioSet("soil", _soil_members()),
    "model": lambda: ScenarioSet("model", _model_members()),
    "as-built": lambda: ScenarioSet("as-built", (Member("nominal"),) + _as_built_members()),
    "field": lambda: ScenarioSet("field", _soil_members() + _model_members() + _as_built_members()),
}


def scenario_set(spec: str, aggregate_how: str | None = None) -> ScenarioSet:
    """A built-in set by name, or a set from a TOML file; ``aggregate_how`` overrides its aggregate."""
    if spec in BUILT_IN:
        return BUILT_IN[spec]().with_aggregate(aggregate_how)
    if spec.endswith(".toml") or Path(spec).exists():
        return load_set(spec).with_aggregate(aggregate_how)
    raise UserInputError(f"--scenarios {spec}: choose one of {', '.join(BUILT_IN)} or give a TOML file")


MEMBER_KEYS_AS_BUILT = "as_built"


def load_set(path: str | Path) -> ScenarioSet:
    """A scenario set from a TOML file (see the module doc); every mistake one line naming the
    file and the member."""
    path = Path(path)
    try:
        doc = tomllib.loads(path.read_text())
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"{path}: {exc}") from None
    unknown = set(doc) - {"name", "aggregate", "member"}
    if unknown:
        raise ConfigError(f"{path}: unknown key(s) {sorted(unknown)}; expected name, aggregate, [[member]]")
    members_doc = doc.get("member", [])
    if not isinstance(members_doc, list) or not all(isinstance(m, dict) for m in members_doc):
        raise ConfigError(f"{path}: 'member' must be [[member]] tables")
    name, how = doc.get("name", path.stem), doc.get("aggregate", "worst")
    if not isinstance(name, str) or not isinstance(how, str):
        raise ConfigError(f"{path}: name and aggregate must be strings")
    members = []
    for i, m in enumerate(members_doc):
        where = f"{path}: [[member]] #{i + 1}"
        label = m.get("name", f"member {i + 1}")
        if not isinstance(label, str):
            raise ConfigError(f"{where}: name must be a string")
        built = m.get(MEMBER_KEYS_AS_BUILT)
        if built is not None and not isinstance(built, str):
            raise ConfigError(f"{where}: as_built must be a string")
        over = {k: v for k, v in m.items() if k not in ("name", MEMBER_KEYS_AS_BUILT)}
        for k, v in over.items():
            if isinstance(v, bool) or not isinstance(v, (int, float, str, list)):
                raise ConfigError(f"{where}: {k} = {v!r} is not a value a setting takes")
        members.append(Member(label, tuple(sorted(over.items())), built))
    try:
        return ScenarioSet(name, tuple(members), how)
    except UserInputError as exc:
        raise ConfigError(f"{path}: {exc}") from None


def check_not_overridden(scenarios: ScenarioSet, settings: EvalSettings) -> None:
    """Refuse a soil or model setting that differs from its default where members of the set
    override it: ``--eps-r 3 --scenarios soil`` scored no member at eps_r 3, and with ``field``
    only the as-built members, whose moves are then read against MRO soil they were not solved
    on. (A setting at its default cannot be told from one not given, and changes nothing.)"""
    from groundplane.options import options

    defaults = {o.key: (o.name, getattr(Soil(), o.name)) for o in options(Soil)}
    model_defaults = type(settings.model)()
    defaults.update({o.key: (o.name, getattr(model_defaults, o.name)) for o in options(type(settings.model))})
    for key, (name, default) in defaults.items():
        value = getattr(settings.soil if key in ("eps_r", "sigma") else settings.model, name)
        setting = [m.name for m in scenarios.members if key in dict(m.overrides)]
        if value == default or not setting:
            continue
        others = len(scenarios.members) - len(setting)
        reach = "none of them" if not others else f"only the other {others}"
        raise UserInputError(f"{key} = {value!r} (--{key.replace('_', '-')}): the scenario set '{scenarios.name}' sets "
                             f"{key} itself on {len(setting)} of its {len(scenarios.members)} member(s) "
                             f"({'; '.join(setting[:3])}{'; ...' if len(setting) > 3 else ''}), so the value "
                             f"given would reach {reach}. Leave it out, or use a set whose members do not set it "
                             f"(nominal, as-built, or a TOML file of members)")


def check_set(scenarios: ScenarioSet, settings: EvalSettings, plane: GroundPlane | None = None) -> None:
    """Refuse, before any solve, members the engine cannot take (an unknown model field, a bad
    value) or a plane they cannot build, and a soil or model setting given away from its default that
    members set themselves (it would reach only the others, or none: a silent wrong answer)."""
    check_not_overridden(scenarios, settings)
    skipped = []
    for m in scenarios.members:
        m.settings(settings)
        if plane is not None and m.as_built is not None:
            try:
                m.plane(plane)
            except NotApplicable:
                skipped.append(m.name)  # skipped, as the solve skips it (sawtooth-20-16's teeth fill its sides)
    problem = too_few_for_aggregate(scenarios, len(scenarios.members) - len(skipped), skipped)
    if problem:
        raise UserInputError(problem)


def too_few_for_aggregate(scenarios: ScenarioSet, scored: int, skipped: list[str]) -> str | None:
    """Why a design's scored members cannot make the set's worst-K (fewer than K once the
    as-built variants it has no part for are skipped), or None: a mean of fewer would be
    another aggregate than the one asked for, and rank designs unlike each other."""
    if scored == 0:  # every member an as-built variant of a part this design lacks: max() of nothing
        return (f"no member of the set '{scenarios.name}' applies to this design ({'; '.join(skipped)}): nothing to "
                "score it on")
    if scenarios.aggregate in AGGREGATES or worst_k(scenarios.aggregate) <= scored:
        return None
    return (f"--aggregate {scenarios.aggregate}: this design has {scored} member(s) of the set '{scenarios.name}' "
            f"to score ({len(skipped)} skipped: {'; '.join(skipped)}); choose K <= {scored}")


# ------------------------------------------------------------------ constraints
@dataclass(frozen=True)
class Constraints:
    """Beside the metal: the largest ground loss in the fit band on every soil member
    (``max_loss``, a fraction; None: none) and the spread of the loss across the soil members at
    any frequency (``max_loss_spread``)."""

    max_loss: float | None = DEFAULT_MAX_LOSS
    max_loss_spread: float | None = None

    def __post_init__(self) -> None:
        for name, v in (("--max-loss", self.max_loss), ("--max-loss-spread", self.max_loss_spread)):
            if v is not None and not (math.isfinite(v) and 0 < v < 1):
                raise UserInputError(f"{name} {v:g}: a fraction of the input power between 0 and 1 (0.005 is 0.5 %)")

    def identity(self) -> dict[str, Any]:
        return {"max_loss": self.max_loss, "max_loss_spread": self.max_loss_spread}

    def violations(self, max_loss: float | None, spread: float | None) -> list[str]:
        """What the numbers break, each with by how much (empty: feasible)."""
        out = []
        if self.max_loss is not None:
            if max_loss is None:
                out.append("ground loss unknown (a gain not normalised to input power)")
            elif max_loss > self.max_loss:
                out.append(f"ground loss {100 * max_loss:.3f} % > {100 * self.max_loss:.3f} % (by "
                           f"{100 * (max_loss - self.max_loss):.3f} points)")
        if self.max_loss_spread is not None and spread is not None and spread > self.max_loss_spread:
            out.append(f"loss spread across soils {100 * spread:.3f} % > {100 * self.max_loss_spread:.3f} % (by "
                       f"{100 * (spread - self.max_loss_spread):.3f} points)")
        return out

    def margin(self, max_loss: float | None, spread: float | None) -> list[float]:
        """Each constraint's value, <= 0 when met (nlopt's inequality constraints)."""
        out = []
        if self.max_loss is not None:
            out.append(0.0 if max_loss is None else (max_loss - self.max_loss) / self.max_loss)
        if self.max_loss_spread is not None:
            out.append(0.0 if spread is None else (spread - self.max_loss_spread) / self.max_loss_spread)
        return out


NO_CONSTRAINTS = Constraints(None, None)


def parse_loss(text: str) -> float | None:
    """--max-loss / --max-loss-spread value: a fraction (0.005), a percentage (0.5%), or none."""
    t = text.strip().lower()
    if t in ("none", "off", "no"):
        return None
    try:
        return float(t[:-1]) / 100 if t.endswith("%") else float(t)
    except ValueError:
        raise UserInputError(f"'{text}': a fraction (0.005), a percentage (0.5%) or none") from None


# ------------------------------------------------------------------ evaluation
Evaluate = Callable[[Candidate, EvalSettings], dict[str, Any]]


def member_jobs(candidate: Candidate, settings: EvalSettings, scenarios: ScenarioSet
                ) -> list[tuple[Member, EvalSettings, Candidate, str | None]]:
    """Each member's settings and candidate (the plane as built), refused by name before any solve."""
    jobs = []
    for m in scenarios.members:
        s = m.settings(settings)
        if candidate.plane is None and m.as_built is not None:
            raise UserInputError(f"scenario '{m.name}' builds the plane as built; '{candidate.name}' is a beam file")
        try:
            plane, note = m.plane(candidate.plane) if candidate.plane is not None else (None, None)
        except NotApplicable:
            continue  # the design has no such part: the member does not apply (listed as skipped in the row)
        c = Candidate(f"{candidate.name} [{m.name}]", plane=plane) if plane is not None else candidate
        jobs.append((m, s, c, note))
    return jobs


def _solve_members(jobs, progress: bool) -> dict[int, tuple[Any, float] | str]:
    """Each member's (beam, seconds), or its error: members of one model solved together."""
    import time

    from .evaluate import candidate_beam

    out: dict[int, tuple[Any, float] | str] = {}
    groups: dict[str, list[int]] = {}
    for i, (m, s, c, _) in enumerate(jobs):
        if c.plane is None:  # a beam file: loaded, not solved (one soil: its own)
            try:
                out[i] = candidate_beam(c, s)
            except Exception as exc:  # noqa: BLE001 - reported in the row
                out[i] = f"{type(exc).__name__}: {exc}"
            continue
        key = repr((s.engine, s.model.as_dict(), s.freqs_mhz, s.workers))
        groups.setdefault(key, []).append(i)
    for members in groups.values():
        s = jobs[members[0]][1]
        t0 = time.perf_counter()
        try:
            beams = s.make_solver(progress).solve_many([Design(jobs[i][2].plane, jobs[i][1].soil) for i in members],
                              s.freqs_mhz)
        except KeyboardInterrupt:
            raise
        except Exception as exc:  # noqa: BLE001 - reported in the row
            for i in members:
                out[i] = f"{type(exc).__name__}: {exc}"
            continue
        secs = (time.perf_counter() - t0) / len(members)
        for i, b in zip(members, beams):
            out[i] = (b, secs)
    return out


MEMBER_FIELDS = ("lst_averaged_fom_mk", "fom_mk", "lst_hours", "residuals_mk", "max_ground_loss", "ground_loss",
                 "freqs_mhz", "fit_freqs_mhz", "solve_s", "solver_cpu_s", "n_unknowns", "beam_cache_key")


def evaluate_scenarios(candidate: Candidate, settings: EvalSettings, scenarios: ScenarioSet,
                       constraints: Constraints = NO_CONSTRAINTS, progress: bool = False,
                       member_fn: Evaluate | None = None) -> dict[str, Any]:
    """Solve and score a candidate on every member of ``scenarios``: the set's aggregate as its
    FoM (``lst_averaged_fom_mk``), every member's FoM and loss, the constraints and whether it
    meets them. The members of one model are solved together (``solve_many``); with
    ``member_fn(candidate, settings) -> row`` each member is evaluated by it instead, one by one.
    A member that fails makes the row failed (naming it); nothing else is lost."""
    try:
        jobs = member_jobs(candidate, settings, scenarios)
        solved = _solve_members(jobs, progress) if member_fn is None else {}
    except KeyboardInterrupt:
        raise
    except Exception as exc:  # noqa: BLE001 - reported in the row, never swallowed silently
        return failed_row(candidate, f"{type(exc).__name__}: {exc}")
    members = []
    for i, (m, s, c, note) in enumerate(jobs):
        try:
            if member_fn is not None:
                row = member_fn(c, s)
            elif isinstance(solved[i], str):
                row = {"status": "failed", "error": solved[i]}
            else:
                row = score(c, *solved[i][:1], s, solved[i][1])  # type: ignore[misc]
        except KeyboardInterrupt:
            raise
        except Exception as exc:  # noqa: BLE001
            row = {"status": "failed", "error": f"{type(exc).__name__}: {exc}"}
        fom = row.get("lst_averaged_fom_mk")
        if row.get("status") != "ok" or fom is None or not math.isfinite(fom):
            return failed_row(candidate, f"on scenario '{m.name}': {row.get('error', 'no FoM')}")
        members.append({"member": m.name, "axis": m.axis, "soil_only": m.soil_only, "as_built": note,
                        "metal_area_m2": c.plane.metal_area if c.plane is not None else None,
                        **{k: row.get(k) for k in MEMBER_FIELDS}})
    skipped = [m.name for m in scenarios.members if m.name not in {r["member"] for r in members}]
    problem = too_few_for_aggregate(scenarios, len(members), skipped)
    if problem:
        return failed_row(candidate, problem)
    row = scenario_row(candidate, scenarios, constraints, members, settings)
    return {**row, **({"skipped_members": skipped} if skipped else {})}


def scenario_row(candidate: Candidate, scenarios: ScenarioSet, constraints: Constraints, members: list[dict],
                 settings: EvalSettings) -> dict[str, Any]:
    """The candidate's row from its members' rows: aggregate, loss, spread, feasibility."""
    foms = [r["lst_averaged_fom_mk"] for r in members]
    soil = [r for r in members if r["soil_only"]] or members
    losses = [r["max_ground_loss"] for r in soil]
    max_loss = None if any(v is None for v in losses) else float(max(losses))
    spread = None
    if len(soil) > 1 and all(r["ground_loss"] is not None and r["freqs_mhz"] is not None for r in soil):
        from groundplane.loss import spread_across

        band = settings.fom.fit_band_mhz
        f = np.asarray(soil[0]["freqs_mhz"])
        inside = (f >= band[0] - 1e-9) & (f <= band[1] + 1e-9)
        spread = float(spread_across([np.asarray(r["ground_loss"])[inside] for r in soil]).max())
    broken = constraints.violations(max_loss, spread)
    nominal = next((r for r in members if r["axis"] in ("nominal",)), None)
    worst = max(members, key=lambda r: r["lst_averaged_fom_mk"])  # its curves stand for the row in figures
    return {**row_head(candidate, "ok"), "lst_averaged_fom_mk": aggregate(foms, scenarios.aggregate),
            "fom_mk": worst.get("fom_mk"), "lst_hours": worst.get("lst_hours"), "residuals_mk": worst.get("residuals_mk"),
            "curves_of": worst["member"],
            "aggregate": scenarios.aggregate, "scenario_set": scenarios.name,
            "mean_fom_mk": float(np.mean(foms)), "worst_fom_mk": float(np.max(foms)),
            "nominal_fom_mk": nominal["lst_averaged_fom_mk"] if nominal else None,
            "per_member_mk": foms, "max_loss": max_loss, "loss_spread": spread,
            "feasible": not broken, "violations": broken, "constraints": constraints.identity(),
            "members": members, "fit_freqs_mhz": members[0].get("fit_freqs_mhz"),
            "solve_s": round(float(sum(r.get("solve_s") or 0 for r in members)), 2),
            "solver_cpu_s": round(float(sum(r.get("solver_cpu_s") or 0 for r in members)), 2)}


def scenario_evaluator(scenarios: ScenarioSet, constraints: Constraints, progress: bool = False,
                       member_fn: Evaluate | None = None) -> Evaluate:
    """``evaluate_fn(candidate, settings)`` for searches and sweeps: :func:`evaluate_scenarios`."""
    def ev(candidate: Candidate, settings: EvalSettings) -> dict[str, Any]:
        return evaluate_scenarios(candidate, settings, scenarios, constraints, progress, member_fn)
    return ev


def soil_set(soils: tuple[Soil, ...], how: str = "worst", name: str = "soil grid") -> ScenarioSet:
    """A set of soil members (eps_r, sigma of each)."""
    return ScenarioSet(name, tuple(Member(f"eps_r {s.eps_r:g}, sigma {s.sigma:g}", (("eps_r", s.eps_r),
                                                                                   ("sigma", s.sigma))) for s in soils),
                       how)


# ------------------------------------------------------------------ sensitivity
@dataclass
class Sensitivity:
    """Per axis (soil, model, as built): the member that moves the FoM most from the nominal
    member's, and whether that makes the design fragile (more than ``FRAGILE``)."""

    nominal_mk: float
    nominal_name: str = "the nominal member"
    rows: list[dict[str, Any]] = field(default_factory=list)

    def verdicts(self) -> list[str]:
        """One computed sentence per axis."""
        out = []
        for r in self.rows:
            head = (f"- {r['axis']}: the largest move is {r['member']} ({r['fom_mk']:.1f} mK, "
                    f"{100 * r['change']:+.1f} % from {self.nominal_mk:.1f})")
            out.append(head + (f": **fragile** (more than {100 * FRAGILE:.0f} %)." if r["fragile"]
                               else f": within {100 * FRAGILE:.0f} %, not fragile on this axis."))
        return out

    def table(self) -> list[str]:
        """Markdown: one row per axis, its largest move and the computed verdict."""
        lines = [f"Sensitivity to each axis, against {self.nominal_name} ({self.nominal_mk:.1f} mK); fragile where one "
                 f"member moves the FoM by more than {100 * FRAGILE:.0f} %:", "",
                 "| axis | members | largest move (member) | its FoM (mK) | change | verdict |", "|---|---|---|---|---|---|"]
        lines += [f"| {r['axis']} | {r['members']} | {r['member']} | {r['fom_mk']:.1f} | {100 * r['change']:+.1f} % | "
                  f"{'**fragile**' if r['fragile'] else 'not fragile'} |" for r in self.rows]
        return lines


def sensitivity(row: dict[str, Any], nominal_mk: float | None = None) -> Sensitivity | None:
    """:class:`Sensitivity` of a scenario row against ``nominal_mk``, by default the row's nominal
    member, else its MRO member (the default soil); None when it has neither."""
    name = "the nominal member"
    if nominal_mk is None:
        mro = next((m for m in row.get("members", []) if m["member"].startswith("MRO")), None)
        nominal_mk = row.get("nominal_fom_mk") or (mro["lst_averaged_fom_mk"] if mro else None)
        name = "the nominal member" if row.get("nominal_fom_mk") else "the MRO soil member"
    if not nominal_mk:
        return None
    out = Sensitivity(nominal_mk, name)
    for axis in ("soil", "model", "as built"):
        ms = [m for m in row["members"] if m["axis"] == axis]
        if ms:
            worst = max(ms, key=lambda m: abs(m["lst_averaged_fom_mk"] / nominal_mk - 1))
            change = worst["lst_averaged_fom_mk"] / nominal_mk - 1
            out.rows.append({"axis": axis, "member": worst["member"], "fom_mk": worst["lst_averaged_fom_mk"],
                             "change": change, "fragile": abs(change) > FRAGILE, "members": len(ms)})
    return out


def member_table(row: dict[str, Any]) -> list[str]:
    """Markdown: every member's FoM and ground loss (a report's table)."""
    lines = ["| member | axis | FoM (mK) | largest ground loss in the fit band (%) | metal (m^2) |", "|---|---|---|---|---|"]
    for m in row.get("members", []):
        loss = m.get("max_ground_loss")
        lines.append(f"| {m['member']}{(' (' + m['as_built'] + ')') if m.get('as_built') else ''} | {m['axis']} | "
                     f"{m['lst_averaged_fom_mk']:.1f} | {'-' if loss is None else f'{100 * loss:.3f}'} | "
                     f"{'-' if m.get('metal_area_m2') is None else format(m['metal_area_m2'], '.1f')} |")
    return lines


def describe_set(scenarios: ScenarioSet, constraints: Constraints) -> str:
    """One line for reports: the set, its aggregate, its members, the constraints."""
    cons = []
    if constraints.max_loss is not None:
        cons.append(f"ground loss <= {100 * constraints.max_loss:g} % in the fit band on every soil member")
    if constraints.max_loss_spread is not None:
        cons.append(f"loss spread across the soil members <= {100 * constraints.max_loss_spread:g} %")
    return (f"scenario set `{scenarios.name}` ({len(scenarios.members)} member(s): "
            f"{'; '.join(m.name for m in scenarios.members)}), aggregate {scenarios.aggregate}; constraints: "
            f"{', '.join(cons) or 'none'}")


# ------------------------------------------------------------------ options
from groundplane.options import option  # noqa: E402 - the options live beside what they configure


@dataclass(frozen=True)
class ScenarioOptions:
    """What a design is scored on and held to, as command-line options and a sweep's
    ``[scenarios]`` table: the scenario set, its aggregate, the loss constraints."""

    scenarios: str = option("soil", "the uncertainty each design is scored on (a name, or a TOML file of members): nominal (the settings as given), "
                            "soil (the paper's section-5 corners and MRO), model (feed 4 / 125.2 cm x plate 2.5 / "
                            "10 mm), as-built, field (all of them)", metavar="SET")
    aggregate: str = option("", "how the members' FoMs make one: mean, worst, or worst-K (the mean of the worst K) "
                            "(default: the set's own, worst for the built-in sets)", metavar="HOW")
    max_loss: float | None = option(DEFAULT_MAX_LOSS, "the largest ground loss in the fit band on every soil member, a "
                                    "fraction (0.005) or a percentage (0.5%); none: no limit", parse=parse_loss,
                                    metavar="L")
    max_loss_spread: float | None = option(None, "the largest spread of the loss across the soil members at any "
                                           "frequency (the calibration risk); none: no limit", parse=parse_loss,
                                           metavar="D")

    def __post_init__(self) -> None:
        try:
            self.constraints()
        except UserInputError as exc:
            raise SettingsError(str(exc)) from None

    def set(self) -> ScenarioSet:
        return scenario_set(self.scenarios, self.aggregate or None)

    def constraints(self) -> Constraints:
        return Constraints(self.max_loss, self.max_loss_spread)


PAPER_OBJECTIVE = ScenarioOptions("nominal", "", None, None)
"""The paper's objective: the FoM at the nominal soil and model, no loss limit (``results/pareto``)."""
