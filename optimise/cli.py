"""``groundplane sweep``, ``groundplane optimise`` and ``groundplane reproduce``."""
from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path


def register(sub) -> None:
    s = sub.add_parser("sweep", help="solve, score and rank the candidates of a TOML file (resumable)")
    s.add_argument("config", help="sweep TOML (see optimise/sweep.py for the format)")
    s.add_argument("-o", "--out", default=None, help="output folder (default: next to the config, named after it)")
    s.add_argument("--executor", choices=["local", "dask"], default="local")
    s.add_argument("--scheduler", help="Dask scheduler address (default: a local cluster)")
    s.add_argument("--retry-failed", action="store_true", help="solve failed candidates again")
    s.set_defaults(func=cmd_sweep)

    o = sub.add_parser("optimise", help="nlopt search of a shape family under a metal-area budget")
    o.add_argument("--shape", required=True, choices=["square", "plus", "sawtooth", "polygon-n", "star"])
    o.add_argument("--max-area", type=float, required=True, help="metal budget, m^2")
    o.add_argument("--algorithm", default="LN_COBYLA", help="nlopt algorithm taking constraints (default LN_COBYLA)")
    o.add_argument("--budget", type=int, default=30, help="evaluations in all (default 30)")
    o.add_argument("--integers", type=int, nargs="+", help="values of the family's integer parameter to try")
    o.add_argument("--compare", nargs="*", default=[], metavar="PRESET", help="presets scored with the same settings")
    o.add_argument("--step", action="store_true", help="write the best design's STEP")
    _eval_args(o)
    o.add_argument("-o", "--out", required=True)
    o.set_defaults(func=cmd_optimise)

    r = sub.add_parser("reproduce", help="reproduce the reference study's design table or soil sweep")
    r.add_argument("what", choices=["design-study", "soil-sweep"])
    _eval_args(r)
    r.add_argument("-o", "--out", default="results")
    r.add_argument("--compare-mesh", type=float, metavar="SPACING",
                   help="design-study: also solve at this plate spacing and report how rows and conclusions move")
    r.set_defaults(func=cmd_reproduce)


def _eval_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("solver and scoring")
    g.add_argument("--mesh", type=float, default=0.5, help="plate grid spacing m (default 0.5)")
    g.add_argument("--plate-height", type=float, default=0.05, help="plate height above the soil m (default 0.05)")
    g.add_argument("--refine-centre", type=float, nargs=2, metavar=("HALF_WIDTH", "FACTOR"),
                   help="a grid FACTOR times finer inside |x|,|y| <= HALF_WIDTH m")
    g.add_argument("--freqs", default="40:100:1", help="MHz, LO:HI:STEP (default 40:100:1)")
    g.add_argument("--eps-r", type=float, default=3.5)
    g.add_argument("--sigma", type=float, default=0.02)
    g.add_argument("--n-lst", type=int, default=360)


def _settings(args: argparse.Namespace):
    from groundplane.design import Soil
    from groundplane.fom import FomSettings
    from solvers.nec import MeshSettings, parse_freqs

    from .objective import EvalSettings

    from solvers.cli import _refine

    mesh = MeshSettings(spacing=args.mesh, plate_height=args.plate_height, **_refine(args.refine_centre))
    return EvalSettings(soil=Soil(args.eps_r, args.sigma), mesh=mesh,
                        freqs_mhz=tuple(parse_freqs(args.freqs)), fom=FomSettings(n_lst=args.n_lst))


def _command() -> str:
    return "groundplane " + " ".join(shlex.quote(a) for a in sys.argv[1:])


def cmd_sweep(args: argparse.Namespace) -> int:
    from .report import write_report
    from .sweep import load_config, run_sweep, summary_table

    candidates, invalid, settings = load_config(args.config)
    out = Path(args.out) if args.out else Path(args.config).with_suffix("")
    rows = run_sweep(candidates, settings, out, invalid=invalid, executor=args.executor,
                     scheduler=args.scheduler, retry_failed=args.retry_failed, progress=sys.stderr.isatty())
    paths = write_report(rows, out, title=f"Sweep {Path(args.config).name}", preamble=f"Command: `{_command()}`")
    print(summary_table(rows))
    print(f"report: {paths['md']}")
    return 0


def cmd_optimise(args: argparse.Namespace) -> int:
    from groundplane.shapes import preset

    from .objective import Candidate, evaluate
    from .report import write_report
    from .search import best_plane, optimise

    settings = _settings(args)
    out = Path(args.out)
    res = optimise(args.shape, args.max_area, settings, out, algorithm=args.algorithm, budget=args.budget,
                   integer_values=tuple(args.integers) if args.integers else None)
    rows = []
    for name in args.compare:
        row = evaluate(Candidate(name, plane=preset(name)), settings)
        rows.append(row)
    if res.best:
        best = best_plane(args.shape, res.best)
        rows.append(evaluate(Candidate(f"optimised {args.shape}", plane=best), settings))
        if args.step:
            from groundplane.cad import export_step

            export_step(best, out / "best.step")
    _history_plot(res.history, out / "history.png", args.max_area)
    verdict = _verdict(rows, args)
    paths = write_report(rows, out, title=f"Optimised {args.shape} under {args.max_area:g} m^2",
                         preamble=f"Command: `{_command()}`. {len(res.history)} evaluations in "
                                  f"history.jsonl. {verdict}")
    print(verdict)
    print(f"report: {paths['md']}")
    return 0 if res.best else 1


def _verdict(rows, args) -> str:
    ok = {r["name"]: r for r in rows if r.get("status") == "ok"}
    best = ok.get(f"optimised {args.shape}")
    if best is None:
        return "No feasible design was scored."
    text = (f"Best {args.shape}: {best['lst_averaged_fom_mk']:.1f} mK at {best['metal_area_m2']:.1f} m^2 "
            f"({json.dumps(best['params'])}).")
    for name in args.compare:
        if name in ok:
            r = ok[name]
            better = best["lst_averaged_fom_mk"] < r["lst_averaged_fom_mk"]
            text += (f" {name}: {r['lst_averaged_fom_mk']:.1f} mK at {r['metal_area_m2']:.0f} m^2 -> the optimiser "
                     f"{'found a lower' if better else 'did not find a lower'} FoM with these settings.")
    return text


def _history_plot(history, path: Path, max_area: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

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
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def cmd_reproduce(args: argparse.Namespace) -> int:
    from .reproduce import design_study, soil_sweep

    settings = _settings(args)
    if args.what == "design-study":
        compare = None
        if args.compare_mesh is not None:
            from dataclasses import replace

            compare = replace(settings, mesh=replace(settings.mesh, spacing=args.compare_mesh))
        table = design_study(settings, args.out, _command(), progress=sys.stderr.isatty(), compare=compare)
        for t in table:
            print(f"{t['preset']:16s} paper {t['paper_fom_mk']:6.0f}  ours {t['our_fom_mk']}")
    else:
        for r in soil_sweep(settings, args.out, _command(), progress=sys.stderr.isatty()):
            print(r)
    return 0
