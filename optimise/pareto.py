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

from groundplane.design import Design, InfinitePEC
from groundplane.files import atomic_path, write_csv
from groundplane.fom import figure_of_merit
from groundplane.shapes import PRESETS, to_dict

from .evaluate import Candidate, EvalSettings, evaluate
from .provenance import header
from .report import cell
from .search import OptimiseResult, best_plane, family, optimise

LADDER_DESIGNS = 24  # designs scored at both levels to measure how well the cheap one ranks (>= 20)
PARETO_COLUMNS = ("budget_m2", "area_m2", "fom_mk", "mesh_m", "design", "evaluations", "search_fom_mk",
                  "search_mesh_m", "answer_fom_mk", "answer_mesh_m")


@dataclass
class Front:
    """What :func:`pareto_front` found: one row per budget, the presets and the PEC floor on
    the confirm level, the ladder's pairs and its Spearman."""

    rows: list[dict[str, Any]]
    presets: list[dict[str, Any]]
    ladder: list[dict[str, Any]] = field(default_factory=list)
    ladder_spearman: float | None = None
    results: dict[float, OptimiseResult] = field(default_factory=dict)


def _fom(candidate: Candidate, settings: EvalSettings, evaluate_fn) -> float | None:
    row = evaluate_fn(candidate, settings)
    return float(row["lst_averaged_fom_mk"]) if row.get("status") == "ok" else None


def pec_floor_mk(settings: EvalSettings) -> float:
    """The blade over infinite PEC on the same engine, mesh and FoM settings: no finite ground
    plane on soil does better in this model (the paper's Table 2 reference case)."""
    beam = settings.make_solver(progress=False).solve(Design(None, InfinitePEC()), settings.freqs_mhz)
    return float(figure_of_merit(beam, settings.fom).lst_averaged_fom_mk)


def preset_rows(confirm: EvalSettings, evaluate_fn, floor: Callable[[EvalSettings], float] = pec_floor_mk) -> list[dict]:
    """The nine Table 3 presets (and ``extended``) and the PEC floor (area 0) at the confirm level."""
    rows = [{"preset": name, "area_m2": plane.metal_area, "fom_mk": _fom(Candidate(name, plane=plane), confirm, evaluate_fn)}
            for name, plane in PRESETS.items()]
    return rows + [{"preset": "pec", "area_m2": 0.0, "fom_mk": floor(confirm)}]


def _answer(shape: str, budget_m2: float, res: OptimiseResult, confirm: EvalSettings, answer_mesh: float | None,
            evaluate_fn) -> dict[str, Any]:
    """One budget's row: its best (confirmed) design, and that design at the answer mesh."""
    best = res.best
    solves = sum(1 for r in res.history if r["status"] in ("ok", "failed"))
    if best is None:
        return {"budget_m2": budget_m2, "area_m2": None, "fom_mk": None, "mesh_m": confirm.spacing, "design": None,
                "evaluations": solves}
    plane = best_plane(shape, best)
    answer = _fom(Candidate(f"{shape}-answer-{budget_m2:g}", plane=plane), confirm.with_spacing(answer_mesh),
                  evaluate_fn) if answer_mesh else None
    return {"budget_m2": budget_m2, "area_m2": round(plane.metal_area, 3), "fom_mk": best["fom_mk"],
            "mesh_m": best.get("confirmed_at", best.get("mesh_m")), "design": json.dumps(to_dict(family(shape).cls.member(plane))),
            "evaluations": solves, "search_fom_mk": best.get("search_fom_mk", best["fom_mk"]),
            "search_mesh_m": best.get("mesh_m"), "answer_fom_mk": answer, "answer_mesh_m": answer_mesh}


def fidelity_ladder(shape: str, results: dict[float, OptimiseResult], confirm: EvalSettings, evaluate_fn,
                    count: int = LADDER_DESIGNS) -> tuple[list[dict], float | None]:
    """How well the search level ranks designs: ``count`` distinct designs the searches scored,
    spread over their FoM range, scored again at the confirm level; Spearman between the two."""
    from scipy.stats import spearmanr

    from .search import History, row_plane

    fam = family(shape)
    seen = {}
    for res in results.values():
        for r in res.history:
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


def pareto_front(shape: str, budgets: list[float], settings: EvalSettings, confirm: EvalSettings, out_dir: str | Path,
                 *, budget: int = 40, answer_mesh: float | None = None, ladder: int = LADDER_DESIGNS, confirm_top: int = 3,
                 evaluate_fn: Callable[[Candidate, EvalSettings], dict[str, Any]] | None = None,
                 executor: str = "local", scheduler: str | None = None, progress: bool = True,
                 floor: Callable[[EvalSettings], float] = pec_floor_mk) -> Front:
    """Search ``shape`` at each metal budget (``out/budget-<A>/``, each resumable; a design met
    again is a cache hit), confirm, answer; then the presets, the floor and the ladder."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    evaluate_fn = evaluate_fn or (lambda c, s: evaluate(c, s, progress=progress))
    results, rows = {}, []
    for b in sorted(budgets):
        if progress:
            print(f"pareto: budget {b:g} m^2", file=sys.stderr, flush=True)
        # the smaller budgets' answers fit this one too: scored first, so the front cannot rise with metal
        smaller = {f"answer at {a:g} m^2": best_plane(shape, r.best) for a, r in results.items() if r.best}
        res = optimise(shape, b, settings, out / f"budget-{b:g}", budget=budget, evaluate_fn=evaluate_fn,
                       progress=progress, confirm_settings=confirm, confirm_top=confirm_top, executor=executor,
                       scheduler=scheduler, seeds=smaller)
        results[b] = res
        rows.append(_answer(shape, b, res, confirm, answer_mesh, evaluate_fn))
        write_csv(out / "pareto.csv", rows, PARETO_COLUMNS)
    presets = preset_rows(confirm, evaluate_fn, floor)
    write_csv(out / "presets.csv", presets, ("preset", "area_m2", "fom_mk"))
    lad, rho = fidelity_ladder(shape, results, confirm, evaluate_fn, ladder) if ladder else ([], None)
    if lad:
        write_csv(out / "ladder.csv", lad, tuple(lad[0]))
    return Front(rows, presets, lad, rho, results)


def best_preset_within(presets: list[dict], area_m2: float) -> dict | None:
    """The lowest-FoM preset (not the PEC floor) using no more metal than ``area_m2``."""
    fit = [p for p in presets if p["preset"] != "pec" and p["fom_mk"] is not None
           and p["area_m2"] <= area_m2 * (1 + 1e-9)]
    return min(fit, key=lambda p: p["fom_mk"]) if fit else None


def verdicts(front: Front, target: float = 0.25) -> list[str]:
    """Per budget, computed from the rows: the answer against the best preset with no more
    metal (at least ``target`` lower is the issue's bar), and against the PEC floor."""
    floor = next(p["fom_mk"] for p in front.presets if p["preset"] == "pec")
    out = []
    for r in front.rows:
        if r["fom_mk"] is None:
            out.append(f"- {r['budget_m2']:g} m^2: no feasible design was scored.")
            continue
        ref = best_preset_within(front.presets, r["budget_m2"])
        head = f"- {r['budget_m2']:g} m^2: {r['fom_mk']:.1f} mK at {r['area_m2']:.0f} m^2 ({r['evaluations']} solves)"
        if ref is None:
            out.append(head + f"; no preset fits this budget; {r['fom_mk'] / floor:.2f} x the blade over infinite PEC.")
            continue
        gain = 1 - r["fom_mk"] / ref["fom_mk"]
        out.append(head + f" against {ref['preset']} {ref['fom_mk']:.1f} mK at {ref['area_m2']:.0f} m^2: "
                   + (f"{gain:.0%} lower, " + ("at least" if gain >= target else "short of") + f" {target:.0%}"
                      if gain > 0 else f"{-gain:.0%} higher: the search did not beat it")
                   + f"; {r['fom_mk'] / floor:.2f} x the blade over infinite PEC ({floor:.1f} mK)"
                   + (", below it: in this model the blade over PEC is no floor." if r["fom_mk"] < floor else "."))
    return out


def label_offsets(points: list[tuple[float, float]], near: tuple[float, float] = (60.0, 8.0),
                  step: float = 9.0) -> list[float]:
    """Vertical label offsets (points) so that labels of points closer than ``near`` (m^2, mK)
    stack instead of overprinting: each label goes above the ones already placed near it."""
    offsets: list[float] = [0.0] * len(points)
    placed: list[int] = []
    for i in sorted(range(len(points)), key=lambda k: points[k][1]):
        crowd = [j for j in placed if abs(points[j][0] - points[i][0]) < near[0]
                 and abs(points[j][1] - points[i][1]) < near[1]]
        offsets[i] = max((offsets[j] + step for j in crowd), default=0.0)
        placed.append(i)
    return offsets


def pareto_figure(front: Front, path: Path) -> Path:
    """FoM vs metal area: the front, the presets and the PEC floor on the same axes."""
    from groundplane.plots import finish_figure, pyplot

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 5))
    done = sorted((r for r in front.rows if r["fom_mk"] is not None), key=lambda r: r["budget_m2"])
    ax.plot([r["area_m2"] for r in done], [r["fom_mk"] for r in done], "o", color="C0",
            label="each budget's answer (confirm level) at its metal area")
    if done:  # the front: the lowest FoM found with at most this much metal, up to the largest budget
        by_area = sorted(done, key=lambda r: r["area_m2"])
        best = list(np.minimum.accumulate([r["fom_mk"] for r in by_area]))
        ax.step([r["area_m2"] for r in by_area] + [max(r["budget_m2"] for r in done)], best + best[-1:],
                where="post", color="C0", lw=1.2, label="lowest FoM found with at most this much metal")
    ans = [r for r in done if r.get("answer_fom_mk") is not None]
    if ans:
        ax.plot([r["area_m2"] for r in ans], [r["answer_fom_mk"] for r in ans], "s", mfc="none", color="C0",
                label=f"the same at the answer mesh ({ans[0]['answer_mesh_m']:g} m)")
    shown = [p for p in front.presets if p["preset"] != "pec" and p["fom_mk"] is not None]
    for p, dy in zip(shown, label_offsets([(p["area_m2"], p["fom_mk"]) for p in shown])):
        ax.plot(p["area_m2"], p["fom_mk"], "^", color="C3")
        ax.annotate(p["preset"], (p["area_m2"], p["fom_mk"]), fontsize=7, xytext=(4, 2 + dy), textcoords="offset points")
    for p in front.presets:
        if p["preset"] == "pec":
            ax.axhline(p["fom_mk"], color="k", ls="--", lw=1, label=f"blade over infinite PEC ({p['fom_mk']:.1f} mK)")
    ax.plot([], [], "^", color="C3", label="the paper's presets")
    for b in sorted({r["budget_m2"] for r in front.rows}):
        ax.axvline(b, color="0.85", lw=0.8, zorder=0)
    ax.set(xlabel="metal area (m$^2$)", ylabel="LST-averaged FoM (mK)", title="Metal vs chromaticity")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return finish_figure(fig, path)


def convergence_figure(front: Front, path: Path) -> Path:
    """Best-so-far FoM (search level) against solves, one line per budget, exploration and
    refinement marked: a flat second half says the search has stopped finding better designs."""
    from groundplane.plots import finish_figure, pyplot

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for k, (b, res) in enumerate(sorted(front.results.items())):
        solved = [r for r in res.history if r["status"] in ("ok", "failed")]
        best = np.minimum.accumulate([r["fom_mk"] if r["status"] == "ok" else np.inf for r in solved])
        x = np.arange(1, len(solved) + 1)
        ax.step(x, best, where="post", color=f"C{k}", label=f"{b:g} m$^2$")
        refine = [i for i, r in enumerate(solved) if str(r.get("phase", "")).startswith("refine")]
        if refine:
            ax.plot(x[refine], best[refine], ".", color=f"C{k}", ms=3)
    ax.set(xlabel="solves (dots: local refinement)", ylabel="best FoM so far, search level (mK)",
           title="Search convergence per metal budget")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, title="budget")
    return finish_figure(fig, path)


def write_report(front: Front, out: Path, command: str, settings: EvalSettings, confirm: EvalSettings) -> Path:
    """pareto.md (with a provenance comment), the two figures, and each answer's STEP and outline."""
    from groundplane import cad
    from groundplane.shapes import from_dict

    pareto_figure(front, out / "pareto.png")
    convergence_figure(front, out / "convergence.png")
    for r in front.rows:
        if r["design"]:
            plane = from_dict(json.loads(r["design"]))
            cad.export(plane, out / f"answer-{r['budget_m2']:g}.step")
            cad.export(plane, out / f"answer-{r['budget_m2']:g}.svg")
    lines = [header("pareto", command, settings.identity(), confirm=confirm.identity()),
             "# Metal vs chromaticity: the optimised front", "", f"Command: `{command}` (resumable; every solve cached).",
             "", f"Search level: {settings.describe()}.", "", f"Confirm level (the presets too): {confirm.describe()}.", "",
             "| budget (m^2) | area (m^2) | FoM, confirm level (mK) | search level (mK) | answer mesh (mK) | solves | design |",
             "|---|---|---|---|---|---|---|"]
    for r in front.rows:
        ans = f"{cell(r.get('answer_fom_mk'))} ({r['answer_mesh_m']:g} m)" if r.get("answer_mesh_m") else "-"
        lines.append(f"| {r['budget_m2']:g} | {cell(r['area_m2'])} | {cell(r['fom_mk'])} | "
                     f"{cell(r.get('search_fom_mk'))} | {ans} | {r['evaluations']} | `{r['design'] or '-'}` |")
    lines += ["", "| preset | area (m^2) | FoM, confirm level (mK) |", "|---|---|---|"]
    lines += [f"| {p['preset']} | {p['area_m2']:.0f} | {cell(p['fom_mk'])} |" for p in front.presets]
    lines += ["", "## Against the presets (computed from the rows)", "", *verdicts(front)]
    if front.ladder:
        lines += ["", f"Fidelity ladder: {len(front.ladder)} designs the searches scored, spread over their FoM range, "
                  f"scored again at the confirm level (`ladder.csv`): Spearman **{cell(front.ladder_spearman, 2)}** "
                  "between the two levels."]
    lines += ["", "![FoM vs metal area](pareto.png)", "", "![convergence](convergence.png)", "",
              "Each budget's search (history, confirmations) is in `budget-<A>/`; its answer as `answer-<A>.step` "
              "and a 1:1 outline `answer-<A>.svg`."]
    path = out / "pareto.md"
    with atomic_path(path, suffix=".tmp.md") as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return path
