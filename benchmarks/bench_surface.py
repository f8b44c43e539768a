"""Surface engine speed: the fast solve of today's code against a baseline, on the same designs
and frequencies, each solve in a child process of this one run, cold (a fresh cache folder).

    .venv/bin/python benchmarks/bench_surface.py [--cases sawtooth-20-16@0.5 CROSS.json@0.5 ...]
        [--freqs 55:97:1] [--workers 2] [--against REV|dense] [--soils CASE@SPACING]
        [--soil-freqs 55:97:2] [--solve-every 2] [--json out.json]

``--against REV`` (default: the commit before the shared-terms work) solves each case with the
code of that git revision (a detached worktree beside this checkout, on ``PYTHONPATH``), and
``--against dense`` with today's code and ``--method dense`` (the reference). Printed per case:
unknowns, the wall time of each and their ratio, the first frequency in a worker (the per-design
build) and the mean of the rest, the largest over frequencies of the solid-angle-weighted rms
gain difference above 10 deg elevation, the FoM of each (every LST and in 2 h LST bins), GMRES
iterations and the process tree's peak memory (polled every 0.2 s).

``--soils CASE@SPACING``: one design on the five soils of the ``soil`` scenario set at the
search level (``--soil-freqs``): today's code on one soil and on all five together
(``solve_many``), each with the Sommerfeld tables cold and again warm (kept on disk by its first
run, as every later design of a search finds them; the design's own model is built again, as a
new design's is), and the baseline's five one by one. The ratios compare like with like: five
cold over one cold, five warm over one warm. Never fails on a time; the machine is noisy, so read
the ratios.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BASELINE_REV = "2af09dd"  # main before the shared-terms fast solve (2026-12-02)
SOILS = [(3.5, 0.02), (2.5, 0.005), (2.5, 0.05), (5.0, 0.005), (5.0, 0.05)]


def one_design_args(doc: str, design: str, mesh: float, repeat: int, freqs: str, freq_help: str | None = None,
                    flags: dict[str, str] | None = None) -> tuple[argparse.Namespace, object]:
    """The command line every one-design, in-process benchmark takes, parsed, and the design's plane:
    --design (a preset or a design file under the checkout), --mesh, --repeat, --freqs (a candidate's
    frequencies), -o, with ``freq_help`` a --freq (MHz, 76 by default) and each of ``flags`` (name: help)
    a switch. BLAS is held to one thread, as in the solver's workers."""
    from threadpoolctl import threadpool_limits

    from groundplane.shapes import PRESETS, from_file

    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--design", default=design)
    ap.add_argument("--mesh", type=float, default=mesh)
    ap.add_argument("--repeat", type=int, default=repeat)
    ap.add_argument("--freqs", default=freqs)
    if freq_help:
        ap.add_argument("--freq", type=float, default=76.0, help=freq_help)
    for name, help in (flags or {}).items():
        ap.add_argument(name, action="store_true", help=help)
    ap.add_argument("-o", "--out")
    args = ap.parse_args()
    threadpool_limits(1)
    plane = from_file(str(ROOT / args.design)) if args.design.endswith(".json") else PRESETS[args.design]
    return args, plane


def child(spec: dict) -> None:
    """Run in a child process: solve ``spec``'s design(s) with the code on sys.path, write the
    beams and the timings."""
    from groundplane.design import Design, Soil
    from groundplane.shapes import PRESETS, from_file
    from solvers.engines.surface import SurfaceSettings, SurfaceSolver

    name = spec["design"]
    plane = from_file(name) if name.endswith(".json") else PRESETS[name]
    every = {"solve_every": spec["solve_every"]} if spec.get("solve_every", 1) > 1 else {}  # today's code only
    solver = SurfaceSolver(SurfaceSettings(spacing=spec["spacing"], method=spec["method"], **every),
                           workers=spec["workers"], use_cache=False)
    designs = [Design(plane, Soil(*s)) for s in spec["soils"]]
    t0 = time.perf_counter()
    if spec["together"]:
        beams = solver.solve_many(designs, spec["freqs"])
    else:
        beams = [solver.solve(d, spec["freqs"]) for d in designs]
    wall = time.perf_counter() - t0
    for i, b in enumerate(beams):
        b.save(Path(spec["out"]) / f"beam{i}.npz")
    (Path(spec["out"]) / "timing.json").write_text(json.dumps({"wall_s": wall}))


def run_child(spec: dict, code_root: Path, cache: Path) -> dict:
    """Run :func:`child` with the code at ``code_root``; its wall time, peak memory and beams."""
    import psutil

    from groundplane.beam import Beam

    out = Path(tempfile.mkdtemp(prefix="bench-surface-"))
    spec = {**spec, "out": str(out)}
    env = {**os.environ, "PYTHONPATH": str(code_root), "GROUNDPLANE_CACHE": str(cache)}
    proc = subprocess.Popen([sys.executable, __file__, "--child", json.dumps(spec)], env=env, cwd=code_root)
    peak = 0
    parent = psutil.Process(proc.pid)
    while proc.poll() is None:
        try:
            tree = [parent, *parent.children(recursive=True)]
            peak = max(peak, sum(p.memory_info().rss for p in tree if p.is_running()))
        except psutil.Error:
            pass
        time.sleep(0.2)
    if proc.returncode:
        raise SystemExit(f"bench_surface: the child solve failed ({spec['design']}, {code_root})")
    timing = json.loads((out / "timing.json").read_text())
    beams = [Beam.load(out / f"beam{i}.npz") for i in range(len(spec["soils"]))]
    return {"wall_s": timing["wall_s"], "peak_gib": peak / 2**30, "beams": beams}


def baseline_root(rev: str) -> Path:
    """A detached worktree of ``rev`` beside this checkout (made once, reused)."""
    path = Path(tempfile.gettempdir()) / f"groundplane-baseline-{rev}"
    if not path.exists():
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(path), rev], check=True,
                       capture_output=True)
    return path


def print_and_write(text: str, out: str | None) -> None:
    """Print a benchmark's result and, with ``out``, write it under a header line naming the
    command and the date (every committed output says how to reproduce it)."""
    print(text)
    if out:
        head = f"# .venv/bin/python benchmarks/{Path(sys.argv[0]).name} {' '.join(sys.argv[1:])}  ({time.strftime('%Y-%m-%d')})\n"
        Path(out).write_text(head + text + "\n")


def rms_db(a, b) -> np.ndarray:
    """Per frequency, the solid-angle-weighted rms of B - A in dB above 10 deg elevation."""
    from groundplane.comparison import direction_differences

    return direction_differences(a, b, 10.0)["rms_db"]


def foms(beam) -> tuple[float, float]:
    from groundplane.fom import FomSettings, figure_of_merit

    res = figure_of_merit(beam, FomSettings(lst_bin_hours=0.0))
    return res.lst_averaged_mk, res.in_lst_bins(2.0).lst_averaged_mk


def split_times(beam, workers: int) -> tuple[float, float]:
    """(mean first frequency in a worker, mean of the rest) from the beam's own timings."""
    sec = np.asarray(beam.meta["seconds_per_frequency"], dtype=float)
    sec = np.sort(sec[np.isfinite(sec)])  # a filled frequency (solve_every) was not solved: NaN
    first = sec[-min(max(workers, 1), len(sec)):]
    rest = sec[:-len(first)] if len(sec) > len(first) else first
    return float(first.mean()), float(rest.mean())


def case(text: str) -> tuple[str, float]:
    name, spacing = text.rsplit("@", 1)
    return name, float(spacing)


def compare_case(text: str, freqs: list[float], workers: int, against: str, solve_every: int = 1) -> dict:
    name, spacing = case(text)
    spec = {"design": name, "spacing": spacing, "freqs": freqs, "workers": workers, "soils": [SOILS[0]],
            "together": False, "method": "fast"}
    with tempfile.TemporaryDirectory() as c1, tempfile.TemporaryDirectory() as c2:
        if against == "dense":
            base = run_child({**spec, "method": "dense"}, ROOT, Path(c1))
        else:
            base = run_child(spec, baseline_root(against), Path(c1))
        now = run_child({**spec, "solve_every": solve_every}, ROOT, Path(c2))
    a, b = base["beams"][0], now["beams"][0]
    (fa, fa2), (fb, fb2) = foms(a), foms(b)
    rms = rms_db(a, b)
    row = {"case": text, "unknowns": b.meta["n_unknowns"], "freqs": len(freqs), "against": against,
           "baseline_wall_s": base["wall_s"], "wall_s": now["wall_s"], "ratio": base["wall_s"] / now["wall_s"],
           "baseline_first_rest_s": split_times(a, workers), "first_rest_s": split_times(b, workers),
           "gain_rms_db_max": float(rms.max()), "fom_baseline_mk": fa, "fom_mk": fb, "fom_2h_baseline_mk": fa2,
           "fom_2h_mk": fb2, "fom_diff_pct": 100 * (fb / fa - 1), "fom_2h_diff_pct": 100 * (fb2 / fa2 - 1),
           "gmres_iterations": [int(x) for x in b.meta["gmres_iterations"] if np.isfinite(x)],
           "solve_every": solve_every,
           "baseline_peak_gib": base["peak_gib"], "peak_gib": now["peak_gib"]}
    print(f"| {text} | {row['unknowns']} | {row['baseline_wall_s']:.1f} | {row['wall_s']:.1f} | {row['ratio']:.2f}x | "
          f"{row['baseline_first_rest_s'][0]:.1f} / {row['baseline_first_rest_s'][1]:.1f} | "
          f"{row['first_rest_s'][0]:.1f} / {row['first_rest_s'][1]:.1f} | {row['gain_rms_db_max']:.1e} | "
          f"{fa:.1f} / {fb:.1f} ({row['fom_diff_pct']:+.3f} %) | {fa2:.1f} / {fb2:.1f} ({row['fom_2h_diff_pct']:+.3f} %) | "
          f"{min(row['gmres_iterations'])}-{max(row['gmres_iterations'])} | "
          f"{row['baseline_peak_gib']:.2f} / {row['peak_gib']:.2f} |", flush=True)
    return row


def soils_case(text: str, freqs: list[float], workers: int, against: str) -> dict:
    name, spacing = case(text)
    spec = {"design": name, "spacing": spacing, "freqs": freqs, "workers": workers, "method": "fast"}
    with tempfile.TemporaryDirectory() as c0, tempfile.TemporaryDirectory() as c1, \
            tempfile.TemporaryDirectory() as c2:
        one = run_child({**spec, "soils": [SOILS[0]], "together": False}, ROOT, Path(c0))
        one_warm = run_child({**spec, "soils": [SOILS[0]], "together": False}, ROOT, Path(c0))
        cold = run_child({**spec, "soils": SOILS, "together": True}, ROOT, Path(c1))
        warm = run_child({**spec, "soils": SOILS, "together": True}, ROOT, Path(c1))
        root = ROOT if against == "dense" else baseline_root(against)
        base = run_child({**spec, "soils": SOILS, "together": False}, root, Path(c2))
    worst = max(float(rms_db(a, b).max()) for a, b in zip(base["beams"], cold["beams"]))
    fom_diff = max(abs(foms(b)[1] / foms(a)[1] - 1) * 100 for a, b in zip(base["beams"], cold["beams"]))
    row = {"case": text, "freqs": len(freqs), "one_soil_s": one["wall_s"], "one_soil_warm_s": one_warm["wall_s"],
           "five_cold_s": cold["wall_s"], "five_warm_s": warm["wall_s"], "baseline_five_s": base["wall_s"],
           "five_over_one_cold": cold["wall_s"] / one["wall_s"], "five_over_one_warm": warm["wall_s"] / one_warm["wall_s"],
           "baseline_over_now_cold": base["wall_s"] / cold["wall_s"], "gain_rms_db_max": worst,
           "fom_2h_diff_pct_max": fom_diff, "peak_gib": cold["peak_gib"]}
    print(f"| {text} | {len(freqs)} | {one['wall_s']:.1f} / {one_warm['wall_s']:.1f} | "
          f"{cold['wall_s']:.1f} ({row['five_over_one_cold']:.2f}x one cold) | "
          f"{warm['wall_s']:.1f} ({row['five_over_one_warm']:.2f}x one warm) | {base['wall_s']:.1f} "
          f"({row['baseline_over_now_cold']:.2f}x) | {worst:.1e} | {fom_diff:.3f} % |", flush=True)
    return row


def main() -> None:
    from groundplane.options import parse_freqs

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="*", default=["sawtooth-20-16@0.5"])
    ap.add_argument("--freqs", type=parse_freqs, default=parse_freqs("55:97:1"))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--against", default=BASELINE_REV, help="a git revision, or dense (today's --method dense)")
    ap.add_argument("--soils", nargs="*", default=[], metavar="CASE@SPACING")
    ap.add_argument("--soil-freqs", type=parse_freqs, default=parse_freqs("55:97:2"))
    ap.add_argument("--solve-every", type=int, default=1,
                    help="today's solves with SurfaceSettings(solve_every=N): every N-th frequency solved, the rest "
                         "filled (the baseline solves them all)")
    ap.add_argument("--json", help="also write the rows here")
    args = ap.parse_args()
    rows: dict[str, list] = {"cases": [], "soils": []}
    freqs = [float(f) for f in args.freqs]
    if args.cases:
        print(f"{len(freqs)} frequencies {freqs[0]:g}-{freqs[-1]:g} MHz, {args.workers} worker process(es), sheet 5 mm "
              f"above MRO soil, cold; baseline: {args.against}; wall times of the whole solve (s)"
              + (f"; now solves every {args.solve_every} frequencies and fills the rest" if args.solve_every > 1 else ""))
        print("| case | unknowns | baseline (s) | now (s) | baseline / now | baseline first / rest per freq (s) | "
              "now first / rest (s) | gain rms diff (dB, worst freq) | FoM every LST, baseline / now (mK) | "
              "FoM 2 h bins (mK) | GMRES iterations | peak memory baseline / now (GiB) |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        rows["cases"] = [compare_case(c, freqs, args.workers, args.against, args.solve_every) for c in args.cases]
    if args.soils:
        sf = [float(f) for f in args.soil_freqs]
        print(f"\nFive soils {SOILS} of one design, {len(sf)} frequencies {sf[0]:g}-{sf[-1]:g} MHz, "
              f"{args.workers} workers; wall times (s)")
        print("| case | freqs | one soil, tables cold / warm | five together, tables cold | five together, tables warm | "
              "baseline, five one by one | gain rms diff (dB, worst) | FoM 2 h diff (worst) |")
        print("|---|---|---|---|---|---|---|---|")
        rows["soils"] = [soils_case(c, sf, args.workers, args.against) for c in args.soils]
    if args.json:
        Path(args.json).write_text(json.dumps({"argv": sys.argv, **rows}, indent=1))


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--child":
        child(json.loads(sys.argv[2]))
    else:
        main()
