"""nlopt search of a ground-plane family under a metal-area budget.

The continuous parameters are optimised with a derivative-free nlopt algorithm that takes
inequality constraints (metal area <= A, and the family's validity, e.g. teeth that fit);
integer parameters (teeth per side, polygon sides, star points) are enumerated, one nlopt
run each. Bounds are always set. Every evaluation is appended to ``history.jsonl`` as it
completes; a rerun replays the history (nlopt is deterministic given the same answers),
so an interrupted optimisation resumes without solving anything twice. A failed or
non-finite evaluation returns a finite penalty: nlopt's COBYLA can hang on NaN.
"""
from __future__ import annotations

import hashlib
import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable

import numpy as np

from groundplane.errors import ShapeError, UserInputError
from groundplane.files import append_jsonl, atomic_path, one_writer, read_jsonl
from groundplane.shapes import SHAPES, GroundPlane

from .evaluate import Candidate, EvalSettings, evaluate

if TYPE_CHECKING:
    from .scenarios import Constraints, ScenarioSet

CONSTRAINED_ALGORITHMS = ("LN_COBYLA", "GN_ISRES", "GN_ORIG_DIRECT", "GN_ORIG_DIRECT_L")


@dataclass(frozen=True)
class Family:
    """A shape family as the optimiser sees it, read from the family's own declaration:
    the continuous parameters with bounds are searched, one integer parameter with listed
    values is enumerated, everything else keeps its default."""

    cls: type[GroundPlane]
    names: tuple[str, ...]  # continuous parameters, in x order
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    integer: str | None  # name of the enumerated integer parameter
    integer_values: tuple[int, ...]

    def params(self, x, n: int | None) -> dict[str, Any]:
        p: dict[str, Any] = dict(zip(self.names, map(float, x)))
        if self.integer:
            p[self.integer] = int(n)  # type: ignore[arg-type]
        return p

    def build(self, x, n: int | None) -> GroundPlane:
        return self.cls(**self.params(x, n))

    def area(self, x, n: int | None) -> float:
        """Closed-form metal area, defined for invalid x too (the constraint needs it there)."""
        return float(self.cls.area_of(self.params(x, n)))

    def validity(self, x, n: int | None) -> list[float]:
        """Each <= 0 when valid."""
        return [v for v, _ in self.cls.constraints(self.params(x, n))]

    def sample(self, u: np.ndarray, n: int | None) -> np.ndarray:
        """The family's own map of unit-cube coordinates ``u`` onto its (valid) parameters."""
        p = self.cls.sample(dict(zip(self.names, map(float, u))), {self.integer: n} if self.integer else {})
        return np.array([p[k] for k in self.names])

    def start(self, max_area: float, n: int | None) -> np.ndarray:
        """A valid x with metal area below the budget."""
        x = self.cls.optimiser_start(max_area, {self.integer: n} if self.integer else {})
        return np.array([x[k] for k in self.names])


def family(kind: str) -> Family:
    """The optimiser's view of a registered shape family."""
    if kind not in SHAPES:
        raise UserInputError(f"unknown shape family '{kind}'; choose one of {', '.join(optimisable())}")
    cls = SHAPES[kind]
    cont = [p for p in cls.parameters() if p.optimise and p.bounds is not None]
    ints = [p for p in cls.parameters() if p.optimise and p.values]
    if not cont or cls.area_of({**{p.name: p.bounds[0] for p in cont}, **{p.name: p.values[0] for p in ints}}) is None:
        raise UserInputError(f"shape family '{kind}' declares no bounded parameters with a closed-form area; it "
                             f"cannot be optimised (choose one of {', '.join(optimisable())})")
    if len(ints) > 1:
        raise UserInputError(f"shape family '{kind}': the optimiser enumerates one integer parameter, "
                             f"found {[p.name for p in ints]}")
    return Family(cls, tuple(p.name for p in cont), tuple(p.bounds[0] for p in cont),  # type: ignore[index]
                  tuple(p.bounds[1] for p in cont), ints[0].name if ints else None,  # type: ignore[index]
                  tuple(ints[0].values) if ints else ())


def optimisable() -> list[str]:
    """Shape families the optimiser can search (bounded parameters and a closed-form area)."""
    out = []
    for kind, cls in SHAPES.items():
        cont = [p for p in cls.parameters() if p.optimise and p.bounds is not None]
        ints = [p for p in cls.parameters() if p.optimise and p.values]
        if cont and len(ints) <= 1:
            out.append(kind)
    return out


class History:
    """Every evaluation, appended as it completes (fsync'd), keyed by (integer, x)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        rows = read_jsonl(path)  # a torn last line is evaluated again
        self.rows: list[dict[str, Any]] = [r for r in rows if self.whole(r)]
        if len(self.rows) < len(rows):
            from groundplane.files import warn_once

            warn_once(str(path), f"{path}: {len(rows) - len(self.rows)} line(s) are not history rows and are ignored "
                                 "(their designs are evaluated again)")
        self.index = {self.key(r["integer"], r["x"]): r for r in self.rows}
        self.outlines: dict[str, dict[str, Any]] = {}  # outline_key -> the first scored row of that metal
        for r in self.rows:
            if r["status"] in ("ok", "failed") and r.get("outline") and r["outline"] not in self.outlines:
                self.outlines[r["outline"]] = r

    @staticmethod
    def whole(r: dict[str, Any]) -> bool:
        """A row this search wrote: a list of numbers x, an integer or null, a status, a number objective."""
        def number(v: Any) -> bool:
            return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
        return (isinstance(r.get("x"), list) and all(number(v) for v in r["x"])
                and (r.get("integer") is None or isinstance(r.get("integer"), int))
                and isinstance(r.get("status"), str) and number(r.get("objective"))
                and (r["status"] != "ok" or number(r.get("fom_mk"))) and number(r.get("area_m2")))

    @staticmethod
    def key(n: int | None, x) -> tuple:
        return (n, tuple(round(float(v), 9) for v in x))

    def get(self, n: int | None, x) -> dict[str, Any] | None:
        return self.index.get(self.key(n, x))

    def add(self, row: dict[str, Any]) -> None:
        self.rows.append(row)
        self.index[self.key(row["integer"], row["x"])] = row
        if row["status"] in ("ok", "failed") and row.get("outline"):
            self.outlines.setdefault(row["outline"], row)
        append_jsonl(self.path, row)

    def same_metal(self, outline: str) -> dict[str, Any] | None:
        """The scored row of this outline (another x of the same plane: parameters that change
        nothing, such as the base of teeth of height 0), or None."""
        return self.outlines.get(outline)


@dataclass
class OptimiseResult:
    """The best history row (None if nothing feasible was scored), every row, and where
    they are; ``confirmed``: the best few re-solved at the finer confirmation mesh (the
    answer is then the best there, and says so in ``best["confirmed_at"]``)."""

    best: dict[str, Any] | None
    history: list[dict[str, Any]]
    out_dir: Path
    confirmed: list[dict[str, Any]] = field(default_factory=list)
    closest: dict[str, Any] | None = None  # with no feasible design: the one that broke the constraints least
    stopping: dict[str, Any] = field(default_factory=dict)  # solves, where the best was found, flat over the last half
    counted: list[dict[str, Any]] | None = None  # the solved rows the stopping rule read, in its order

    def solved(self) -> list[dict[str, Any]]:
        """The solves this search counted (what its stopping rule and convergence curve read): a
        history may hold more, from a run with a larger budget or another path before a rule changed."""
        return self.counted if self.counted is not None else solved_rows(self.history)


def smallest_feature(plane: GroundPlane) -> tuple[float, float]:
    """(shortest outline edge, narrowest spike) in m: a gap between teeth, and the base of
    the narrowest tooth -- the span between the neighbours of a convex vertex sharper
    than 90 deg (inf when there is none)."""
    from shapely.geometry.polygon import orient

    v = np.asarray(orient(plane.outline()).exterior.coords)[:-1]  # counter-clockwise
    prev, nxt = np.roll(v, 1, axis=0), np.roll(v, -1, axis=0)
    a, b = v - prev, nxt - v
    convex = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] > 1e-12
    sharp = np.einsum("ij,ij->i", -a, b) > 1e-12  # interior angle under 90 deg
    edges = np.hypot(*b.T)
    spans = np.hypot(*(nxt - prev).T)[convex & sharp]
    return float(edges.min()), float(spans.min()) if spans.size else math.inf


MAX_THIN_FRACTION = 0.10  # of the metal narrower than two cells: every Table 3 preset has 0 % at a 1 m mesh (a
# tooth grows back whole from its eroded core), a cross of 1.1 m wide arms on a 1 m mesh 46 % (the search's
# first pareto run had found it at 70 mK on that mesh: an artefact of one triangle across an arm)


def thin_fraction(plane: GroundPlane, spacing: float) -> float:
    """The share of the metal area narrower than two cells: what a morphological opening of
    radius one cell (erode, then grow back with mitred corners, clipped to the plate) removes."""
    outline = plane.outline()
    kept = outline.buffer(-spacing).buffer(spacing, join_style="mitre").intersection(outline)
    return float(1.0 - kept.area / outline.area)


MAX_STRANDED_CELLS = 1.0  # metal may lie at most this many cells from metal two cells wide: every Table 3 preset
# is within 0.12 cells at 0.5-1 m; the robust front's 400 m^2 answer of 2026-12-02 had 10.7 m spikes on 4.7 cm necks (15
# cells at 0.7 m), and a search candidate a 1.4 mm neck that the surface mesher filled with 60 608 triangles


def stranded_metal(plane: GroundPlane, spacing: float) -> tuple[float, tuple[float, float]]:
    """How far (m) the metal reaches from the metal at least two cells wide, and the farthest
    point: a long strip or a neck narrower than two cells holds little area (the thin share
    misses it) but reaches far."""
    import shapely

    outline = plane.outline()
    kept = outline.buffer(-spacing).buffer(spacing, join_style="mitre").intersection(outline)
    thin = outline.difference(kept)
    if thin.is_empty or kept.is_empty:
        return (0.0, (0.0, 0.0)) if thin.is_empty else (math.inf, (0.0, 0.0))
    points = shapely.points(shapely.get_coordinates(shapely.segmentize(thin, spacing / 4)))
    far = shapely.distance(kept, points)
    i = int(np.argmax(far))
    return float(far[i]), (float(points[i].x), float(points[i].y))


def too_fine_for(plane: GroundPlane, spacing: float) -> str | None:
    """Why a mesh at ``spacing`` cannot represent ``plane`` on any engine (None if it can):
    metal narrower than two cells has at most one grid line (or triangle) across it. An
    engine's own limits (a wire grid moving short outline edges) are its ``why_unresolved``."""
    edge, span = smallest_feature(plane)
    if span < 2 * spacing:
        return f"a {span:.2f} m wide feature is under two mesh cells ({2 * spacing:g} m)"
    thin = thin_fraction(plane, spacing)
    if thin > MAX_THIN_FRACTION:  # strips (long thin teeth) have no sharp vertex for the rule above
        return (f"{100 * thin:.0f} % of the metal is narrower than two mesh cells ({2 * spacing:g} m; at most "
                f"{100 * MAX_THIN_FRACTION:.0f} %)")
    reach, (x, y) = stranded_metal(plane, spacing)
    if reach > MAX_STRANDED_CELLS * spacing:  # a neck or strip: a wire the mesh (and a 5 cm welded mesh) cannot make
        return (f"metal narrower than two mesh cells ({2 * spacing:g} m) reaches {reach:.2f} m from the wider metal "
                f"(to ({x:.2f}, {y:.2f}) m; at most {MAX_STRANDED_CELLS:g} cell)")
    return None


def same_search(out: Path, ident: dict[str, Any]) -> None:
    """Refuse to resume into ``out`` a search with other settings: its history's FoMs, keyed
    by design only, would be replayed as if solved with these (search.json records them; a
    history without one cannot say what it was solved with, so it is refused too)."""
    path = out / "search.json"
    ident = json.loads(json.dumps(ident))  # tuples as lists, as they read back
    if not path.exists() and (out / "history.jsonl").exists():
        raise UserInputError(f"{out} holds a search history without its settings (search.json): its FoMs cannot "
                             "be replayed safely. Use another -o.")
    if path.exists():
        try:
            old = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise UserInputError(f"{path}: unreadable ({exc}); remove it only if {out} holds this search") from None
        if "model" not in old and "model" in ident and {**old, "model": ident["model"]} == ident:
            # written before search.json recorded the model: take today's, and say so (its rows cannot tell)
            print(f"{path}: no model version recorded; recorded now as {ident['model']['engine']} model "
                  f"v{ident['model']['version']} (today's): rows solved by an older model cannot be told apart",
                  file=sys.stderr)
            old = ident
            with atomic_path(path, suffix=".tmp.json") as tmp:
                tmp.write_text(json.dumps(ident, indent=1) + "\n")
        if old != ident:
            diff = _differences(old, ident)
            raise UserInputError(f"{out} holds a search with other settings ({'; '.join(diff)}): its FoMs would be "
                                 "replayed as if solved with these. Use another -o, or the same settings to resume.")
        return
    with atomic_path(path, suffix=".tmp.json") as tmp:
        tmp.write_text(json.dumps(ident, indent=1) + "\n")


def _differences(old: Any, new: Any, where: str = "") -> list[str]:
    """Where two JSON values differ, as 'key: old -> new' (dicts compared key by key)."""
    if isinstance(old, dict) and isinstance(new, dict):
        return [d for k in sorted(set(old) | set(new))
                for d in _differences(old.get(k), new.get(k), f"{where}.{k}" if where else k)]
    return [] if old == new else [f"{where}: {json.dumps(old)[:60]} -> {json.dumps(new)[:60]}"]


def _confirm(ev: "_Evaluator", fine: EvalSettings, out: Path, top: int, progress: bool,
             picked: list[dict[str, Any]] | None = None) -> list[dict[str, Any]]:
    """Re-solve the ``top`` best distinct designs of the search (or the ``picked`` rows) with
    ``fine`` (a finer mesh, or the default model; resumable: confirm.jsonl, keyed by those
    settings), so the answer is one that holds beyond the level the search used."""
    level = hashlib.sha256(json.dumps(fine.identity(), sort_keys=True).encode()).hexdigest()[:16]
    done = {History.key(r["integer"], r["x"]): r for r in read_jsonl(out / "confirm.jsonl")
            if r.get("confirm_level") == level}  # a rerun at another level re-solves
    # distinct planes: rows of one outline under other parameters (solved before a search knew them for one) once
    ranked = sorted((r for r in ev.counted if r["status"] == "ok" and r.get("feasible", True)
                     and r["area_m2"] <= ev.max_area * (1 + 1e-9)), key=lambda r: r["fom_mk"])
    if picked is None:
        picked = list({row_plane(ev.fam, r).outline_key(): r for r in reversed(ranked)}.values())[::-1][:top]
    rows = []
    for i, r in enumerate(picked, 1):
        k = History.key(r["integer"], r["x"])
        if k not in done:
            if progress:
                print(f"  confirm {i}/{len(picked)} at {fine.spacing:g} m: {r.get('name')} "
                      f"({r['fom_mk']:.1f} mK at the search level)", file=sys.stderr, flush=True)
            res = ev.evaluate_fn(Candidate(f"{ev.shape}-confirm-{i}", plane=row_plane(ev.fam, r)), fine)
            fom = res.get("lst_averaged_fom_mk") if res.get("status") == "ok" else None
            loss = res.get("max_loss", res.get("max_ground_loss"))
            kept = {key: res[key] for key in SCENARIO_FIELDS if key in res}
            broken = ev.constraints.violations(loss, res.get("loss_spread")) if ev.constraints is not None else []
            done[k] = {**r, **kept, "search_fom_mk": r["fom_mk"], "search_max_loss": r.get("max_loss"), "fom_mk": fom,
                       "max_loss": loss, "feasible": not broken, "violations": broken, "confirmed_at": fine.spacing,
                       "confirm_level": level, "status": "ok" if fom is not None else "failed"}
            append_jsonl(out / "confirm.jsonl", done[k])
        rows.append(done[k])
    return rows


STRATEGIES = ("global", "local")
EXPLORE_FRACTION = 0.6  # of the solves: the space-filling exploration (with the seeds); the rest refines
EXPLORE_MIN_FILL = 0.5  # exploration samples designs using at least half the metal budget
REFINE_STARTS = 3  # local refinements, from the best distinct designs found so far


def optimise(
    shape: str, max_area: float, settings: EvalSettings, out_dir: str | Path, *,
    algorithm: str = "LN_COBYLA", budget: int = 30, integer_values: tuple[int, ...] | None = None,
    evaluate_fn: Callable[[Candidate, EvalSettings], dict[str, Any]] | None = None,
    progress: bool = True,
    confirm_mesh: float | None = None,
    confirm_top: int = 3,
    confirm_settings: EvalSettings | None = None,
    strategy: str = "global",
    executor: str = "local",
    scheduler: str | None = None,
    objective: dict[str, Any] | None = None,
    seeds: dict[str, GroundPlane] | None = None,
    scenarios: "ScenarioSet | None" = None,
    constraints: "Constraints | None" = None,
    max_budget: int | None = None,
    explore: int | None = None,
    build_tolerance: float | None = None,
) -> OptimiseResult:
    """Minimise the LST-averaged FoM of ``shape`` with metal area <= ``max_area`` (m^2), in at
    most ``budget`` solves (designs that are invalid or over the budget cost none).

    ``strategy`` "global": the family's presets that fit the budget (the paper's designs are always
    scored) and a scrambled-Sobol sample of the family take ``explore`` solves (default EXPLORE_FRACTION;
    as many as the ``seeds``: refine another search's best designs at a finer level without exploring
    again); ``algorithm`` then refines the best REFINE_STARTS distinct designs with the rest. "local":
    ``algorithm`` from the family's start point, one run per integer value, the solves shared. With
    ``executor`` "dask" the exploration's designs are solved in parallel on the cluster first. The best
    ``confirm_top`` are re-solved at ``confirm_mesh`` (or with ``confirm_settings``) and the answer is
    the best there. ``objective`` names what ``evaluate_fn`` returns when it is not the plain FoM (e.g.
    the mean over soils), so a resume refuses another one. ``seeds``: more named designs the global
    search scores first (before the presets). ``scenarios``: each design is scored on every member of
    the set (its aggregate the objective) unless ``evaluate_fn`` is given; ``constraints`` (ground
    loss, its spread) make a design that breaks them infeasible: never the answer, and a constraint
    of the local refinement. Past ``budget`` solves it refines from its best until the best so far lies
    in the first half of the solves or ``max_budget`` is spent (``stopping`` says which). With
    ``build_tolerance`` a design within it (of each parameter's range) of a solved one is that one
    (:meth:`_Evaluator._built_alike`). Raises UserInputError for a request that cannot work."""
    from .scenarios import NO_CONSTRAINTS

    fam, rules = family(shape), {"explore": explore, "build_tolerance": build_tolerance}
    ints = integer_choices(fam, integer_values)
    _check_request(max_area, algorithm, budget, strategy, fam, ints, seeds, **rules)
    settings.check_scorable()
    constraints = constraints or NO_CONSTRAINTS
    with one_writer(out_dir):  # a second search into the folder is refused, not interleaved with this one
        out = _open_search(out_dir, shape, max_area, settings, strategy, executor,
                           _objective(objective, scenarios, constraints), scenarios, rules)
        ev = _Evaluator(fam, shape, max_area, settings, History(out / "history.jsonl"),
                        evaluate_fn or _default_evaluate(scenarios, constraints, progress), progress, budget=budget,
                        constraints=constraints, build_tolerance=build_tolerance)
        ev.resumed()
        if strategy == "global":
            _global_search(fam, ints, ev, algorithm, out, executor, scheduler, seeds, explore)
        else:
            _local_search(fam, ints, ev, algorithm)
        stopping = _until_flat(fam, ints, ev, algorithm, max(budget, max_budget or budget))
        fine = (confirm_settings or settings.with_spacing(confirm_mesh)) if (confirm_mesh or confirm_settings) else None
        best, confirmed, closest = _answer(ev, fine, out, confirm_top, progress)
        return OptimiseResult(best, ev.hist.rows, out, confirmed, closest, stopping, list(ev.counted))


def _check_explore(explore: int | None, budget: int, strategy: str) -> None:
    """Refuse global-stage solves (``explore``; None: the default share of the budget) that no
    search could spend as asked."""
    if explore is not None and strategy != "global":
        raise UserInputError("--explore needs --strategy global (the local search does not explore)")
    if explore is not None and not 1 <= explore <= budget:
        raise UserInputError(f"--explore {explore}: the global stage's solves must lie between 1 and --budget ({budget})")


def _open_search(out_dir: str | Path, shape: str, max_area: float, settings: EvalSettings, strategy: str,
                 executor: str, objective: dict[str, Any] | None, scenarios, rules: dict | None = None) -> Path:
    """The search's folder, refused when it holds another search (a resume must ask the same)."""
    if scenarios is not None and scenarios.name != "nominal" and executor != "local":
        raise UserInputError("--executor dask presolves one beam per design; a search over a scenario set runs "
                             "locally (its members of one model are solved together)")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    # another explore share or build tolerance takes another path: part of the search, as asked
    extra = {**({"strategy": strategy} if strategy != "local" else {}), **({"objective": objective} if objective else {}),
             **{k: v for k, v in (rules or {}).items() if v is not None}}
    same_search(out, {"shape": shape, "max_area": max_area, "settings": settings.identity(), **extra,
                      "model": engine_model(settings)})
    return out


def engine_model(settings: EvalSettings) -> dict[str, Any] | None:
    """The engine and its model version a search's FoMs come from: a resume under another model
    version would replay the old model's FoMs beside the new one's (the beam cache keys carry it;
    a history's rows do not)."""
    from solvers.engines import ENGINES

    engine = settings.identity().get("engine")
    return {"engine": engine, "version": int(ENGINES[engine].model_version)} if engine in ENGINES else None


def _answer(ev: "_Evaluator", fine: EvalSettings | None, out: Path, confirm_top: int, progress: bool
            ) -> tuple[dict[str, Any] | None, list[dict[str, Any]], dict[str, Any] | None]:
    """The best feasible design (the best of the top ``confirm_top`` re-solved with ``fine``,
    when given), written to ``best.json``; those confirmations; and with none feasible the
    closest design, re-solved with ``fine`` too (its FoM then reads on the frequencies and mesh
    of the presets and answers beside it, not the search level's)."""
    best, closest = ev.best(), None
    confirmed: list[dict[str, Any]] = []
    if best is not None and fine is not None:
        confirmed = _confirm(ev, fine, out, confirm_top, progress)
        held = [r for r in confirmed if r["status"] == "ok" and r.get("feasible", True)]
        if held:
            best = min(held, key=lambda r: r["fom_mk"])
    elif best is None and (closest := ev.closest()) is not None and fine is not None:
        confirmed = _confirm(ev, fine, out, 1, progress, picked=[closest])
        closest = confirmed[0] if confirmed[0]["status"] == "ok" else closest
    with atomic_path(out / "best.json", suffix=".tmp.json") as tmp:
        tmp.write_text(json.dumps(best, indent=1))
    return best, confirmed, closest


def _objective(objective: dict[str, Any] | None, scenarios, constraints) -> dict[str, Any] | None:
    """What the search minimises and under which constraints, as recorded in search.json."""
    from .scenarios import NO_CONSTRAINTS

    if scenarios is not None:
        objective = {**(objective or {}), "scenarios": scenarios.identity()}
    if constraints != NO_CONSTRAINTS:
        objective = {**(objective or {}), "constraints": constraints.identity()}
    return objective


def _default_evaluate(scenarios, constraints, progress: bool) -> Callable[[Candidate, EvalSettings], dict[str, Any]]:
    """The scenario set's evaluation, or one solve at the settings as given."""
    from .scenarios import scenario_evaluator

    if scenarios is not None:
        return scenario_evaluator(scenarios, constraints, progress)
    return lambda c, s: evaluate(c, s, progress=progress)


FLAT_TOLERANCE = 0.01  # improvements smaller than this (relative) are not progress, however quiet the objective
# The objective's own scatter: two solved designs whose every parameter lies within SCATTER_STEP of its range of
# the other's (2.6 cm on teeth-xy's side) are one plane to a crew, so their FoMs differ by the search level's
# remeshing alone. Measured by this rule on the 600 m^2 robust search (2026-12-03, 170 solves): median 2.3 % over
# 76 pairs, above FLAT_TOLERANCE, so a local search kept "improving" within it; the tolerance is the larger of the two.
SCATTER_STEP = 1e-3
SCATTER_MIN_PAIRS = 20  # fewer pairs: no scatter measured, FLAT_TOLERANCE alone


def solved_rows(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows that cost a solve, in order (not the invalid ones, nor a plane met again)."""
    return [r for r in rows if r["status"] in ("ok", "failed") and "same_metal_as" not in r]


def best_so_far(solved: list[dict[str, Any]]) -> list[float]:
    """The best feasible FoM after each solve (inf until the first feasible one): the curve the
    stopping rule reads and the convergence figure draws."""
    so_far, curve = math.inf, []
    for r in solved:
        if r["status"] == "ok" and r.get("feasible", True):
            so_far = min(so_far, r["fom_mk"])
        curve.append(so_far)
    return curve


def search_scatter(solved: list[dict[str, Any]], span: np.ndarray) -> tuple[float | None, int]:
    """The objective's scatter at the search level: the median relative difference of the FoMs of
    feasible solved designs (same integer) whose every parameter lies within SCATTER_STEP x
    ``span`` (each parameter's range) of the other's, and how many such pairs there are (None
    below SCATTER_MIN_PAIRS)."""
    ok = [r for r in solved if r["status"] == "ok" and r.get("feasible", True) and r.get("fom_mk")]
    if len(ok) < 2:
        return None, 0
    span = np.asarray(span, float)
    x = np.array([r["x"] for r in ok], float) / np.where(span > 0, span, 1.0)
    n = np.array([-1 if r.get("integer") is None else r["integer"] for r in ok])
    f = np.array([r["fom_mk"] for r in ok], float)
    near = (np.abs(x[:, None, :] - x[None, :, :]).max(axis=2) < SCATTER_STEP) & (n[:, None] == n[None, :])
    i, j = np.nonzero(np.triu(near, 1))
    if len(i) < SCATTER_MIN_PAIRS:
        return None, int(len(i))
    return float(np.median(np.abs(f[i] - f[j]) / np.minimum(f[i], f[j]))), int(len(i))


def remeshings_of_best(solved: list[dict[str, Any]], span: np.ndarray) -> tuple[int, float | None]:
    """How often the search solved the final best's plane (feasible designs of its integer whose every
    parameter lies within SCATTER_STEP x ``span`` of it, the best included) and how far their median
    FoM lies above the best (relative; None below two solves): the remeshing luck a best-so-far
    that keeps sampling one plane picks up. A fact for the report; the stopping rule does not use it."""
    ok = [r for r in solved if r["status"] == "ok" and r.get("feasible", True) and r.get("fom_mk")]
    if not ok:
        return 0, None
    span = np.where(np.asarray(span, float) > 0, np.asarray(span, float), 1.0)
    best = min(ok, key=lambda r: r["fom_mk"])
    xb = np.asarray(best["x"], float) / span
    f = [r["fom_mk"] for r in ok if r.get("integer") == best.get("integer")
         and np.abs(np.asarray(r["x"], float) / span - xb).max() < SCATTER_STEP]
    return len(f), (float(np.median(f)) / best["fom_mk"] - 1 if len(f) >= 2 else None)


def best_plane_clause(stop: dict) -> str:
    """How often the search solved the best's own plane and how far those solves' median lies above
    the best (:func:`remeshings_of_best`), as a sentence; empty below two solves."""
    n, gap = stop.get("best_plane_solves") or 0, stop.get("best_plane_gap")
    if n < 2 or gap is None:
        return ""
    return (f" The best's own plane (every parameter within {100 * SCATTER_STEP:g} % of its range) was solved {n} "
            f"times; their median "
            f"FoM lies {100 * gap:.1f} % above the best" + (", more than the tolerance: part of the best is the "
            "search level's remeshing, not the design." if gap > (stop.get("tolerance") or 0) else
            ", within the tolerance."))


def flat_over_last_half(rows: list[dict[str, Any]], tol: float = FLAT_TOLERANCE,
                        span: np.ndarray | None = None) -> dict[str, Any]:
    """The stopping rule, from a search's rows in order: the solves, the solve from which the best
    feasible objective so far stays within the tolerance of the final best, and whether that lies
    in the first half (the second half found nothing better by more than it). The tolerance is
    ``tol``, or with ``span`` (the family's parameter ranges) the objective's own scatter
    (:func:`search_scatter`) where that is larger."""
    solved = solved_rows(rows)
    scatter, pairs = search_scatter(solved, span) if span is not None else (None, 0)
    tol = max(tol, scatter or 0.0)
    head = {"solves": len(solved), "tolerance": tol, "scatter": scatter, "scatter_pairs": pairs}
    curve, measure = best_so_far(solved), "fom"
    if curve and not math.isfinite(curve[-1]):  # nothing feasible: how close the search came
        curve, measure = least_violation_so_far(solved), "violation"
    if not curve or not math.isfinite(curve[-1]):
        return {**head, "best_at": 0, "flat": False, "measure": measure}
    at = next(i for i, v in enumerate(curve, 1) if v <= curve[-1] * (1 + tol))
    if measure == "fom" and span is not None:
        head["best_plane_solves"], head["best_plane_gap"] = remeshings_of_best(solved, span)
    return {**head, "best_at": at, "flat": at <= len(solved) / 2, "measure": measure}


def least_violation_so_far(solved: list[dict[str, Any]]) -> list[float]:
    """With no feasible design: the smallest relative constraint violation after each solve (the
    largest of a row's margins; inf until the first scored row)."""
    so_far, curve = math.inf, []
    for r in solved:
        if r["status"] == "ok" and r.get("margins"):
            so_far = min(so_far, max(r["margins"]))
        curve.append(so_far)
    return curve


RESTART_DISTANCE = 0.05  # of each parameter's range (the until-flat rounds' first step): a start this near one that
# proposed nothing solvable would propose the same planes again


def _until_flat(fam: Family, ints: tuple, ev: "_Evaluator", algorithm: str, max_budget: int) -> dict[str, Any]:
    """Go on refining from the best design (with none feasible: the closest), half the solves so
    far at a time, until at least the budget asked is spent and the best so far lies in the first
    half of the solves, or ``max_budget`` solves are spent. A round that solves nothing (every plane
    it proposed is invalid, over the budget or solved already) does not end the search: the next
    starts from the best design not within RESTART_DISTANCE of such a start, and with none left from
    a fresh space-filling draw."""
    span = np.array(fam.upper, float) - np.array(fam.lower, float)
    state = flat_over_last_half(ev.counted, span=span)  # as counted, so a resumed search decides as the first run did
    asked, k, barren, exhausted = ev.budget, 0, [], False
    while (not state["flat"] or ev.solves < asked) and ev.solves < max_budget:
        k += 1
        more = min(max_budget, max(ev.solves + 1, 2 * state["best_at"], asked)) - ev.solves
        ev.budget, before = ev.solves + more, ev.solves
        start = ev.next_start(barren, span)
        if start is None:
            if not _fresh_draw(fam, ints, ev, seed=k, phase=f"until-flat-{k}-draw"):
                exhausted = True  # the family holds no design left to solve
                break
        else:
            _run_nlopt(fam, start["integer"], ev, algorithm, ev.solves + more, ev.max_area, ev.progress,
                       x0=np.array(start["x"]), phase=f"until-flat-{k}", step=RESTART_DISTANCE)
            if ev.solves == before:  # nothing solvable from here: the next round starts elsewhere
                barren.append(start)
                if ev.progress:
                    print(f"  round until-flat-{k} solved nothing from its start; the next starts from another "
                          "design", file=sys.stderr, flush=True)
        state = flat_over_last_half(ev.counted, span=span)
    return {**state, "max_budget": max_budget, "barren_starts": len(barren), "exhausted": exhausted}


def _fresh_draw(fam: Family, ints: tuple, ev: "_Evaluator", seed: int, phase: str) -> bool:
    """Solve the first design of a space-filling draw (Sobol ``seed``; the exploration's is 0) that
    the search has not met and can solve (one built alike a solved one is met); False when there is none."""
    before = ev.solves
    for x, n in space_filling(fam, ints, ev.max_area, 2 ** 10, seed=seed):
        if ev.hist.get(n, x) is None and ev.reason(x, n) is None:
            ev(x, np.zeros(0), n, phase=phase)
            if ev.solves > before:
                return True
    return False


def integer_choices(fam: Family, integer_values: Iterable[int] | None) -> tuple:
    """The values of the family's integer parameter a search tries (the given ones, else the
    family's own; (None,) for a family without one); refused by name when the family cannot take
    one (0 teeth, a negative count)."""
    if not integer_values:
        return fam.integer_values or (None,)
    values = tuple(integer_values)
    if fam.integer is None:
        raise UserInputError(f"--integers: the {fam.cls.kind} family has no integer parameter")
    from groundplane.shapes import MAX_COUNT

    prm = next(p for p in fam.cls.parameters() if p.name == fam.integer)
    low = max(1, int(prm.minimum or 1))
    bad = [v for v in values if not isinstance(v, int) or isinstance(v, bool) or not low <= v <= MAX_COUNT]
    if bad:
        raise UserInputError(f"--integers {' '.join(map(str, bad))}: {fam.integer} of a {fam.cls.kind} must be a whole "
                             f"number {low}-{MAX_COUNT}")
    return values


def _check_request(max_area: float, algorithm: str, budget: int, strategy: str, fam: Family, ints: tuple,
                   seeds: dict[str, GroundPlane] | None, explore: int | None = None,
                   build_tolerance: float | None = None) -> None:
    """Refuse, before any work, a search that cannot run."""
    if not (math.isfinite(max_area) and max_area > 0):
        raise UserInputError(f"--max-area must be a positive number of m^2, got {max_area}")
    if algorithm not in CONSTRAINED_ALGORITHMS:
        raise UserInputError(f"algorithm {algorithm} does not take the area constraint; use one of "
                             f"{', '.join(CONSTRAINED_ALGORITHMS)}")
    if budget < 1:
        raise UserInputError("--budget must be >= 1 evaluation")
    if strategy not in STRATEGIES:
        raise UserInputError(f"--strategy {strategy}: choose one of {', '.join(STRATEGIES)}")
    check_seeds(fam, max_area, ints, seeds, strategy)
    _check_explore(explore, budget, strategy)
    if build_tolerance is not None and not 0 < build_tolerance < 0.5:
        raise UserInputError(f"--build-tolerance {build_tolerance}: a fraction of each parameter's range, above 0 "
                             "and below 0.5 (0.001: 2.6 cm on teeth-xy's side)")


def check_seeds(fam: Family, max_area: float, ints: tuple, seeds: dict[str, GroundPlane] | None,
                strategy: str = "global") -> None:
    """Refuse, before any work, seeds the search could not use (they would be skipped silently):
    a local search, or a design outside the family, its bounds or the budget."""
    if not seeds:
        return
    if strategy != "global":
        raise UserInputError("--seed needs --strategy global (the local search starts from the family's own start point)")
    usable = {name for name, *_ in seeds_for(fam, max_area, ints, seeds)}
    for name, plane in seeds.items():
        if name not in usable:
            raise UserInputError(f"--seed {name}: not a {fam.cls.kind} design within the bounds and the {max_area:g} m^2 "
                                 f"budget ({plane.metal_area:.1f} m^2)")


def seeds_for(fam: Family, max_area: float, ints: tuple, extra: dict[str, GroundPlane] | None = None
              ) -> list[tuple[str, GroundPlane, np.ndarray, int | None]]:
    """The presets (and ``extra`` named planes, e.g. smaller budgets' answers) that are members
    of the family (exactly: :meth:`GroundPlane.member`) and fit the budget: (name, the plane
    itself, its x, its integer)."""
    from groundplane.shapes import PRESETS

    out = []
    for name, plane in {**(extra or {}), **PRESETS}.items():  # the known answers first
        m = fam.cls.member(plane)
        if m is None or plane.metal_area > max_area * (1 + 1e-9):
            continue
        p = m.params()
        n = p.get(fam.integer) if fam.integer else None
        x = np.array([p[k] for k in fam.names], float)
        if (fam.integer and n not in ints) or np.any(x < np.array(fam.lower) - 1e-9) or np.any(x > np.array(fam.upper) + 1e-9):
            continue
        out.append((name, plane, x, n))
    return out


def space_filling(fam: Family, ints: tuple, max_area: float, count: int, seed: int = 0) -> list[tuple[np.ndarray, int | None]]:
    """``count`` designs of a scrambled Sobol sequence over the bounds (and the integer values),
    kept when valid and using EXPLORE_MIN_FILL-1 of the budget; deterministic for a seed."""
    from scipy.stats import qmc

    if count <= 0:
        return []
    d = len(fam.names)
    lo, hi = np.array(fam.lower), np.array(fam.upper)
    out: list[tuple[np.ndarray, int | None]] = []
    for u in qmc.Sobol(d + 1, scramble=True, seed=seed).random(2 ** 14):
        n = ints[min(int(u[d] * len(ints)), len(ints) - 1)]
        x = np.clip(fam.sample(u[:d], n), lo, hi)
        if EXPLORE_MIN_FILL * max_area <= fam.area(x, n) <= max_area and all(v <= 0 for v in fam.validity(x, n)):
            out.append((x, n))
            if len(out) == count:
                break
    return out


def _local_search(fam: Family, ints: tuple, ev: "_Evaluator", algorithm: str) -> None:
    """One nlopt run per integer value from the family's start, the solves shared out (the
    first values take the remainder)."""
    for i, n in enumerate(ints):
        share = ev.budget // len(ints) + (1 if i < ev.budget % len(ints) else 0)
        if share:
            _run_nlopt(fam, n, ev, algorithm, ev.solves + share, ev.max_area, ev.progress)


def _global_search(fam: Family, ints: tuple, ev: "_Evaluator", algorithm: str, out: Path, executor: str,
                   scheduler: str | None, extra: dict[str, GroundPlane] | None = None,
                   explore: int | None = None) -> None:
    """Seeds and a space-filling sample (``explore`` solves, default EXPLORE_FRACTION of the
    budget), then local refinement from the best few."""
    explore = explore or max(1, math.ceil(EXPLORE_FRACTION * ev.budget))
    seeds = seeds_for(fam, ev.max_area, ints, extra)[:explore]
    sample = space_filling(fam, ints, ev.max_area, 10 * explore)  # spares for designs the mesh cannot hold
    designs = [(x, n, plane, name) for name, plane, x, n in seeds] + [(x, n, None, None) for x, n in sample]
    if executor != "local":
        _presolve(designs, ev, out, executor, scheduler, explore)
    for x, n, plane, name in designs:
        if ev.solves >= explore:
            break
        ev(x, np.zeros(0), n, phase="seed" if plane is not None else "explore", plane=plane, name=name)
    # from the exploration's rows only: a resumed search's history also holds the refinements
    # feasible designs first (by FoM), then the rest by how little they break the constraints
    ok = sorted((r for r in ev.counted if r["status"] == "ok" and r.get("phase") in ("seed", "explore")),
                key=lambda r: (not r.get("feasible", True), max(r.get("margins") or [0.0]) if not r.get("feasible", True)
                               else 0.0, r["fom_mk"]))
    starts = list({History.key(r["integer"], r["x"]): r for r in ok}.values())[:REFINE_STARTS]
    for i, r in enumerate(starts):
        left = ev.budget - ev.solves
        if left <= 0:
            break
        share = left if i == len(starts) - 1 else max(1, math.ceil(left / 2))  # the best start gets the most
        _run_nlopt(fam, r["integer"], ev, algorithm, ev.solves + share, ev.max_area, ev.progress,
                   x0=np.array(r["x"]), phase=f"refine-{i + 1}")


def _presolve(designs: list, ev: "_Evaluator", out: Path, executor: str, scheduler: str | None, count: int) -> None:
    """Solve the exploration's designs in parallel on the executor (the beam cache keeps them;
    scoring them afterwards is a cache hit): the first ``count`` the evaluator would solve."""
    from .sweep import run_sweep

    todo = []
    for x, n, plane, name in designs:
        if len(todo) >= count:
            break
        if ev.hist.get(n, x) is None and ev.reason(x, n) is None:
            todo.append(Candidate(name or f"{ev.shape}-explore-{len(todo)}", plane=plane or ev.fam.build(x, n)))
    run_sweep(todo, ev.settings, out / "explore", executor=executor, scheduler=scheduler, progress=ev.progress)


SCENARIO_FIELDS = ("per_member_mk", "mean_fom_mk", "worst_fom_mk", "nominal_fom_mk", "loss_spread", "aggregate")


class BudgetSpent(Exception):
    """The search has used its solves."""


@dataclass
class _Evaluator:
    """The objective nlopt calls: replays the history, else checks and scores one x. Counts
    the solves (replayed ones too, so a resumed search takes the same path) against ``budget``."""

    fam: Family
    shape: str
    max_area: float
    settings: EvalSettings
    hist: History
    evaluate_fn: Callable[[Candidate, EvalSettings], dict[str, Any]]
    progress: bool
    budget: int = 10 ** 9
    constraints: Any = None  # scenarios.Constraints (None: none)
    penalty_floor: float = 1.0e4  # mK: far above any real FoM, and finite
    solves: int = 0
    _replayed: set = field(default_factory=set)
    counted: list = field(default_factory=list)  # the solved rows in the order this search counted them
    _seconds: list = field(default_factory=list)  # this run's solve times (the progress line's time left)
    build_tolerance: float | None = None  # of each parameter's range: within it of a solved design, that design

    def best(self) -> dict[str, Any] | None:
        """The feasible solved row with the lowest FoM within the budget (None: none), of the rows
        this search has counted (a history may hold more, from a run with a larger budget)."""
        ok = [r for r in self.counted if r["status"] == "ok" and r.get("feasible", True)
              and r["area_m2"] <= self.max_area * (1 + 1e-9)]
        return min(ok, key=lambda r: r["fom_mk"]) if ok else None

    def closest(self) -> dict[str, Any] | None:
        """With no feasible row: the solved row whose constraints are broken least (relative)."""
        ok = [r for r in self.counted if r["status"] == "ok" and r["area_m2"] <= self.max_area * (1 + 1e-9)]
        return min(ok, key=lambda r: (max(r.get("margins") or [0.0]), r["fom_mk"])) if ok else None

    def next_start(self, barren: list[dict[str, Any]], span: np.ndarray) -> dict[str, Any] | None:
        """The best design (feasible ones by FoM, then the rest by how little they break the
        constraints; within the area budget) not within RESTART_DISTANCE of a ``barren`` start
        (one from which a round solved nothing), or None."""
        span = np.where(span > 0, span, 1.0)
        ok = sorted((r for r in self.counted if r["status"] == "ok" and r["area_m2"] <= self.max_area * (1 + 1e-9)),
                    key=lambda r: (not r.get("feasible", True),
                                   0.0 if r.get("feasible", True) else max(r.get("margins") or [0.0]), r["fom_mk"]))
        for r in ok:
            if all(r.get("integer") != b.get("integer") or
                   np.abs((np.asarray(r["x"], float) - np.asarray(b["x"], float)) / span).max() >= RESTART_DISTANCE
                   for b in barren):
                return r
        return None

    def margins(self, n: int | None, x) -> list[float]:
        """Each constraint's relative margin at x (<= 0 when met); 0 where x has no solved row."""
        if self.constraints is None:
            return []
        r = self.hist.get(n, x)
        width = len(self.constraints.margin(None, None))
        return list(r["margins"]) if r is not None and r.get("margins") else [0.0] * width

    @property
    def solver(self):
        """The engine that solves this search's designs (asked what its mesh cannot represent)."""
        if "_solver" not in self.__dict__:
            self.__dict__["_solver"] = self.settings.make_solver()
        return self.__dict__["_solver"]

    def penalty(self) -> float:
        finite = [r["fom_mk"] for r in self.hist.rows if r["status"] == "ok"]
        return max([self.penalty_floor] + [10 * f for f in finite])

    def __call__(self, x: np.ndarray, grad: np.ndarray, n: int | None, phase: str = "local",
                 plane: GroundPlane | None = None, name: str | None = None) -> float:
        _zero(grad)
        seen = self.hist.get(n, x)
        if seen is not None:  # replay: nlopt sees exactly what it saw before
            key = History.key(n, x)
            if seen["status"] in ("ok", "failed") and "same_metal_as" not in seen and key not in self._replayed:
                self._replayed.add(key)
                self.counted.append(seen)
                self.solves += 1
            return float(seen["objective"])
        why = self.reason(x, n)
        if why is None and (twin := self.hist.same_metal((plane or self.fam.build(x, n)).outline_key())) is not None:
            return self._same_metal(x, n, phase, twin)
        if why is None and plane is None and (twin := self._built_alike(x, n)) is not None:
            return self._same_metal(x, n, phase, twin, "within the build tolerance")
        if why is None and self.solves >= self.budget:
            raise BudgetSpent
        t0 = time.perf_counter()
        row: dict[str, Any] = {"integer": n, "x": [float(v) for v in x], "params": self.fam.params(x, n),
                               "area_m2": self.fam.area(x, n), "phase": phase, "mesh_m": self.settings.spacing}
        row.update({"status": "invalid", "fom_mk": None, "error": why} if why else self._score(x, n, plane, name))
        if row["status"] in ("ok", "failed"):
            self.solves += 1
            self._replayed.add(History.key(n, x))
            self.counted.append(row)
        row["objective"] = row["fom_mk"] if row["status"] == "ok" else self.penalty()
        row["seconds"] = round(time.perf_counter() - t0, 2)
        self.hist.add(row)
        if self.progress:
            f = f"{row['fom_mk']:.1f} mK" if row["fom_mk"] is not None else row["status"]
            which = f" {self.fam.integer}={n}" if self.fam.integer else ""
            print(f"  eval {len(self.hist.rows):3d} [{phase}, solve {self.solves}/{self.budget}]{which} "
                  f"x={np.round(x, 3).tolist()} area={row['area_m2']:.1f} m^2 -> {f} ({row['seconds']:.0f} s"
                  f"{self._time_left(row)})", file=sys.stderr, flush=True)
        return float(row["objective"])

    def _time_left(self, row: dict[str, Any]) -> str:
        """'; ~T to the budget's last solve' at the median of this run's solves so far (a resumed
        search's replayed rows and beams found in the cache, under a second, are not counted), or ''
        before there are three."""
        if row["status"] in ("ok", "failed") and row["seconds"] >= 1.0:
            self._seconds.append(row["seconds"])
        left = self.budget - self.solves
        if len(self._seconds) < 3 or left <= 0:
            return ""
        t = left * float(np.median(self._seconds))
        when = f"{t / 3600:.1f} h" if t >= 5400 else f"{t / 60:.0f} min"
        return f"; ~{when} to solve {self.budget}"

    def _built_alike(self, x: np.ndarray, n: int | None) -> dict[str, Any] | None:
        """With a build tolerance: the solved row (same integer) nearest x whose every parameter lies
        within the tolerance x its range of x's (a crew would build the two alike), else None."""
        if not self.build_tolerance:
            return None
        span = np.array(self.fam.upper, float) - np.array(self.fam.lower, float)
        span = np.where(span > 0, span, 1.0)
        near = [(float(np.abs((np.asarray(r["x"], float) - x) / span).max()), i) for i, r in enumerate(self.hist.rows)
                if r["status"] in ("ok", "failed") and "same_metal_as" not in r and r.get("integer") == n]
        d, i = min(near, default=(np.inf, -1))
        return self.hist.rows[i] if d <= self.build_tolerance else None

    def _same_metal(self, x: np.ndarray, n: int | None, phase: str, twin: dict[str, Any],
                    why: str = "same outline") -> float:
        """x is a plane already scored under other parameters (or, ``why`` says, one built alike):
        its row again, no solve counted."""
        row = {**twin, "integer": n, "x": [float(v) for v in x], "params": self.fam.params(x, n), "phase": phase,
               "same_metal_as": self.hist.rows.index(twin) + 1, "seconds": 0.0,
               **({"built_alike": True} if why != "same outline" else {})}
        self.hist.add(row)
        if self.progress:
            print(f"  eval {len(self.hist.rows):3d} [{phase}]: the plane of eval {row['same_metal_as']} ({why}), "
                  "no solve", file=sys.stderr, flush=True)
        return float(row["objective"])

    def resumed(self) -> None:
        """Bring a history written by an earlier version up to today's: outlines, refusals."""
        self.backfill_outlines()
        self.refuse_again()

    def backfill_outlines(self) -> None:
        """Index the scored rows of a history written before rows carried their outline."""
        for r in self.hist.rows:
            if r["status"] in ("ok", "failed") and not r.get("outline") and "same_metal_as" not in r:
                try:
                    self.hist.outlines.setdefault(row_plane(self.fam, r).outline_key(), r)
                except ShapeError:
                    continue

    def refuse_again(self) -> None:
        """Hold the history's solved rows to today's rules: a design a newer check refuses (a row
        solved before the check existed) is replayed as refused, not as a FoM nlopt or the answer
        may take. The file keeps its rows; they are reclassified in memory on every resume."""
        refused = []
        for r in self.hist.rows:
            if r["status"] not in ("ok", "failed") or "same_metal_as" in r:
                continue
            try:
                why = self.reason(np.asarray(r["x"], float), r.get("integer"))
            except ShapeError as exc:
                why = str(exc)
            if why is not None:
                refused.append(r)
                r.update({"status": "invalid", "fom_mk": None, "error": f"refused on resume: {why}",
                          "solved_before": {"fom_mk": r.get("fom_mk"), "status": r["status"]}})
        gone = {id(x) for x in refused}
        for r in self.hist.rows:  # a twin of a refused row is refused with it
            if r.get("same_metal_as") and id(self.hist.rows[r["same_metal_as"] - 1]) in gone:
                r.update({"status": "invalid", "fom_mk": None, "error": "refused on resume with its twin"})
        if refused:
            self.hist.outlines = {k: v for k, v in self.hist.outlines.items() if id(v) not in gone}
            penalty = self.penalty()
            for r in self.hist.rows:
                if r["status"] == "invalid":
                    r["objective"] = penalty
            if self.progress:
                print(f"  {len(refused)} solved row(s) of the history are refused by today's checks (first: "
                      f"{refused[0]['error']}); replayed as refused", file=sys.stderr, flush=True)

    def reason(self, x: np.ndarray, n: int | None) -> str | None:
        """Why x cannot be solved (None if it can): invalid, over the budget, or finer than the mesh."""
        if not np.all(np.isfinite(x)) or any(v > 0 for v in self.fam.validity(x, n)):
            return "outside the family's valid region"
        if self.fam.area(x, n) > self.max_area * (1 + 1e-9):
            return "metal area above the budget"
        try:
            plane = self.fam.build(x, n)
        except ShapeError as exc:
            return str(exc)
        spacing = self.settings.spacing
        if spacing and (why := too_fine_for(plane, spacing)):  # the search would exploit the model
            return why
        return self.solver.why_unresolved(plane)

    def _score(self, x: np.ndarray, n: int | None, plane: GroundPlane | None, name: str | None) -> dict[str, Any]:
        plane = plane or self.fam.build(x, n)
        if self.progress:
            print(f"  eval {len(self.hist.rows) + 1:3d}: solving {plane.describe()} ...", file=sys.stderr, flush=True)
        res = self.evaluate_fn(Candidate(name or f"{self.shape}-{len(self.hist.rows)}", plane=plane), self.settings)
        fom = res.get("lst_averaged_fom_mk")
        if res.get("status") == "ok" and fom is not None and math.isfinite(fom):
            kept = {k: res[k] for k in SCENARIO_FIELDS if k in res}  # a scenario objective's members and loss
            loss = res.get("max_loss", res.get("max_ground_loss"))
            feas = {}
            if self.constraints is not None:
                broken = self.constraints.violations(loss, res.get("loss_spread"))
                feas = {"feasible": not broken, "violations": broken,
                        "margins": self.constraints.margin(loss, res.get("loss_spread"))}
            return {"status": "ok", "fom_mk": float(fom), "name": name or plane.describe(), "max_loss": loss, **kept,
                    **feas, "outline": plane.outline_key()}
        return {"status": "failed", "fom_mk": None, "error": str(res.get("error", "non-finite FoM")),
                "outline": plane.outline_key()}


def _run_nlopt(fam: Family, n: int | None, ev: _Evaluator, algorithm: str, stop_at_solves: int, max_area: float,
               progress: bool, x0: np.ndarray | None = None, phase: str = "local", step: float = 0.15) -> None:
    """One nlopt run over the continuous parameters at integer value ``n``, until the
    evaluator has made ``stop_at_solves`` solves (or nlopt converges); COBYLA's first step is
    ``step`` of each parameter's range."""
    import nlopt

    opt = nlopt.opt(getattr(nlopt, algorithm), len(fam.names))
    opt.set_lower_bounds(list(fam.lower))
    opt.set_upper_bounds(list(fam.upper))

    def objective(x, g):
        # this run's solves are spent: stop before any design that would count as a solve, replayed or not
        # (a rerun then stops where the first run did, even at designs a later phase solved)
        if ev.solves >= stop_at_solves and History.key(n, x) not in ev._replayed and ev.reason(x, n) is None:
            raise nlopt.ForcedStop
        return ev(x, g, n, phase=phase)

    def loss_margin(i: int):
        def margin(x, g):  # the same design's row as the objective's (solved by whichever nlopt asks first)
            _zero(g)
            if History.key(n, x) not in ev._replayed and ev.reason(x, n) is None:
                objective(x, np.zeros(0))
            return ev.margins(n, x)[i]
        return margin

    opt.set_min_objective(objective)
    opt.add_inequality_constraint(lambda x, g: _zero(g) + fam.area(x, n) - max_area, 1e-6 * max_area)
    for i in range(len(ev.margins(n, x0 if x0 is not None else fam.start(max_area, n)))):
        opt.add_inequality_constraint(loss_margin(i), 1e-3)
    x0 = np.clip(fam.start(max_area, n) if x0 is None else x0, fam.lower, fam.upper)
    for i in range(len(fam.validity(x0, n))):
        opt.add_inequality_constraint(lambda x, g, i=i: _zero(g) + fam.validity(x, n)[i], 1e-9)
    opt.set_maxeval(10 * max(1, stop_at_solves))  # invalid proposals cost no solve; this only bounds a stuck run
    opt.set_xtol_rel(1e-3)
    if algorithm == "LN_COBYLA":
        opt.set_initial_step([step * (u - l) for l, u in zip(fam.lower, fam.upper)])
    try:
        opt.optimize(x0)
    except (nlopt.ForcedStop, BudgetSpent):
        pass
    except (nlopt.RoundoffLimited, ValueError, RuntimeError) as exc:
        if progress:
            print(f"  nlopt stopped early for {fam.integer}={n}: {exc}", file=sys.stderr)


def _zero(grad: np.ndarray) -> float:
    if grad.size:
        grad[:] = 0.0
    return 0.0


def row_plane(fam: Family, row: dict[str, Any]) -> GroundPlane:
    """The plane a history row was solved as: a seed preset as itself (so its confirmations and
    answers reuse the preset's beams), any other row as the family member of its x."""
    from groundplane.shapes import PRESETS

    if row.get("phase") == "seed" and row.get("name") in PRESETS:
        return PRESETS[row["name"]]
    return fam.build(np.array(row["x"]), row["integer"])


def best_plane(shape: str, best: dict[str, Any]) -> GroundPlane:
    """The plane of a history row."""
    return row_plane(family(shape), best)
