"""The metal-vs-FoM front: the best design of a family at each of several metal budgets, set
beside the paper's presets and the blade over infinite PEC (the floor no ground plane beats)
on the same model and settings. The answer a designer wants: how much metal buys how much
chromaticity.

Three fidelity levels (measured, not assumed: :func:`fidelity_ladder`): the search runs at
the cheap level (``settings``: a coarse mesh and/or fewer frequencies), its best few are
re-solved at the confirm level (``confirm``: the default model, where the presets are scored
too), and the answer at each budget once more at a finer mesh (``answer_mesh``).
"""
from __future__ import annotations

import json
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from groundplane.files import atomic_path, write_csv
from groundplane.shapes import PRESETS, to_dict

from .evaluate import Candidate, EvalSettings, evaluate, pec_floor_mk
from .provenance import header
from .report import cell
from .search import (
    OptimiseResult,
    best_plane,
    best_plane_clause,
    best_so_far,
    family,
    least_violation_so_far,
    optimise,
    solved_rows,
)

LADDER_DESIGNS = 24  # designs scored at both levels to measure how well the cheap one ranks (>= 20)
PARETO_COLUMNS = ("budget_m2", "area_m2", "fom_mk", "worst_fom_mk", "mean_fom_mk", "max_loss", "loss_spread",
                  "feasible", "violations", "mesh_m", "design", "evaluations", "best_at", "flat", "flat_tolerance",
                  "search_scatter", "best_plane_solves", "best_plane_gap", "barren_starts", "search_fom_mk",
                  "search_mesh_m", "search_max_loss", "answer_fom_mk", "answer_max_loss", "answer_mesh_m")
PRESET_COLUMNS = ("preset", "area_m2", "fom_mk", "worst_fom_mk", "mean_fom_mk", "max_loss", "loss_spread", "feasible",
                  "violations")


@dataclass
class Front:
    """What :func:`pareto_front` found: one row per budget, the presets and the PEC floor on
    the confirm level, the ladder's pairs and its Spearman."""

    rows: list[dict[str, Any]]
    presets: list[dict[str, Any]]
    ladder: list[dict[str, Any]] = field(default_factory=list)
    ladder_spearman: float | None = None
    results: dict[float, OptimiseResult] = field(default_factory=dict)


REFERENCE_BAR = 0.15  # the robust-design issue's bar: this far below the reference preset, whatever its metal


def _fom(candidate: Candidate, settings: EvalSettings, evaluate_fn) -> float | None:
    return _scored(candidate, settings, evaluate_fn)["fom_mk"]


def _scored(candidate: Candidate, settings: EvalSettings, evaluate_fn, constraints=None) -> dict[str, Any]:
    """A design's FoM (the objective: a scenario set's aggregate, or the plain FoM), its worst and
    mean member, ground loss and whether it meets ``constraints``, from ``evaluate_fn``."""
    row = evaluate_fn(candidate, settings)
    if row.get("status") != "ok":
        return {"fom_mk": None, "worst_fom_mk": None, "mean_fom_mk": None, "max_loss": None, "loss_spread": None,
                "feasible": None, "violations": row.get("error")}
    fom = float(row["lst_averaged_fom_mk"])
    loss = row.get("max_loss", row.get("max_ground_loss"))
    broken = constraints.violations(loss, row.get("loss_spread")) if constraints is not None else []
    return {"fom_mk": fom, "worst_fom_mk": row.get("worst_fom_mk", fom), "mean_fom_mk": row.get("mean_fom_mk", fom),
            "max_loss": loss, "loss_spread": row.get("loss_spread"), "feasible": not broken,
            "violations": "; ".join(broken)}


def preset_rows(confirm: EvalSettings, evaluate_fn, floor: Callable[[EvalSettings], float] = pec_floor_mk,
                constraints=None) -> list[dict]:
    """The nine Table 3 presets (and ``extended``) and the PEC floor (area 0) at the confirm level,
    each with its worst and mean member, ground loss and constraints (the blade over PEC loses
    nothing and is the same on every soil)."""
    rows = [{"preset": name, "area_m2": plane.metal_area,
             **_scored(Candidate(name, plane=plane), confirm, evaluate_fn, constraints)} for name, plane in PRESETS.items()]
    pec = floor(confirm)
    return rows + [{"preset": "pec", "area_m2": 0.0, "fom_mk": pec, "worst_fom_mk": pec, "mean_fom_mk": pec,
                    "max_loss": 0.0, "loss_spread": 0.0, "feasible": True, "violations": ""}]


def _answer(shape: str, budget_m2: float, res: OptimiseResult, confirm: EvalSettings, answer_mesh: float | None,
            evaluate_fn, constraints=None) -> dict[str, Any]:
    """One budget's row: its best (confirmed) design, and that design at the answer mesh; with no
    feasible design, the one that came closest (``feasible`` False, and what it breaks)."""
    best = res.best or res.closest
    stop = res.stopping or {}
    solves = stop.get("solves", len(res.solved()))
    head = {"budget_m2": budget_m2, "evaluations": solves, "best_at": stop.get("best_at"), "flat": stop.get("flat"),
            "flat_tolerance": stop.get("tolerance"), "search_scatter": stop.get("scatter"),
            "best_plane_solves": stop.get("best_plane_solves"), "best_plane_gap": stop.get("best_plane_gap"),
            "barren_starts": stop.get("barren_starts")}
    if best is None:
        return {**head, "area_m2": None, "fom_mk": None, "mesh_m": confirm.spacing, "design": None}
    plane = best_plane(shape, best)
    answer = (_scored(Candidate(f"{shape}-answer-{budget_m2:g}", plane=plane), confirm.with_spacing(answer_mesh),
                      evaluate_fn, constraints) if answer_mesh else {})
    return {**head, "area_m2": round(plane.metal_area, 3), "fom_mk": best["fom_mk"],
            "worst_fom_mk": best.get("worst_fom_mk", best["fom_mk"]), "mean_fom_mk": best.get("mean_fom_mk", best["fom_mk"]),
            "max_loss": best.get("max_loss"), "loss_spread": best.get("loss_spread"),
            "feasible": best.get("feasible", True) and res.best is not None,
            "violations": "; ".join(best.get("violations") or []),
            "mesh_m": best.get("confirmed_at", best.get("mesh_m")),
            "design": json.dumps(to_dict(family(shape).cls.member(plane))),
            "search_fom_mk": best.get("search_fom_mk", best["fom_mk"]), "search_mesh_m": best.get("mesh_m"),
            "search_max_loss": best.get("search_max_loss", best.get("max_loss")),
            "answer_fom_mk": answer.get("fom_mk"), "answer_max_loss": answer.get("max_loss"), "answer_mesh_m": answer_mesh}


def fidelity_ladder(shape: str, results: dict[float, OptimiseResult], confirm: EvalSettings, evaluate_fn,
                    count: int = LADDER_DESIGNS) -> tuple[list[dict], float | None]:
    """How well the search level ranks designs: ``count`` distinct designs the searches scored,
    spread over their FoM range, scored again at the confirm level; Spearman between the two."""
    from scipy.stats import spearmanr

    from .search import History, row_plane

    fam = family(shape)
    seen = {}
    for res in results.values():
        for r in solved_rows(res.history):
            if r["status"] == "ok":
                seen.setdefault(History.key(r["integer"], r["x"]), r)
    pool = sorted(seen.values(), key=lambda r: r["fom_mk"])
    picks = [pool[int(i)] for i in np.unique(np.linspace(0, len(pool) - 1, min(count, len(pool))).round())] if pool else []
    rows = []
    for i, r in enumerate(picks):
        plane = row_plane(fam, r)
        fine = _fom(Candidate(f"{shape}-ladder-{i}", plane=plane), confirm, evaluate_fn)
        rows.append({"design": json.dumps(r["params"]), "area_m2": r["area_m2"], "search_fom_mk": r["fom_mk"],
                     "search_mesh_m": r.get("mesh_m"), "confirm_fom_mk": fine, "confirm_mesh_m": confirm.spacing})
    pairs = [(r["search_fom_mk"], r["confirm_fom_mk"]) for r in rows if r["confirm_fom_mk"] is not None]
    rho = float(spearmanr(*zip(*pairs)).statistic) if len(pairs) >= 3 else None
    return rows, rho


def kept_rows(evaluate_fn: Callable[[Candidate, EvalSettings], dict[str, Any]], path: Path,
              objective: dict[str, Any]) -> Callable[[Candidate, EvalSettings], dict[str, Any]]:
    """``evaluate_fn`` whose scored rows are kept in ``path`` (JSON lines keyed by the plane's
    outline, the settings and ``objective``): a front resumed on another machine, whose beam
    cache is empty, scores its answers, presets and ladder again from these rows, not by solving."""
    import hashlib

    from groundplane.files import append_jsonl, read_jsonl

    done = {r["key"]: r["row"] for r in read_jsonl(path) if isinstance(r.get("key"), str) and isinstance(r.get("row"), dict)}

    def run(candidate: Candidate, settings: EvalSettings) -> dict[str, Any]:
        what = candidate.plane.outline_key() if candidate.plane is not None else candidate.identity()
        key = hashlib.sha256(json.dumps([what, settings.identity(), objective], sort_keys=True,
                                        default=str).encode()).hexdigest()[:24]
        if key in done:
            return done[key]
        row = evaluate_fn(candidate, settings)
        if row.get("status") == "ok":
            row = json.loads(json.dumps(row, default=float))  # as it will read back (numpy scalars as floats)
            append_jsonl(path, {"key": key, "name": candidate.name, "row": row})
            done[key] = row
        return row
    return run


def pareto_front(shape: str, budgets: list[float], settings: EvalSettings, confirm: EvalSettings, out_dir: str | Path,
                 *, budget: int = 40, answer_mesh: float | None = None, ladder: int = LADDER_DESIGNS, confirm_top: int = 3,
                 evaluate_fn: Callable[[Candidate, EvalSettings], dict[str, Any]] | None = None,
                 executor: str = "local", scheduler: str | None = None, progress: bool = True,
                 floor: Callable[[EvalSettings], float] = pec_floor_mk, scenarios=None, constraints=None,
                 max_budget: int | None = None, seeds: dict[str, Any] | None = None,
                 explore: int | None = None, build_tolerance: float | None = None) -> Front:
    """Search ``shape`` at each metal budget (``out/budget-<A>/``, each resumable; a design met
    again is a cache hit), confirm, answer; then the presets, the floor and the ladder. Each
    budget scores first the smaller budgets' answers, then the ``seeds`` (named planes) that fit it, in
    its ``explore`` solves of the global stage (:func:`optimise.search.optimise`, as is ``build_tolerance``). With
    ``scenarios`` every design is scored on each member (the set's aggregate the objective) and
    ``constraints`` decide which designs can be an answer."""
    from .scenarios import scenario_evaluator

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if evaluate_fn is None:
        evaluate_fn = (scenario_evaluator(scenarios, constraints, progress) if scenarios is not None
                       else (lambda c, s: evaluate(c, s, progress=progress)))
        objective = {"scenarios": scenarios.identity() if scenarios is not None else None,
                     "constraints": constraints.identity() if constraints is not None else None}
        scored = kept_rows(evaluate_fn, out / "scored.jsonl", objective)  # answers, presets, ladder
    else:
        scored = evaluate_fn
    results, rows, answers, earlier = {}, [], [], None
    for b in sorted(budgets):
        if progress:
            print(f"pareto: budget {b:g} m^2", file=sys.stderr, flush=True)
        # the smaller budgets' answers fit this one too: scored first, so the front cannot rise with metal
        smaller = {f"answer at {a:g} m^2": best_plane(shape, r.best) for a, r in results.items() if r.best}
        smaller.update({n: p for n, p in (seeds or {}).items() if p.metal_area <= b * (1 + 1e-9)})  # those that fit it
        res = optimise(shape, b, settings, out / f"budget-{b:g}", budget=budget, evaluate_fn=evaluate_fn,
                       progress=progress, confirm_settings=confirm, confirm_top=confirm_top, executor=executor,
                       scheduler=scheduler, seeds=smaller, constraints=constraints, max_budget=max_budget,
                       objective={"scenarios": scenarios.identity()} if scenarios is not None else None,
                       explore=explore, build_tolerance=build_tolerance)
        results[b] = res
        write_convergence(out / f"budget-{b:g}", res)
        answers.append(_answer(shape, b, res, confirm, answer_mesh, scored, constraints))
        if earlier is None:  # a run of some budgets keeps the others this folder answered with the same objective
            earlier = earlier_rows(out, budgets, out / f"budget-{b:g}")
        rows = sorted(answers + earlier, key=lambda r: r["budget_m2"])
        write_csv(out / "front.csv", rows, PARETO_COLUMNS)
    presets = preset_rows(confirm, scored, floor, constraints)
    write_csv(out / "presets.csv", presets, PRESET_COLUMNS)
    lad, rho = fidelity_ladder(shape, results, confirm, scored, ladder) if ladder else ([], None)
    if lad:
        write_csv(out / "ladder.csv", lad, tuple(lad[0]))
    return Front(rows, presets, lad, rho, results)


def earlier_rows(out: Path, budgets: list[float], searched: Path) -> list[dict[str, Any]]:
    """The rows of ``out/front.csv`` for budgets this run does not search, kept when their search
    (``budget-<A>/search.json``) had the same shape, settings, objective and model as ``searched``'s: a
    run of one budget (resuming it, say) must not drop the front's other answers, nor keep answers
    to another question."""
    import csv

    def identity(d: Path) -> Any:
        try:
            search = json.loads((d / "search.json").read_text())
        except (OSError, ValueError):
            return None
        return search.get("shape"), search.get("settings"), search.get("objective"), search.get("model")

    def same(a: Any, b: Any) -> bool:  # a search.json from before the model was recorded matches any model
        return a is not None and b is not None and a[:3] == b[:3] and (None in (a[3], b[3]) or a[3] == b[3])

    path, mine = out / "front.csv", identity(searched)
    if mine is None or not path.exists():
        return []
    kept = []
    with open(path, newline="") as fh:
        for r in csv.DictReader(fh):
            try:
                a = float(r["budget_m2"])
            except (KeyError, ValueError):
                continue
            if a not in budgets and same(identity(out / f"budget-{a:g}"), mine):
                kept.append({k: _cell_value(k, v) for k, v in r.items() if k in PARETO_COLUMNS})
    return kept


def _cell_value(column: str, text: str | None) -> Any:
    """A front.csv cell back as the value :func:`_answer` wrote (numbers, booleans, None for empty)."""
    if text is None or text == "":
        return None
    if column in ("design", "violations"):
        return text
    if text in ("True", "False"):
        return text == "True"
    try:
        return int(text) if column in ("evaluations", "best_at", "best_plane_solves", "barren_starts") else float(text)
    except ValueError:
        return text


def best_preset_within(presets: list[dict], area_m2: float) -> dict | None:
    """The lowest-FoM preset (not the PEC floor) using no more metal than ``area_m2``."""
    fit = [p for p in presets if p["preset"] != "pec" and p["fom_mk"] is not None
           and p["area_m2"] <= area_m2 * (1 + 1e-9)]
    return min(fit, key=lambda p: p["fom_mk"]) if fit else None


def verdicts(front: Front, target: float = 0.25, reference: str | None = None) -> list[str]:
    """Per budget, computed from the rows: the answer against the best preset with no more
    metal (at least ``target`` lower is the bar), or against the preset ``reference`` whatever its
    metal, and against the PEC floor; whether the search's best was flat over its last half; an
    infeasible budget says what its closest design breaks."""
    floor = next(p["fom_mk"] for p in front.presets if p["preset"] == "pec")
    out = []
    for r in front.rows:
        if r["fom_mk"] is None:
            out.append(f"- {r['budget_m2']:g} m^2: no design was scored.")
            continue
        tol = "" if r.get("flat_tolerance") is None else f" within {100 * r['flat_tolerance']:.1f} %"
        if r.get("barren_starts"):  # rounds that solved nothing from their start and restarted elsewhere
            tol += f"; {r['barren_starts']} refinement round(s) restarted from another design"
        if r.get("feasible") is False:
            flat = ("" if not r.get("best_at") else f" (the least violation found at solve {r['best_at']}{tol}: "
                    + ("flat over the last half)" if r.get("flat") else "**not** flat over the last half)"))
            out.append(f"- {r['budget_m2']:g} m^2: no feasible design in {r['evaluations']} solves{flat}; the closest, "
                       f"{r['area_m2']:.0f} m^2 at {r['fom_mk']:.1f} mK, breaks: {r.get('violations') or '?'}.")
            continue
        flat = ("" if r.get("flat") is None else f"; best at solve {r['best_at']} of {r['evaluations']}{tol}: "
                + ("flat over the last half" if r["flat"] else "**not** flat over the last half"))
        if reference is not None:
            ref = next((p for p in front.presets if p["preset"] == reference and p["fom_mk"] is not None), None)
        else:
            ref = best_preset_within(front.presets, r["budget_m2"])
        head = (f"- {r['budget_m2']:g} m^2: {r['fom_mk']:.1f} mK at {r['area_m2']:.0f} m^2 ({r['evaluations']} solves"
                f"{flat})")
        if ref is None:
            out.append(head + f"; no preset fits this budget; {r['fom_mk'] / floor:.2f} x the blade over infinite PEC.")
            continue
        gain = 1 - r["fom_mk"] / ref["fom_mk"]
        out.append(head + f" against {ref['preset']} {ref['fom_mk']:.1f} mK at {ref['area_m2']:.0f} m^2: "
                   + (f"{gain:.0%} lower, " + ("at least" if gain >= target else "short of") + f" {target:.0%}"
                      if gain > 0 else f"{-gain:.0%} higher: the search did not beat it")
                   + f"; {r['fom_mk'] / floor:.2f} x the blade over infinite PEC ({floor:.1f} mK)"
                   + (", below it: in this model the blade over PEC is no floor." if r["fom_mk"] < floor else ".")
                   + best_plane_clause({**r, "tolerance": r.get("flat_tolerance")}))
    return out


def label_offsets(points: list[tuple[float, float]], size: tuple[float, float] = (60.0, 10.0)) -> list[float]:
    """Upward label offsets (points) for labels anchored at ``points`` (display points, x and y) and
    ``size`` wide and tall (points), so that no two overprint: lowest point first, each label goes just
    above any placed label its box would overlap. In display units, not data: a fixed gap in mK is a
    different gap on the page on every front's axis."""
    offsets: list[float] = [0.0] * len(points)
    placed: list[tuple[float, float]] = []  # (x, bottom of the label) of each placed label
    for i in sorted(range(len(points)), key=lambda k: points[k][1]):
        x, y = points[i]
        off, moved = 0.0, True
        while moved:  # ends: the offset only grows, past each placed label at most once
            moved = False
            for px, bottom in placed:  # touching is not overlapping (with rounding: y + off - y != off)
                if abs(px - x) < size[0] and abs(bottom - (y + off)) < size[1] - 1e-6:
                    off, moved = bottom + size[1] - y, True
        offsets[i] = off
        placed.append((x, y + off))
    return offsets


def read_front(path: str | Path) -> list[dict[str, Any]]:
    """Another run's front (``front.csv`` or an older ``pareto.csv``): (area, FoM) per budget, to draw beside."""
    import csv
    import io

    path = Path(path)
    if not path.is_file():  # /dev/zero was read as one endless line until memory ran out
        raise ValueError("not a regular file")
    if path.stat().st_size > MAX_FRONT_BYTES:
        raise ValueError(f"{path.stat().st_size:,} bytes; a front table is a few kB (at most {MAX_FRONT_BYTES:,})")
    text = path.read_text(errors="replace")
    reader = csv.DictReader(io.StringIO(text))
    need = {"budget_m2", "area_m2", "fom_mk"}
    if not need <= set(reader.fieldnames or ()):
        raise ValueError(f"no {', '.join(sorted(need - set(reader.fieldnames or ())))} column(s) in its first line "
                         "(front.csv and pareto.csv have budget_m2, area_m2, fom_mk)")
    rows = []
    for r in reader:
        if r.get("area_m2") and r.get("fom_mk"):
            rows.append({"budget_m2": float(r["budget_m2"]), "area_m2": float(r["area_m2"]),
                         "fom_mk": float(r["fom_mk"])})
    if not rows:
        raise ValueError("it holds no budget with an answer (area_m2 and fom_mk)")
    return rows


MAX_FRONT_BYTES = 10_000_000


def pareto_figure(front: Front, path: Path, beside: list[dict[str, Any]] | None = None,
                  beside_label: str = "another front") -> Path:
    """FoM vs metal area: the front (coloured by its ground loss when the rows carry one; hollow:
    no feasible design), the presets and the PEC floor on the same axes, and ``beside``'s front."""
    from groundplane.plots import finish_figure, pyplot

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8.5, 5))
    done = sorted((r for r in front.rows if r["fom_mk"] is not None), key=lambda r: r["budget_m2"])
    feasible = [r for r in done if r.get("feasible") is not False]
    losses = [r.get("max_loss") for r in done]
    if any(v is not None for v in losses):
        vmax = max(v for v in losses + [p.get("max_loss") for p in front.presets] if v is not None) * 100 or 1.0
        sc = ax.scatter([r["area_m2"] for r in feasible], [r["fom_mk"] for r in feasible], s=60, cmap="viridis",
                        c=[100 * (r.get("max_loss") or 0) for r in feasible], vmin=0, vmax=vmax, edgecolor="k", zorder=3,
                        label="each budget's answer (confirm level)")
        fig.colorbar(sc, ax=ax, label="largest ground loss in the fit band (%)")
        bad = [r for r in done if r.get("feasible") is False]
        if bad:
            ax.scatter([r["area_m2"] for r in bad], [r["fom_mk"] for r in bad], s=60, facecolor="none", edgecolor="r",
                       zorder=3, label="no feasible design: the closest")
    else:
        ax.plot([r["area_m2"] for r in feasible], [r["fom_mk"] for r in feasible], "o", color="C0",
                label="each budget's answer (confirm level) at its metal area")
    if feasible:  # the front: the lowest FoM found with at most this much metal, up to the largest budget
        by_area = sorted(feasible, key=lambda r: r["area_m2"])
        best = list(np.minimum.accumulate([r["fom_mk"] for r in by_area]))
        ax.step([r["area_m2"] for r in by_area] + [max(r["budget_m2"] for r in feasible)], best + best[-1:],
                where="post", color="C0", lw=1.2, label="lowest FoM found with at most this much metal")
    if beside:
        ax.plot([r["area_m2"] for r in beside], [r["fom_mk"] for r in beside], "s--", color="0.5", mfc="none",
                label=beside_label)
    ans = [r for r in done if r.get("answer_fom_mk") is not None]
    if ans:  # drawn over the answers' circles, which lie a few mK away and hid them
        ax.plot([r["area_m2"] for r in ans], [r["answer_fom_mk"] for r in ans], "D", mfc="none", color="C1", mew=1.5,
                zorder=4, label=f"the same at the answer mesh ({ans[0]['answer_mesh_m']:g} m)")
    shown = [p for p in front.presets if p["preset"] != "pec" and p["fom_mk"] is not None]
    for p in shown:
        ax.plot(p["area_m2"], p["fom_mk"], "^", color="C3" if p.get("feasible") is not False else "0.6")
    for p in front.presets:
        if p["preset"] == "pec":
            ax.axhline(p["fom_mk"], color="k", ls="--", lw=1, label=f"blade over infinite PEC ({p['fom_mk']:.1f} mK)")
    ax.plot([], [], "^", color="C3", label="the paper's presets (grey: breaking the constraints)")
    for b in sorted({r["budget_m2"] for r in front.rows}):
        ax.axvline(b, color="0.85", lw=0.8, zorder=0)
    ax.set(xlabel="metal area (m$^2$)", ylabel="FoM, the search's objective (mK)", title="Metal vs chromaticity")
    fig.tight_layout()  # the axes' final place and limits, so the labels are spaced as they will be drawn
    on_page = ax.transData.transform([(p["area_m2"], p["fom_mk"]) for p in shown]) * 72.0 / fig.dpi if shown else []
    for p, dy in zip(shown, label_offsets([(float(x), float(y)) for x, y in on_page])):
        ax.annotate(p["preset"], (p["area_m2"], p["fom_mk"]), fontsize=7, xytext=(4, 2 + dy), textcoords="offset points")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return finish_figure(fig, path)


def convergence_curve(res: OptimiseResult) -> dict[str, Any]:
    """A search's best-so-far FoM after each solve (inf before the first feasible one), the solves
    of its local refinement and the stopping rule's tolerance: what the convergence figure draws."""
    solved = res.solved()
    best = np.array(best_so_far(solved), float)
    # with nothing feasible, what the stopping rule read instead: the least relative constraint violation
    violation = None if len(best) and np.isfinite(best[-1]) else np.array(least_violation_so_far(solved), float)
    return {"best": best, "tolerance": (res.stopping or {}).get("tolerance"), "violation": violation,
            "refine": [i for i, r in enumerate(solved) if str(r.get("phase", "")).startswith("refine")]}


def write_convergence(folder: Path, res: OptimiseResult) -> None:
    """``folder/convergence.json``: the search's curve as the stopping rule read it (rows refused on
    resume as refused), so a later run of other budgets draws this one beside its own."""
    c = convergence_curve(res)
    record = {"best_so_far_mk": [float(v) if np.isfinite(v) else None for v in c["best"]], "refine": c["refine"],
              "tolerance": c["tolerance"]}
    if c["violation"] is not None:
        record["least_violation_so_far"] = [float(v) if np.isfinite(v) else None for v in c["violation"]]
    with atomic_path(folder / "convergence.json", suffix=".tmp.json") as tmp:
        tmp.write_text(json.dumps(record))


def read_convergence(folder: Path) -> dict[str, Any] | None:
    """A budget's ``convergence.json`` as :func:`convergence_curve` (None when absent or unreadable:
    a folder from before it was written)."""
    try:
        got = json.loads((folder / "convergence.json").read_text())
        least = got.get("least_violation_so_far")
        return {"best": np.array([np.inf if v is None else v for v in got["best_so_far_mk"]], float),
                "refine": [int(i) for i in got.get("refine", [])], "tolerance": got.get("tolerance"),
                "violation": None if least is None else np.array([np.inf if v is None else v for v in least], float)}
    except (OSError, ValueError, KeyError, TypeError):
        return None


def convergence_curves(front: Front, out: Path | None = None) -> dict[float, dict[str, Any]]:
    """Per budget of the front, its search's curve: this run's searches, and the front's other
    budgets (kept from earlier runs) from ``out/budget-<A>/convergence.json``."""
    curves = {b: convergence_curve(res) for b, res in front.results.items()}
    for r in front.rows if out is not None else []:
        b = r["budget_m2"]
        if b not in curves and (got := read_convergence(out / f"budget-{b:g}")) is not None:
            curves[b] = got
    return curves


def convergence_figure(front: Front, path: Path, out: Path | None = None) -> Path:
    """Best-so-far FoM (search level) against solves, one line per budget (:func:`convergence_curves`),
    exploration and refinement marked: a flat second half says the search has stopped finding better designs.
    A budget with no feasible design gets its least constraint violation so far in a panel below (what its
    stopping rule read)."""
    from groundplane.plots import finish_figure, pyplot

    curves = convergence_curves(front, out)
    infeasible = {b: c for b, c in curves.items() if c.get("violation") is not None and len(c["violation"])
                  and np.isfinite(c["violation"][-1])}
    plt = pyplot()
    if infeasible:
        fig, (ax, low) = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    else:
        fig, ax = plt.subplots(figsize=(8, 4.5))
    for k, (b, c) in enumerate(sorted(curves.items())):
        _convergence_line(ax, c["best"], c, f"C{k}", f"{b:g} m$^2$")
        if b in infeasible:
            _convergence_line(low, 100 * c["violation"], c, f"C{k}", f"{b:g} m$^2$ (no feasible design)")
    bottom = low if infeasible else ax
    bottom.set_xlabel("solves (dots: local refinement; dotted: half the solves; band: the final best's flat tolerance)")
    ax.set(ylabel="best feasible FoM so far, search level (mK)", title="Search convergence per metal budget")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, title="budget")
    if infeasible:
        low.set_ylabel("least violation so far\n(% beyond the limit)")
        low.grid(alpha=0.3)
        low.legend(fontsize=8)
    return finish_figure(fig, path)


def _convergence_line(ax, y: np.ndarray, c: dict[str, Any], colour: str, label: str) -> None:
    """One budget's best-so-far curve, its refinement solves dotted, and its stopping rule drawn: the
    final value's tolerance band and the half of the solves it must lie before."""
    x = np.arange(1, len(y) + 1)
    ax.step(x, y, where="post", color=colour, label=label)
    if c["refine"]:
        ax.plot(x[c["refine"]], y[c["refine"]], ".", color=colour, ms=3)
    if len(y) and np.isfinite(y[-1]) and c["tolerance"] is not None:
        ax.axhspan(y[-1], y[-1] * (1 + c["tolerance"]), color=colour, alpha=0.12, lw=0)
        ax.axvline(len(y) / 2, color=colour, ls=":", lw=0.8)


def write_report(front: Front, out: Path, command: str, settings: EvalSettings, confirm: EvalSettings,
                 objective: str = "", reference: str | None = None, beside: str | None = None) -> Path:
    """pareto.md (with a provenance comment), the two figures, and each answer's STEP and outline.
    ``objective``: the scenarios and constraints in words; ``reference``: the preset each answer is
    set against (default: the best preset with no more metal); ``beside``: another run's front.csv
    or pareto.csv drawn beside this one."""
    from groundplane import cad
    from groundplane.shapes import from_dict

    other = read_front(beside) if beside else None
    pareto_figure(front, out / "pareto.png", other, f"beside: {beside}")
    convergence_figure(front, out / "convergence.png", out)
    for r in front.rows:
        if r["design"]:
            plane = from_dict(json.loads(r["design"]))
            cad.export(plane, out / f"answer-{r['budget_m2']:g}.step")
            cad.export(plane, out / f"answer-{r['budget_m2']:g}.svg")
            with atomic_path(out / f"answer-{r['budget_m2']:g}.json", suffix=".tmp.json") as tmp:  # --design FILE
                tmp.write_text(r["design"] + "\n")

    def pct(v: Any) -> str:
        return "-" if v is None or v == "" else f"{100 * float(v):.3f}"

    lines = [header("pareto", command, settings.identity(), confirm=confirm.identity()),
             "# Metal vs chromaticity: the optimised front", "", f"Command: `{command}` (resumable; every solve cached).",
             "", f"Search level: {settings.describe()}.", "", f"Confirm level (the presets too): {confirm.describe()}.", ""]
    lines += [f"Objective: {objective}.", ""] if objective else []
    lines += ["| budget (m^2) | area (m^2) | FoM, confirm level (mK) | worst member (mK) | mean of the members (mK) | "
              "largest ground loss (%) | feasible | search level (mK) | answer mesh (mK) | solves | best at solve | "
              "design |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in front.rows:
        ans = f"{cell(r.get('answer_fom_mk'))} ({r['answer_mesh_m']:g} m)" if r.get("answer_mesh_m") else "-"
        feas = "-" if r.get("feasible") is None else ("yes" if r["feasible"] else f"no: {r.get('violations')}")
        lines.append(f"| {r['budget_m2']:g} | {cell(r['area_m2'])} | {cell(r['fom_mk'])} | {cell(r.get('worst_fom_mk'))} | "
                     f"{cell(r.get('mean_fom_mk'))} | {pct(r.get('max_loss'))} | {feas} | {cell(r.get('search_fom_mk'))} | "
                     f"{ans} | {r['evaluations']} | {r.get('best_at') or '-'} | `{r['design'] or '-'}` |")
    lines += ["", "| preset | area (m^2) | FoM, confirm level (mK) | worst member (mK) | mean (mK) | largest ground loss "
              "(%) | feasible |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {p['preset']} | {p['area_m2']:.0f} | {cell(p['fom_mk'])} | {cell(p.get('worst_fom_mk'))} | "
              f"{cell(p.get('mean_fom_mk'))} | {pct(p.get('max_loss'))} | "
              f"{'-' if p.get('feasible') is None else ('yes' if p['feasible'] else 'no: ' + str(p.get('violations')))} |"
              for p in front.presets]
    lines += ["", "## Against the presets (computed from the rows)", "", *verdicts(front)]
    if reference:
        lines += ["", f"Against `{reference}` whatever the metal:", "", *verdicts(front, REFERENCE_BAR, reference)]
    if front.ladder:
        lines += ["", f"Fidelity ladder: {len(front.ladder)} designs the searches scored, spread over their FoM range, "
                  f"scored again at the confirm level (`ladder.csv`): Spearman **{cell(front.ladder_spearman, 2)}** "
                  "between the two levels."]
    lines += ["", "![FoM vs metal area](pareto.png)", "", "![convergence](convergence.png)", "",
              "Each budget's search (history, confirmations) is in `budget-<A>/`; its answer as `answer-<A>.step`, "
              "a 1:1 outline `answer-<A>.svg` and a design file `answer-<A>.json` (`--design` of every command)."]
    path = out / "pareto.md"
    with atomic_path(path, suffix=".tmp.md") as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return path
