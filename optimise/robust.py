"""Designs robust to the soil: the FoM over a grid of soils (the paper's section 5 ranges)
as the objective, its mean or its worst, and the nominal answer set beside the robust one
across the whole grid. Soil is uncertain at every site, and it changes with rain.
"""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any, Callable

import numpy as np

from groundplane import paper
from groundplane.design import Soil
from groundplane.errors import UserInputError
from groundplane.files import atomic_path
from groundplane.shapes import GroundPlane

from .evaluate import Candidate, EvalSettings, evaluate
from .provenance import header
from .report import cell
from .scenarios import NO_CONSTRAINTS, scenario_evaluator, soil_set
from .search import OptimiseResult, best_plane, optimise

# the corners of the paper's section 5 ranges (eps_r 2.5-5, sigma 0.005-0.05 S/m) and the MRO soil
SOIL_GRID: tuple[Soil, ...] = tuple(Soil(e, s) for e in (2.5, 5.0) for s in (0.005, 0.05)) + (
    Soil(paper.MRO_EPS_R, paper.MRO_SIGMA_S_PER_M),)
MODES: dict[str, Callable[[list[float]], float]] = {"mean": lambda v: float(np.mean(v)), "max": lambda v: float(np.max(v))}

Evaluate = Callable[[Candidate, EvalSettings], dict[str, Any]]


def over_soils(evaluate_fn: Evaluate, soils: tuple[Soil, ...], mode: str) -> Evaluate:
    """An objective that scores a candidate on every soil (each by ``evaluate_fn``) and returns
    their mean or worst as its FoM (the per-soil FoMs in ``per_member_mk``): the scenario
    module's evaluation of a soil set; failed on any soil is failed."""
    if mode not in MODES:
        raise UserInputError(f"--robust {mode}: choose one of {', '.join(MODES)}")
    return scenario_evaluator(soil_set(soils, {"mean": "mean", "max": "worst"}[mode]), NO_CONSTRAINTS,
                              member_fn=evaluate_fn)


def robust_study(shape: str, max_area: float, settings: EvalSettings, out_dir: str | Path, *, budget: int,
                 mode: str = "mean", soils: tuple[Soil, ...] = SOIL_GRID, evaluate_fn: Evaluate | None = None,
                 progress: bool = True, confirm_settings: EvalSettings | None = None,
                 compare: dict[str, GroundPlane] | None = None, **search: Any
                 ) -> tuple[OptimiseResult, OptimiseResult, list[dict[str, Any]]]:
    """The nominal search (``settings.soil``; ``out/nominal``) and the robust one (``out/robust``),
    then both answers (and the ``compare`` designs) scored on every soil of the grid at the
    confirm level. ``search``: the search's own options (algorithm, strategy, confirm_top, ...),
    the same for both searches."""
    out = Path(out_dir)
    base = evaluate_fn or (lambda c, s: evaluate(c, s, progress=progress))
    nominal = optimise(shape, max_area, settings, out / "nominal", budget=budget, evaluate_fn=base, progress=progress,
                       confirm_settings=confirm_settings, **search)
    robust = optimise(shape, max_area, settings, out / "robust", budget=budget, progress=progress,
                      evaluate_fn=over_soils(base, soils, mode), confirm_settings=confirm_settings,
                      objective={"soils": [[s.eps_r, s.sigma] for s in soils], "robust": mode}, **search)
    level = confirm_settings or settings
    table = []
    for soil in soils:
        row: dict[str, Any] = {"eps_r": soil.eps_r, "sigma": soil.sigma}
        planes = {which: best_plane(shape, res.best) if res.best else None
                  for which, res in (("nominal", nominal), ("robust", robust))}
        for which, plane in {**planes, **(compare or {})}.items():
            if plane is None:
                row[f"{which}_fom_mk"] = None
                continue
            name = f"{shape}-{which}" if which in planes else which
            r = base(Candidate(name, plane=plane), replace(level, soil=soil))
            row[f"{which}_fom_mk"] = r.get("lst_averaged_fom_mk") if r.get("status") == "ok" else None
        table.append(row)
    return nominal, robust, table


def write_robust_report(shape: str, max_area: float, mode: str, nominal: OptimiseResult, robust: OptimiseResult,
                        table: list[dict[str, Any]], path: Path, command: str, settings: EvalSettings) -> Path:
    """robust.md: both answers across the grid, with their mean and worst, compared (computed)."""
    def design(res: OptimiseResult) -> str:
        return json.dumps(res.best["params"]) if res.best else "-"

    compared = [k[:-len("_fom_mk")] for k in (table[0] if table else {})
                if k.endswith("_fom_mk") and k not in ("nominal_fom_mk", "robust_fom_mk")]

    lines = [header("robust", command, settings.identity(), mode=mode),
             f"# A soil-robust {shape} under {max_area:g} m^2 against the nominal one", "", f"Command: `{command}`.", "",
             f"Nominal: the best on eps_r {settings.soil.eps_r:g}, sigma {settings.soil.sigma:g} S/m: `{design(nominal)}`. "
             f"Robust: the best {mode} FoM over the grid below: `{design(robust)}`.", "",
             "Each is scored on every soil at the level in the provenance line"
             + (f", beside {', '.join(f'`{c}`' for c in compared)}." if compared else "."), "",
             "| eps_r | sigma (S/m) | nominal answer (mK) | robust answer (mK) |"
             + "".join(f" {c} (mK) |" for c in compared), "|---|---|---|---|" + "---|" * len(compared)]
    for r in table:
        lines.append(f"| {r['eps_r']:g} | {r['sigma']:g} | {cell(r['nominal_fom_mk'])} | {cell(r['robust_fom_mk'])} |"
                     + "".join(f" {cell(r[f'{c}_fom_mk'])} |" for c in compared))
    stats = {}
    for which in ("nominal", "robust"):
        v = [r[f"{which}_fom_mk"] for r in table if r[f"{which}_fom_mk"] is not None]
        stats[which] = (float(np.mean(v)), float(np.max(v))) if len(v) == len(table) else None
    if stats["nominal"] and stats["robust"]:
        (nm, nx), (rm, rx) = stats["nominal"], stats["robust"]
        lines += ["", "| | mean (mK) | worst (mK) |", "|---|---|---|", f"| nominal | {nm:.1f} | {nx:.1f} |",
                  f"| robust | {rm:.1f} | {rx:.1f} |", ""]
        k = 0 if mode == "mean" else 1
        better = (rm, rx)[k] < (nm, nx)[k]
        if nominal.best and robust.best and nominal.best["params"] == robust.best["params"]:
            lines.append(f"Both searches answer the same design: on this grid the nominal answer is also the best "
                         f"{mode} FoM the robust search found ({len(robust.history)} evaluations).")
        else:
            lines.append(f"The robust answer's {mode} over the grid is {(rm, rx)[k]:.1f} mK against the nominal "
                         f"answer's {(nm, nx)[k]:.1f}: " + ("lower, as its objective asks." if better else
                                                           "not lower: the robust search did not find a better "
                                                           "design for the grid than the nominal one."))
    lines += [line for c in compared for line in ("", beats_on_soils(table, "robust", c))]
    with atomic_path(path, suffix=".tmp.md") as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return path


def beats_on_soils(table: list[dict[str, Any]], which: str, other: str) -> str:
    """One computed sentence: on how many soils of the grid ``which``'s answer scores below ``other``."""
    pairs = [(r[f"{which}_fom_mk"], r[f"{other}_fom_mk"]) for r in table
             if r[f"{which}_fom_mk"] is not None and r[f"{other}_fom_mk"] is not None]
    if not pairs:
        return f"The {which} answer and `{other}` were not both scored on any soil."
    below = [1 - a / b for a, b in pairs if a < b]
    text = f"The {which} answer scores below `{other}` on {len(below)} of {len(pairs)} soils"
    if len(below) == len(pairs):
        return text + f": on every soil of the grid, by {100 * min(below):.0f}-{100 * max(below):.0f} %."
    return text + ": not on every soil, so it is not the better design whatever the soil."
