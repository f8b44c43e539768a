"""``groundplane sweep``, ``groundplane optimise`` and ``groundplane study``."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from groundplane.cli import CLIError, command, invocation
from groundplane.files import check_output_dir
from groundplane.fom import FomSettings
from groundplane.options import add_options, from_args, options
from solvers.cli import add_solve_options, solve_option_groups, solve_options

if TYPE_CHECKING:
    from .evaluate import EvalSettings


FOM_GROUP = "Figure of Merit (defaults: the paper's)"


def eval_option_groups() -> list[tuple[str, type]]:
    """(title, settings dataclass) of every option a command that solves and scores takes."""
    return [*solve_option_groups(), (FOM_GROUP, FomSettings)]


def add_eval_options(p: argparse.ArgumentParser) -> None:
    """Every solver and FoM option (generated from the settings dataclasses)."""
    add_solve_options(p)
    add_options(p, FomSettings, FOM_GROUP)


SCENARIO_GROUP = ("scenarios and constraints (default: the soil set, its worst member, ground loss <= 0.5 %; "
                  "--scenarios nominal --max-loss none is the paper's objective, what results/pareto answers)")


def add_scenario_options(p: argparse.ArgumentParser) -> None:
    """--scenarios, --aggregate, --max-loss, --max-loss-spread (from ScenarioOptions)."""
    from .scenarios import ScenarioOptions

    add_options(p, ScenarioOptions, SCENARIO_GROUP)


def scenario_options(args: argparse.Namespace):
    """The ScenarioOptions the command line gives (defaults where it gives none)."""
    from .scenarios import ScenarioOptions

    return from_args(ScenarioOptions, args)


def eval_settings(args: argparse.Namespace) -> EvalSettings:
    """EvalSettings from the parsed command line (options not given take the dataclass defaults)."""
    from .evaluate import EvalSettings  # here: the engines load only for a command that solves

    soil, solve, model = solve_options(args)
    return EvalSettings(soil=soil, solve=solve, model=model, fom=from_args(FomSettings, args))


@command("sweep", "solve, score and rank the candidates of a TOML file (resumable)")
def _setup_sweep(p: argparse.ArgumentParser):
    p.add_argument("config", help="sweep TOML (see optimise/sweep.py for the format)")
    p.add_argument("-o", "--out", default=None,
                   help="output folder (default: ./sweep-<config name> in the working directory)")
    p.add_argument("--executor", choices=["local", "dask"], default="local")
    p.add_argument("--scheduler", help="Dask scheduler address (default: a local cluster)")
    p.add_argument("--retry-failed", action="store_true", help="solve failed candidates again")
    from .scenarios import ScenarioOptions

    add_options(p, ScenarioOptions, "scenarios and constraints (over the file's [scenarios] table; a sweep without "
                "either scores at the settings as given, with no loss limit)")
    return _run_sweep_cmd


def _run_sweep_cmd(args: argparse.Namespace) -> int:
    from .report import write_report
    from .scenarios import ScenarioOptions, check_set, describe_set
    from .sweep import load_config, load_scenarios, run_sweep, summary_table

    candidates, invalid, settings = load_config(args.config)
    given = {o.key: getattr(args, o.key) for o in options(ScenarioOptions) if getattr(args, o.key, None) is not None}
    opts = load_scenarios(args.config, given)
    scenarios, constraints = (opts.set(), opts.constraints()) if opts else (None, None)
    if scenarios is not None:
        check_set(scenarios, settings)
    out = check_output_dir(Path(args.out) if args.out else Path.cwd() / f"sweep-{Path(args.config).stem}")
    rows = run_sweep(candidates, settings, out, invalid=invalid, executor=args.executor,
                     scheduler=args.scheduler, retry_failed=args.retry_failed, progress=True, scenarios=scenarios,
                     constraints=constraints)
    objective = f" Objective: {describe_set(scenarios, constraints)}." if scenarios else ""
    paths = write_report(rows, out, title=f"Sweep {Path(args.config).name}",
                         preamble=f"Command: `{invocation()}`. Settings: {settings.describe()}.{objective}")
    print(summary_table(rows))
    print(f"report: {paths['md']}")
    failed = [r["name"] for r in rows if r.get("status") == "failed"]
    if failed:
        print(f"sweep: {len(failed)} candidate(s) failed ({', '.join(failed[:5])}{' ...' if len(failed) > 5 else ''}); "
              "their errors are in the report; rerun with --retry-failed to solve them again", file=sys.stderr)
        return 1
    return 0


def _add_stage_options(p: argparse.ArgumentParser) -> None:
    """How a search spends its solves: the global stage's share, the build tolerance."""
    p.add_argument("--explore", type=int, metavar="N",
                   help="solves of the global stage: the seeds and presets first, then a space-filling sample "
                        "(default 60 %% of --budget); as many as --seed's designs: refine another search's best "
                        "designs (e.g. at a finer --mesh) without exploring again")
    p.add_argument("--build-tolerance", type=float, metavar="F",
                   help="a design whose every parameter lies within F of its range of a solved design is that design "
                        "(its row, no solve): a crew builds the two alike, and on a coarse mesh their FoMs differ by "
                        "remeshing alone (e.g. 0.001: 2.6 cm on teeth-xy's side; default: every design solved)")


@command("optimise", "nlopt search of a shape family under a metal-area budget")
def _setup_optimise(p: argparse.ArgumentParser):
    from .search import optimisable

    p.add_argument("--shape", required=True, choices=optimisable())
    area = p.add_mutually_exclusive_group(required=True)
    area.add_argument("--max-area", type=float, help="metal budget, m^2")
    area.add_argument("--pareto", type=float, nargs="+", metavar="A",
                      help="the front: the best design at each of these metal budgets (m^2), beside the paper's "
                           "presets and the blade over infinite PEC; writes front.csv, presets.csv, ladder.csv, "
                           "pareto.md and figures (after every budget is searched)")
    p.add_argument("--strategy", choices=["global", "local"], default="global",
                   help="global (default): the family's presets and a space-filling sample, then local refinement "
                        "of the best few; local: the algorithm from one start per integer value")
    p.add_argument("--algorithm", default="LN_COBYLA", help="nlopt algorithm taking constraints (default LN_COBYLA)")
    p.add_argument("--budget", type=int, default=30, help="solves per search, across every integer value (default 30)")
    _add_stage_options(p)
    p.add_argument("--executor", choices=["local", "dask"], default="local",
                   help="dask: solve the exploration's designs in parallel on a cluster first")
    p.add_argument("--scheduler", help="Dask scheduler address (default: a local cluster)")
    p.add_argument("--answer-mesh", type=float, metavar="SPACING",
                   help="--pareto: re-solve each budget's answer at this finer mesh (default 0.7 x the confirm mesh)")
    p.add_argument("--soil-grid", action="store_true",
                   help="--max-area: also search for the design with the best FoM over the paper's section 5 soils "
                        "(eps_r 2.5-5 x sigma 0.005-0.05 S/m corners and the MRO soil) and write robust.md: both "
                        "answers across the grid")
    p.add_argument("--robust", choices=["mean", "max"], default="mean",
                   help="--soil-grid: minimise the mean (default) or the worst FoM over the soils")
    p.add_argument("--ladder", type=int, default=24, metavar="N",
                   help="--pareto: score N of the searched designs at the confirm level too, to measure how well the "
                        "search level ranks (default 24; 0: don't)")
    p.add_argument("--integers", type=int, nargs="+", help="values of the family's integer parameter to try")
    p.add_argument("--seed", nargs="+", default=[], metavar="FILE.json",
                   help="designs the search scores first (e.g. another search's best.json); each must be a member of "
                        "--shape's family and fit the budget (with --pareto: each budget scores the seeds that fit it, "
                        "after the smaller budgets' answers, and a seed must fit the largest)")
    p.add_argument("--compare", nargs="*", default=[], metavar="PRESET|FILE.json",
                   help="designs scored with the same settings (with --soil-grid: on every soil): preset names or "
                        "design files (an optimiser's best.json)")
    p.add_argument("--step", action="store_true", help="write the best design's STEP")
    p.add_argument("--confirm-mesh", type=float, default=None, metavar="SPACING",
                   help="re-solve the best few at this finer mesh before answering (default 0.7 x the search "
                        "mesh; with --pareto the engine's default mesh, on the fit band at 1 MHz: the default "
                        "model, where the presets are scored too; 0: don't)")
    p.add_argument("--confirm-top", type=int, default=3, help="how many of the best to re-solve (default 3)")
    p.add_argument("--max-budget", type=int, metavar="N",
                   help="after --budget solves, go on refining from the best until the best so far lies in the first "
                        "half of the solves (the stopping rule every report states), at most N solves in all "
                        "(default: --budget)")
    p.add_argument("--reference", metavar="PRESET",
                   help="--pareto: also set every budget's answer against this preset whatever its metal "
                        "(e.g. sawtooth-20-16), with a 15 %% bar")
    p.add_argument("--beside", metavar="FRONT.csv", help="--pareto: draw another run's front (front.csv or pareto.csv) "
                   "beside this one (e.g. results/pareto/pareto.csv, the nominal front)")
    add_scenario_options(p)
    add_eval_options(p)
    p.add_argument("-o", "--out", required=True)
    return _run_optimise


def _run_pareto(args: argparse.Namespace, seeds: dict | None = None) -> int:
    from groundplane.options import parse_freqs

    from .pareto import REFERENCE_BAR, pareto_front, verdicts, write_report

    if any(not (a > 0) for a in args.pareto):
        raise CLIError(f"--pareto: metal budgets must be positive m^2, got {args.pareto}")
    if args.reference:
        from groundplane.shapes import preset

        preset(args.reference)  # an unknown name refused before any solve
    if args.beside:
        from .pareto import read_front

        try:
            read_front(args.beside)
        except (OSError, KeyError, ValueError) as exc:
            raise CLIError(f"--beside {args.beside}: not a front table ({exc})") from None
    settings = eval_settings(args)
    mesh = args.confirm_mesh or getattr(settings.model.__class__(), "spacing", None)
    confirm = settings.with_solve(freqs_mhz=tuple(parse_freqs("fit-band")))
    confirm = confirm.with_spacing(mesh) if mesh else confirm
    answer = args.answer_mesh if args.answer_mesh is not None else (round(0.7 * mesh, 3) if mesh else None)
    out = Path(args.out)
    opts = scenario_options(args)
    scenarios, constraints = opts.set(), opts.constraints()
    from .scenarios import check_set, describe_set

    check_set(scenarios, settings)  # a member the engine cannot take: refused before any solve
    front = pareto_front(args.shape, args.pareto, settings, confirm, out, budget=args.budget, answer_mesh=answer or None,
                         ladder=args.ladder, confirm_top=args.confirm_top, executor=args.executor,
                         scheduler=args.scheduler, scenarios=scenarios, constraints=constraints,
                         max_budget=args.max_budget, seeds=seeds, explore=args.explore,
                         build_tolerance=args.build_tolerance)
    path = write_report(front, out, invocation(), settings, confirm, objective=describe_set(scenarios, constraints),
                        reference=args.reference, beside=args.beside)
    print("\n".join(verdicts(front)))
    if args.reference:  # the bar the report also states
        print(f"against {args.reference} whatever the metal:\n"
              + "\n".join(verdicts(front, REFERENCE_BAR, args.reference)))
    print(f"report: {path}")
    return 0 if all(r["fom_mk"] is not None for r in front.rows) else 1


def _search_options(args: argparse.Namespace, seeds: dict | None = None) -> dict:
    """The search's own flags, for every kind of search (one place, so none is silently dropped)."""
    return {"algorithm": args.algorithm, "strategy": args.strategy, "confirm_top": args.confirm_top,
            "integer_values": tuple(args.integers) if args.integers else None, "executor": args.executor,
            "scheduler": args.scheduler, "seeds": seeds or None, "explore": args.explore,
            "build_tolerance": args.build_tolerance}


def _seeds(args: argparse.Namespace) -> dict:
    """The --seed designs, read once and refused (by search.check_seeds) before any solve."""
    from groundplane.shapes import from_file

    from .search import check_seeds, family, integer_choices

    seeds = {f: from_file(f) for f in args.seed}
    fam = family(args.shape)
    largest = max(args.pareto) if args.pareto else args.max_area  # --pareto: each budget takes the seeds that fit it
    check_seeds(fam, largest, integer_choices(fam, args.integers), seeds, args.strategy)
    return seeds


def compare_plane(name: str):
    """A ``--compare`` entry: a preset by name, or a design file (ends in .json)."""
    from groundplane.shapes import from_file, preset

    return from_file(name) if name.endswith(".json") else preset(name)


def _run_robust(args: argparse.Namespace, compared: dict | None = None, seeds: dict | None = None) -> int:
    from .robust import robust_study, write_robust_report

    given = [f for f in ("--scenarios", "--aggregate", "--max-loss", "--max-loss-spread")
             if getattr(args, f[2:].replace("-", "_"), None) is not None]
    if given:
        raise CLIError(f"--soil-grid runs its own two searches (the nominal soil, the mean or worst over the grid); "
                       f"{', '.join(given)} is for a search on a scenario set: drop --soil-grid")

    settings = eval_settings(args)
    out = Path(args.out)
    spacing = settings.spacing
    confirm = args.confirm_mesh if args.confirm_mesh is not None else (round(0.7 * spacing, 3) if spacing else None)
    fine = settings.with_spacing(confirm) if confirm else None
    nominal, robust, table = robust_study(args.shape, args.max_area, settings, out, budget=args.budget,
                                          mode=args.robust, confirm_settings=fine, compare=compared or {},
                                          **_search_options(args, seeds))
    path = write_robust_report(args.shape, args.max_area, args.robust, nominal, robust, table, out / "robust.md",
                               invocation(), fine or settings)
    print(path.read_text().split("\n")[-2])
    print(f"report: {path}")
    return 0 if nominal.best and robust.best else 1


def _run_optimise(args: argparse.Namespace) -> int:
    from groundplane.plots import pyplot

    from .evaluate import Candidate
    from .report import write_report
    from .search import best_plane, optimise

    if not args.pareto and (args.reference or args.beside):  # they were accepted and ignored
        raise CLIError(f"{'--reference' if args.reference else '--beside'} goes with --pareto (a front's answers "
                       "set against a preset, another front drawn beside); a single search has neither")
    compared = {name: compare_plane(name) for name in args.compare}  # refused before the search, not after it
    seeds = _seeds(args)
    check_output_dir(args.out)
    if args.pareto:
        return _run_pareto(args, seeds)
    if args.soil_grid:
        return _run_robust(args, compared, seeds)
    settings = eval_settings(args)
    out = Path(args.out)
    spacing = settings.spacing
    confirm = args.confirm_mesh if args.confirm_mesh is not None else (round(0.7 * spacing, 3) if spacing else None)
    opts = scenario_options(args)
    scenarios, constraints = opts.set(), opts.constraints()
    from .scenarios import check_set, describe_set, scenario_evaluator

    check_set(scenarios, settings)  # a member the engine cannot take: refused before any solve
    res = optimise(args.shape, args.max_area, settings, out, budget=args.budget, progress=True,
                   confirm_mesh=confirm or None, scenarios=scenarios, constraints=constraints,
                   max_budget=args.max_budget, **_search_options(args, seeds))
    if res.best and res.best.get("confirmed_at"):  # the answer and the presets at the mesh it holds at
        settings = settings.with_spacing(res.best["confirmed_at"])
    score = scenario_evaluator(scenarios, constraints, progress=True)
    rows = [score(Candidate(name, plane=plane), settings) for name, plane in compared.items()]
    if res.best or res.closest:
        best = best_plane(args.shape, res.best or res.closest)
        rows.append(score(Candidate(f"optimised {args.shape}", plane=best), settings))
        if args.step:
            from groundplane.cad import export_step

            export_step(best, out / "best.step")
    _history_plot(pyplot(), res.history, out / "history.png", args.max_area)
    mesh = (f"the {settings.spacing:g} m mesh" + (" (re-solved there from the search's best few)"
                                                 if res.confirmed else "")) if settings.spacing else settings.engine
    verdict = _verdict(rows, args, mesh) + " " + stopping_sentence(res.stopping)
    paths = write_report(rows, out, title=f"Optimised {args.shape} under {args.max_area:g} m^2",
                         preamble=f"Command: `{invocation()}`. Settings: {settings.describe()}. Objective: "
                                  f"{describe_set(scenarios, constraints)}. "
                                  f"{len(res.history)} evaluations in history.jsonl. {verdict}")
    print(verdict)
    print(f"report: {paths['md']}")
    return 0 if res.best else 1


def stopping_sentence(stop: dict) -> str:
    """The stopping rule's reading, computed from the search's rows."""
    from .search import best_plane_clause

    if not stop or not stop.get("solves"):
        return ""
    if not stop.get("best_at"):
        return f"No feasible design in {stop['solves']} solves." + restarts_clause(stop)
    within = flat_within(stop)
    if stop.get("measure") == "violation":
        return (f"No feasible design in {stop['solves']} solves; the least violation so far was found at solve "
                f"{stop['best_at']}{within}: " + ("flat over the last half." if stop["flat"] else "**not** flat over "
                                                  "the last half.") + restarts_clause(stop))
    return (f"The best so far was found at solve {stop['best_at']} of {stop['solves']}{within}: "
            + ("flat over the last half." if stop["flat"] else "**not** flat over the last half (the search had not "
               "converged; --max-budget lets it go on).") + best_plane_clause(stop) + restarts_clause(stop))


def restarts_clause(stop: dict) -> str:
    """How often a refinement round solved nothing from its start (the next started elsewhere), and
    whether the family ran out of designs to solve, as sentences; empty when neither happened."""
    n = stop.get("barren_starts") or 0
    out = (f" {n} refinement round{'s' if n != 1 else ''} solved nothing from {'their' if n != 1 else 'its'} start "
           "(every plane proposed invalid, over the budget or met already); the next started from another design."
           if n else "")
    if stop.get("exhausted"):
        out += (f" The search stopped at {stop['solves']} solves: no design of a fresh space-filling draw was left "
                "that it had not met and could solve.")
    return out


def flat_within(stop: dict) -> str:
    """The stopping rule's tolerance as a clause: the search level's measured scatter when that set it."""
    tol, scatter = stop.get("tolerance"), stop.get("scatter")
    if tol is None:
        return ""
    if scatter is not None and scatter >= tol:
        return (f" (within {100 * tol:.1f} %, the median FoM difference of {stop.get('scatter_pairs')} pairs of "
                "near-identical designs: the search level's own scatter)")
    return f" (within {100 * tol:.1f} %)"


def _verdict(rows, args, mesh: str) -> str:
    ok = {r["name"]: r for r in rows if r.get("status") == "ok"}
    best = ok.get(f"optimised {args.shape}")
    if best is None:
        return "No design was scored."
    if best.get("feasible") is False:
        return (f"No feasible {args.shape} was found; the closest, {best['lst_averaged_fom_mk']:.1f} mK at "
                f"{best['metal_area_m2']:.1f} m^2, breaks: {'; '.join(best.get('violations', []))}.")
    text = (f"Best {args.shape}: {best['lst_averaged_fom_mk']:.1f} mK at {best['metal_area_m2']:.1f} m^2 "
            f"({json.dumps(best['params'])}), solved at {mesh}.")
    for name in args.compare:
        if name in ok:
            r = ok[name]
            better = best["lst_averaged_fom_mk"] < r["lst_averaged_fom_mk"]
            text += (f" {name}: {r['lst_averaged_fom_mk']:.1f} mK at {r['metal_area_m2']:.0f} m^2 -> the optimiser "
                     f"{'found a lower' if better else 'did not find a lower'} FoM with these settings.")
    return text


def _history_plot(plt, history, path: Path, max_area: float) -> None:
    ok = [(i, r) for i, r in enumerate(history, 1) if r["status"] == "ok"]
    if not ok:
        return
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    a.plot([i for i, _ in ok], [r["fom_mk"] for _, r in ok], "o-", ms=3)
    a.set_xlabel("evaluation")
    a.set_ylabel("LST-averaged FoM (mK)")
    a.grid(alpha=0.3)
    sc = b.scatter([r["area_m2"] for _, r in ok], [r["fom_mk"] for _, r in ok], c=[i for i, _ in ok], s=12)
    b.axvline(max_area, color="k", ls="--", lw=0.8)
    b.set_xlabel("metal area (m$^2$)")
    b.set_ylabel("FoM (mK)")
    b.grid(alpha=0.3)
    fig.colorbar(sc, ax=b, label="evaluation")
    from groundplane.plots import finish_figure

    finish_figure(fig, path, dpi=100)  # a full disk: one line naming the file, not a traceback


@command("score", "solve a design on every member of a scenario set and score it: each member's FoM and ground "
         "loss, the set's aggregate, the constraints and how far each uncertainty moves the FoM")
def _setup_score(p: argparse.ArgumentParser):
    from groundplane.cli import add_shape_options

    add_shape_options(p)
    add_scenario_options(p)
    add_eval_options(p)
    p.add_argument("--json", action="store_true", help="print the row as a JSON object")
    p.add_argument("-o", "--out", help="also write report.md/.html, results.json/.csv and figures into this folder")
    return _run_score


def _run_score(args: argparse.Namespace) -> int:
    from groundplane.cli import shape_from_args
    from groundplane.errors import SolveError

    from .evaluate import Candidate
    from .report import write_report
    from .scenarios import check_set, describe_set, evaluate_scenarios, member_table, sensitivity

    plane = shape_from_args(args)
    settings = eval_settings(args)
    opts = scenario_options(args)
    scenarios, constraints = opts.set(), opts.constraints()
    settings.check_scorable()
    check_set(scenarios, settings, plane)  # every member buildable and solvable, before any solve
    out = check_output_dir(Path(args.out)) if args.out else None
    name = args.preset or (Path(args.design).stem if getattr(args, "design", None) else plane.kind)
    row = evaluate_scenarios(Candidate(name, plane=plane), settings, scenarios, constraints, progress=True)
    if row["status"] != "ok":
        raise SolveError(f"{name}: {row.get('error')}")
    if out is not None:
        write_report([row], out, title=f"{name} on the scenario set {scenarios.name}",
                     preamble=f"Command: `{invocation()}`. Settings: {settings.describe()}. Objective: "
                              f"{describe_set(scenarios, constraints)}.")
    if args.json:
        print(json.dumps(row, default=float))
        return 0
    print(f"{name} ({plane.metal_area:.1f} m^2) on {describe_set(scenarios, constraints)}")
    print("\n".join(member_table(row)))
    loss = row.get("max_loss")
    print(f"{scenarios.aggregate} of {len(row['members'])} members: {row['lst_averaged_fom_mk']:.2f} mK (worst "
          f"{row['worst_fom_mk']:.2f}, mean {row['mean_fom_mk']:.2f}); largest ground loss on the soil members "
          + ("-" if loss is None else f"{100 * loss:.3f} %")
          + ("" if row.get("loss_spread") is None else f", spread across them {100 * row['loss_spread']:.3f} %"))
    print("meets the constraints" if row["feasible"] else "breaks: " + "; ".join(row["violations"]))
    if (sens := sensitivity(row)) is not None:
        print("\n".join(sens.verdicts()))
    if row.get("skipped_members"):
        print(f"not applicable to this design: {', '.join(row['skipped_members'])}")
    if out is not None:
        print(f"report: {out / 'report.md'}")
    return 0


@command("fabricate", "cut a design from welded wire-mesh sheets: DXF outline, sheet plan, cut list, mass")
def _setup_fabricate(p: argparse.ArgumentParser):
    from groundplane.cli import add_shape_options

    add_shape_options(p)
    from groundplane.fabricate import MeshSheet

    add_options(p, MeshSheet, "mesh sheets")
    p.add_argument("--snap-to-sheet", action="store_true",
                   help="plan the nearest design whose teeth are whole half-sheet widths instead, and solve both "
                        "(the solver and FoM options below) to report the metal and FoM change (snap.json)")
    add_eval_options(p)
    p.add_argument("-o", "--out", required=True, help="output folder")
    return _run_fabricate


def _run_fabricate(args: argparse.Namespace) -> int:
    from groundplane import fabricate as fab
    from groundplane.cli import shape_from_args

    plane = shape_from_args(args)
    sheet = from_args(fab.MeshSheet, args)
    out = check_output_dir(Path(args.out))
    snap = None
    if args.snap_to_sheet:
        snapped, moved = fab.snap_to_sheet(plane, sheet)
        snap = _snap_report(plane, snapped, moved, eval_settings(args), out)
        plane = snapped
    summary = fab.write_plan(fab.plan_sheets(plane, sheet, progress=True), out, invocation())
    print(f"{summary['design']}: {summary['sheets_bought']} sheets ({summary['sheets_full']} whole, "
          f"{summary['sheets_cut']} cut), waste {summary['waste_percent']:.1f} %, seams {summary['seam_length_m']:.1f} m, "
          f"mesh {summary['mass_kg']:.0f} kg; outline.dxf, plan.png/.svg, cutlist.csv, plan.json in {out}")
    if snap:
        print(snap)
    return 0


def _snap_report(plane, snapped, moved: dict, settings: "EvalSettings", out: Path) -> str:
    """Solve the design and its buildable neighbour with the same settings; snap.json; one line."""
    from groundplane.errors import SolveError
    from groundplane.files import atomic_path
    from groundplane.shapes import to_dict

    from .evaluate import Candidate, evaluate

    if not moved:
        return f"--snap-to-sheet: {plane.describe()} is already cut from whole half-sheet widths; nothing moved"
    rows = [evaluate(Candidate(name, p), settings, progress=True) for name, p in (("as designed", plane), ("snapped", snapped))]
    bad = [r for r in rows if r["status"] != "ok"]
    if bad:
        raise SolveError(f"--snap-to-sheet: solving the {bad[0]['name']} plane failed: {bad[0].get('error')}")
    d_area = snapped.metal_area - plane.metal_area
    fom = [r["lst_averaged_fom_mk"] for r in rows]
    d_fom = fom[1] - fom[0]
    report = {"designed": to_dict(plane), "snapped": to_dict(snapped), "moved": {k: list(v) for k, v in moved.items()},
              "metal_area_m2": [plane.metal_area, snapped.metal_area], "fom_mk": fom,
              "settings": settings.describe(), "command": invocation()}
    with atomic_path(out / "snap.json", suffix=".tmp.json") as tmp:
        tmp.write_text(json.dumps(report, indent=1))
    what = ", ".join(f"{k} {a:g} -> {b:g} m" for k, (a, b) in moved.items())
    return (f"snapped to the sheet: {what}; metal {plane.metal_area:.1f} -> {snapped.metal_area:.1f} m^2 ({d_area:+.1f}); "
            f"FoM {fom[0]:.1f} -> {fom[1]:.1f} mK ({d_fom:+.1f}, {100 * d_fom / fom[0]:+.1f} %)")


@command("study", "run a study: the paper's reproductions (design-study, soil-sweep) and the model studies")
def _setup_study(p: argparse.ArgumentParser):
    from .studies import STUDIES, study_options

    p.add_argument("name", nargs="?", choices=sorted(STUDIES),
                   help="; ".join(f"{k}: {s.help}" for k, s in sorted(STUDIES.items())))
    p.add_argument("--check", action="store_true",
                   help="list the reports under -o (default ./results) that an engine's model change has made stale, "
                        "with the command that regenerates each")
    p.add_argument("-o", "--out", default=None, help="output folder (default: ./<study name> in the working directory)")
    for flag, (o, names) in sorted(study_options().items()):  # each study's own flags, from its registry entry
        kw = {"action": "store_true"} if o.switch else {"type": o.type, "metavar": o.metavar}
        p.add_argument(flag, dest=f"study_{o.into}", default=None, help=f"{', '.join(names)}: {o.help}", **kw)
    add_eval_options(p)
    return _run_study_cmd


def _run_study_cmd(args: argparse.Namespace) -> int:
    from groundplane.design import Soil

    from .studies import STUDIES, run_study, study_options

    if args.check:
        return _check_results(Path(args.out or "results"))
    if args.name is None:
        raise CLIError("name a study (or --check the committed results)")
    s = STUDIES[args.name]
    extra = {}
    for flag, (o, names) in study_options().items():
        value = getattr(args, f"study_{o.into}")
        if value is None or value is False:
            continue
        if args.name not in names:
            raise CLIError(f"{flag} is for {', '.join(names)}")
        extra[o.into] = o.check(value) if o.check else value  # refused here, before any solve
    if s.validate is not None:
        s.validate(extra)
    settings = None
    if s.uses_settings:
        settings = eval_settings(args)
    else:
        from solvers.engines.base import SolveSettings

        owners = [Soil, SolveSettings, FomSettings, *(c.settings_class for c in _engines())]
        given = sorted({o.flag for c in owners for o in options(c) if getattr(args, o.key, None) is not None})
        if given:
            raise CLIError(f"study {args.name} fixes its own solver settings (it measures them); "
                           f"it does not take {', '.join(given)}")
    out = check_output_dir(Path(args.out) if args.out else Path.cwd() / args.name)
    run_study(args.name, out, settings, invocation(), **extra)
    print(f"{args.name}: results in {out}")
    return 0


def _check_results(root: Path) -> int:
    """``study --check``: each report's status, stale ones first; exit 1 when any is stale."""
    from .provenance import check

    if not root.is_dir():
        raise CLIError(f"{root}: no such folder of results")
    rows = check(root)
    order = {"stale": 0, "unknown": 1, "current": 2}
    for r in sorted(rows, key=lambda r: (order[r["status"]], r["path"])):
        again = f"  (regenerate: {r['command']})" if r["command"] and r["status"] != "current" else ""
        print(f"{r['status']:8s} {r['path']}: {r['why']}{again}")
    counts = {k: sum(r["status"] == k for r in rows) for k in order}
    print(f"{len(rows)} reports: {counts['current']} current, {counts['stale']} stale, {counts['unknown']} without "
          "model versions")
    return 1 if counts["stale"] else 0


def _engines():
    from solvers.engines import ENGINES

    return ENGINES.values()
