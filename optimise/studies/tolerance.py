"""What building errors cost: a design against its as-built variants, each solved with the
same engine and FoM settings. Tooth bases off by 0.2 m (the paper's 4.8 m for 5 m), random
corner errors of +-5 and +-10 cm (a few seeded Monte-Carlo draws), the plate 1 and 5 cm above
the soil instead of 5 mm, a whole sheet missing at the edge, the antenna turned +-2 deg and
moved 10 cm off the centre (both as the plane moved under a fixed antenna). A variant that
breaks the mirror symmetry is solved as the whole model (about four times the work).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from groundplane.errors import SolveError, UserInputError
from groundplane.shapes import GroundPlane, from_file, preset, to_dict

from ..evaluate import Candidate, EvalSettings, evaluate
from ..provenance import header, write_md
from ..scenarios import (
    CORNER_ERRORS_M,
    OFFSET_M,
    TOOTH_BASE_ERROR_M,
    TURN_DEG,
    NotApplicable,
    ScenarioSet,
    as_built,
    check_not_overridden,
    missing_sheet,
    moved_corners,
    scenario_set,
)
from . import StudyOption, study
from ._common import verdict, write_csv

DEFAULT_DRAWS = 3
PLATE_HEIGHTS_M = (0.01, 0.05)


@dataclass(frozen=True)
class Variant:
    """One as-built variant: its group (the tolerance it belongs to), a label, the plane and
    the settings it is solved with."""

    group: str
    label: str
    plane: GroundPlane
    settings: EvalSettings


def variants(plane: GroundPlane, settings: EvalSettings, draws: int = DEFAULT_DRAWS,
             scenarios: ScenarioSet | None = None) -> list[Variant]:
    """The nominal design and its as-built variants (seeded: a rerun gives the same ones), built
    by the scenario module's as-built rules; with ``scenarios``, that set's members instead."""
    if scenarios is not None:
        check_not_overridden(scenarios, settings)  # --eps-r 3 with a set whose members set eps_r: refused
        out = []
        for m in scenarios.members:
            try:
                p, note = m.plane(plane)
            except NotApplicable:
                continue
            out.append(Variant(m.axis, m.name + (f" ({note})" if note else ""), p, m.settings(settings)))
        return out
    out = [Variant("nominal", "as designed", plane, settings)]
    d = to_dict(plane)
    if "tooth_base" in d:
        for sign in (-1, 1):
            base = d["tooth_base"] + sign * TOOTH_BASE_ERROR_M
            if base * d.get("teeth_per_side", 1) <= d["side"]:
                out.append(Variant("tooth base", f"tooth base {base:g} m (designed {d['tooth_base']:g})",
                                   as_built(plane, f"tooth-base:{sign * TOOTH_BASE_ERROR_M:g}")[0], settings))
    for err in CORNER_ERRORS_M:
        for k in range(draws):
            out.append(Variant(f"corners +-{err * 100:g} cm", f"draw {k + 1}", moved_corners(plane, err, k + 1),
                               settings))
    for h in PLATE_HEIGHTS_M:
        raised = replace(settings, model=replace(settings.model, plate_height=h))
        out.append(Variant("plate height", f"plate {h * 100:g} cm above the soil", plane, raised))
    missing = missing_sheet(plane)
    if missing is not None:
        out.append(Variant("missing sheet", missing[0], missing[1], settings))
    for turn in (-TURN_DEG, TURN_DEG):  # the antenna turned by +turn is the plane turned by -turn under it
        out.append(Variant("antenna turned", f"antenna turned {turn:+g} deg", as_built(plane, f"turned:{turn:g}")[0],
                           settings))
    for axis, (dx, dy) in (("along the excitation axis (x)", (OFFSET_M, 0)), ("across it (y)", (0, OFFSET_M))):
        out.append(Variant("antenna off centre", f"antenna {OFFSET_M * 100:g} cm off centre {axis}",
                           as_built(plane, f"offset:{dx:g}:{dy:g}")[0], settings))
    return out


def tolerance(out: Path, settings: EvalSettings, command: str, name: str = "extended",
              draws: int = DEFAULT_DRAWS, progress: bool = True, plane: GroundPlane | None = None,
              scenarios: ScenarioSet | None = None) -> list[dict]:
    """Solve and score every variant of ``plane`` (default: the preset ``name``; cached, so a rerun
    resumes), or with ``scenarios`` every member of that set after the design as given; write
    tolerance.md/.csv."""
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    nominal = None
    plane = preset(name) if plane is None else plane
    found = variants(plane, settings, draws, scenarios)
    if scenarios is not None and found[0].group != "nominal":
        found.insert(0, Variant("nominal", "as designed", plane, settings))
    for v in found:
        row = evaluate(Candidate(f"{v.group}: {v.label}", v.plane), v.settings, progress=progress)
        if row["status"] != "ok":
            raise SolveError(f"tolerance: solving {v.group} / {v.label} failed: {row.get('error')} (the rows "
                             f"before it are in {out / 'tolerance.csv'} and cached)")
        fom = row["lst_averaged_fom_mk"]
        nominal = fom if nominal is None else nominal
        rows.append({"group": v.group, "variant": v.label, "metal_area_m2": round(v.plane.metal_area, 3),
                     "fom_mk": round(fom, 2), "change_mk": round(fom - nominal, 2),
                     "change_percent": round(100 * (fom - nominal) / nominal, 2),
                     "max_ground_loss": row.get("max_ground_loss"),
                     "unknowns": row.get("n_unknowns"), "solver_cpu_s": row.get("solver_cpu_s")})
        write_csv(out / "tolerance.csv", rows)  # after each solve: an interrupted study keeps its rows
    write_md(out / "tolerance.md", markdown(rows, name, settings, command), "study tolerance", command, settings.identity())
    return rows


def group_summary(rows: list[dict]) -> list[dict]:
    """Per tolerance: mean and spread of the FoM change, and the largest change in size."""
    groups: dict[str, list[float]] = {}
    for r in rows[1:]:
        groups.setdefault(r["group"], []).append(r["change_percent"])
    return [{"group": g, "n": len(c), "mean_percent": float(np.mean(c)), "std_percent": float(np.std(c)),
             "largest_percent": float(max(c, key=abs))} for g, c in groups.items()]


def markdown(rows: list[dict], name: str, settings: EvalSettings, command: str) -> str:
    """The report: every variant, each tolerance's mean and spread, and which matters most."""
    lines = [header("study tolerance", command, settings.identity(), preset=name),
             f"# What building errors cost: `{name}` as built", "", f"Command: `{command}`", "",
             f"Settings: {settings.describe()}. Each variant is solved and scored with these settings (the plate "
             "height rows change only the plate's height). Corner errors move each outline corner by a uniform "
             "random amount in x and y (seeded draws); the antenna's turn and offset are solved as the plane "
             "turned or moved under it.", "",
             "| tolerance | variant | metal (m^2) | FoM (mK) | change (mK) | change (%) | largest ground loss in the fit "
             "band (%) | unknowns |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        loss = r.get("max_ground_loss")
        lines.append(f"| {r['group']} | {r['variant']} | {r['metal_area_m2']:.1f} | {r['fom_mk']:.1f} | "
                     f"{r['change_mk']:+.1f} | {r['change_percent']:+.1f} | "
                     f"{'-' if loss is None else f'{100 * loss:.3f}'} | {r['unknowns']} |")
    summary = group_summary(rows)
    lines += ["", "| tolerance | variants | mean change (%) | spread (std, %) | largest change (%) |", "|---|---|---|---|---|"]
    for s in summary:
        lines.append(f"| {s['group']} | {s['n']} | {s['mean_percent']:+.1f} | {s['std_percent']:.1f} | "
                     f"{s['largest_percent']:+.1f} |")
    if summary:
        worst = max(summary, key=lambda s: abs(s["largest_percent"]))
        others = [s for s in summary if s is not worst]
        second = max((abs(s["largest_percent"]) for s in others), default=0.0)
        lines += ["", "## Reading (computed from the rows)", "",
                  f"- The tolerance that matters most here is **{worst['group']}** (largest FoM change "
                  f"{worst['largest_percent']:+.1f} %); " + verdict(
                      abs(worst["largest_percent"]) >= 2 * second,
                      f"at least twice any other tolerance's (next: {second:.1f} %).",
                      f"the next is within a factor of two ({second:.1f} %), so their order is not settled by these "
                      "draws."),
                  "- " + verdict(all(abs(s["largest_percent"]) < 5 for s in summary),
                                 "Every as-built variant stays within 5 % of the design's FoM.",
                                 "Some as-built variants move the FoM by 5 % or more: "
                                 + ", ".join(f"{s['group']} ({s['largest_percent']:+.1f} %)" for s in summary
                                             if abs(s["largest_percent"]) >= 5) + ".")]
    return "\n".join(lines) + "\n"


def _known_preset(name: str) -> str:
    preset(name)  # an unknown name is refused here, before any solve
    return name


def _readable_design(path: Path) -> Path:
    from_file(path)  # a bad design file is refused here, before any solve
    return path


def _some_draws(n: int) -> int:
    if n < 1:
        raise UserInputError("--draws must be >= 1")
    return n


def _scenario_set(name: str) -> ScenarioSet:
    return scenario_set(name)  # an unknown set or a bad file: refused here


def _one_design(extra: dict) -> None:
    if extra.get("preset_name") is not None and extra.get("design") is not None:
        raise UserInputError("tolerance: give --preset or --design, not both")


@study("tolerance", "a design (--preset, default extended, or --design FILE) against its as-built variants: tooth "
       "base, corner errors, plate height, a missing sheet, the antenna turned and off centre", uses_settings=True,
       options=(StudyOption("--preset", "preset_name", "the design (default extended)", metavar="NAME",
                            check=_known_preset),
                StudyOption("--design", "design", "the design from a file instead of a preset (a shape JSON or an "
                            "optimiser's best.json)", Path, "FILE", check=_readable_design),
                StudyOption("--draws", "draws", "Monte-Carlo draws per corner error (default 3)", int, "N",
                            check=_some_draws),
                StudyOption("--scenarios", "scenarios", "score the design on this scenario set's members (soil, "
                            "model, as-built, field or a TOML file) instead of the study's own as-built variants",
                            metavar="SET|FILE", check=_scenario_set)),
       validate=_one_design)
def _run(out: Path, settings: EvalSettings, command: str, preset_name: str = "extended",
         draws: int = DEFAULT_DRAWS, design: Path | None = None, scenarios: ScenarioSet | None = None) -> None:
    plane = from_file(design) if design is not None else None
    name = preset_name
    if plane is not None:
        d = to_dict(plane)
        name = f"{design}: {d.pop('shape')} " + ", ".join(
            f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in d.items())
    for r in tolerance(out, settings, command, name, draws, plane=plane, scenarios=scenarios):
        print(f"{r['group']:20s} {r['variant']:52s} {r['fom_mk']:8.1f} mK  {r['change_percent']:+6.1f} %")
