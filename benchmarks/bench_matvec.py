"""The fast operator's matvec (GMRES's cost: a third of a search candidate at 0.5 m) against its
version of ``d67d437`` (``pfft.py`` of that commit, read from git and loaded beside today's), on the
same design's model and terms in this one process, alternating; one BLAS thread, as in the solver's
workers. Then, with ``--solve``, one soil's whole fast solve both ways at a few frequencies.

    .venv/bin/python benchmarks/bench_matvec.py [--design sawtooth-20-16] [--mesh 0.5] [--repeat 30]
        [--solve --freqs 55:97:14] [-o results/bench/bench_matvec.txt]

Prints the median and fastest matvec each way, their ratio and the largest relative difference
of the products (with ``--solve``: times, GMRES iterations and the currents' largest relative
difference). Never fails on a time.
"""
from __future__ import annotations

import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
BASELINE = "d67d437"
SOIL = (3.5, 0.02)


def baseline_pfft():
    """``pfft`` of BASELINE as a module of today's package (its relative imports are today's)."""
    src = subprocess.run(["git", "show", f"{BASELINE}:solvers/engines/surface/pfft.py"], cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout
    path = Path(tempfile.mkdtemp(prefix="gp-pfft-")) / "pfft_baseline.py"
    path.write_text(src)
    name = "solvers.engines.surface._pfft_baseline"
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    from solvers.engines.surface import pfft

    def reflected_moments(mesh, pairs, kernels, near):  # its loop's call as today's loop takes it (the same sums)
        block = pfft._reflected_block(pfft._rule_points(mesh, near), pairs, pfft._stacked_tables([kernels]))
        return tuple(x[0] for x in block)
    mod.reflected_moments = reflected_moments
    return mod


def main() -> None:
    from bench_surface import one_design_args

    from groundplane.design import Design, Soil
    from groundplane.options import parse_freqs
    from solvers.engines.surface import SurfaceSettings, pfft
    from solvers.engines.surface.mesh import build_mesh

    args, plane = one_design_args(__doc__, "sawtooth-20-16", 0.5, 30, "55:97:14", "MHz, for the matvecs",
                                  {"--solve": "also whole one-soil solves, both ways"})
    old = baseline_pfft()
    settings = SurfaceSettings(spacing=args.mesh)
    prob = pfft.problem_of(build_mesh(Design(plane, Soil(*SOIL)), settings), "soil", settings.near_factor, SOIL)
    model = pfft.fast_model(prob, True)
    terms = pfft.frequency_terms(model, args.freq * 1e6)
    ops = {"baseline": old.FastOperator(model, args.freq * 1e6, SOIL, terms),
           "now": pfft.FastOperator(model, args.freq * 1e6, SOIL, terms)}
    x = model.u @ (np.random.default_rng(1).normal(size=model.u.shape[1]) + 0j)
    times: dict[str, list[float]] = {k: [] for k in ops}
    out = {k: op.matvec(x) for k, op in ops.items()}  # compiled, warm
    for _ in range(args.repeat):
        for k, op in ops.items():
            t0 = time.perf_counter()
            op.matvec(x)
            times[k].append(time.perf_counter() - t0)
    med = {k: float(np.median(v)) for k, v in times.items()}
    best = {k: min(v) for k, v in times.items()}
    diff = float(np.abs(out["now"] - out["baseline"]).max() / np.abs(out["baseline"]).max())
    g = model.grid
    lines = [f"{args.design} at {args.mesh:g} m ({prob.rwg.n} unknowns, {model.u.shape[1]} solved; grid {g.nx} x {g.ny}"
             f" x {len(g.levels)} levels, FFT {model.shape[0]} x {model.shape[1]}), {args.freq:g} MHz, MRO soil; "
             f"baseline: pfft.py of {BASELINE}",
             f"  matvec, {args.repeat} alternating: baseline median {1e3 * med['baseline']:.1f} ms (fastest "
             f"{1e3 * best['baseline']:.1f}), now {1e3 * med['now']:.1f} ms ({1e3 * best['now']:.1f}): "
             f"{med['baseline'] / med['now']:.2f}x median, {best['baseline'] / best['now']:.2f}x fastest; largest "
             f"relative difference {diff:.1e}"]
    print("\n".join(lines), flush=True)
    if args.solve:
        lines += solve_both(prob, old, parse_freqs(args.freqs))
        print("\n".join(lines[2:]))
    if args.out:
        Path(args.out).write_text("\n".join(lines) + "\n")


def solve_both(prob, old, freqs) -> list[str]:
    """One soil's fast solve at each frequency, the baseline's and today's operator alternating
    (each from zero, its terms and LU made again: both do the same work)."""
    from solvers.engines.surface import pfft

    pfft.WARM_START = False
    old.WARM_START = False
    for mod in (old, pfft):  # each module's own model (series, assembly) and the tables, outside the clock
        mod.solve_fast(prob, freqs[0] * 1e6, symmetric=True)
    lines = []
    for f in freqs:
        res: dict = {}
        for _ in range(3):  # alternating; the fastest of each
            for name, mod in (("baseline", old), ("now", pfft)):
                mod._TERMS.clear()
                mod._LU.clear()
                pfft._TERMS.clear()
                t0 = time.perf_counter()
                sol, stats = mod.solve_fast(prob, f * 1e6, symmetric=True)
                dt = time.perf_counter() - t0
                res[name] = (min(dt, res.get(name, (np.inf,))[0]), stats.iterations, sol.currents)
        diff = float(np.abs(res["now"][2] - res["baseline"][2]).max() / np.abs(res["baseline"][2]).max())
        lines.append(f"  solve at {f:g} MHz (terms, operator, LU, GMRES; fastest of 3): baseline {res['baseline'][0]:.2f} s "
                     f"({res['baseline'][1]} iterations), now {res['now'][0]:.2f} s ({res['now'][1]}): "
                     f"{res['baseline'][0] / res['now'][0]:.2f}x; currents' largest relative difference {diff:.1e}")
    return lines


if __name__ == "__main__":
    main()
