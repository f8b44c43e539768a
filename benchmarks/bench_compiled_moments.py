"""The fast solve's compiled moment loops (``solvers/engines/surface/_compiled.py``) against their
version of ``56425bf`` (each point pair added into the [6, P] output; read from git and compiled
here), in this one process on one design's real pairs, stencils and tables; with ``--candidate``
also a whole search candidate (the five soils of the ``soil`` set, in-process, beam cache off, the
Sommerfeld tables filled first) with either set of loops, alternating.

    .venv/bin/python benchmarks/bench_compiled_moments.py [--design results/robust_front/answer-600.json]
        [--mesh 0.7] [--repeat 3] [--candidate --freqs 55:97:4] [-o results/bench/bench_compiled_moments.txt]

Prints each loop's fastest time both ways, their ratio and the largest relative difference of the
moments (and with --candidate: wall times, ratio, the largest rms gain difference above 10 deg and
each soil's FoM both ways). Never fails on a time.
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
BASELINE = "56425bf"
SOILS = [(3.5, 0.02), (2.5, 0.005), (2.5, 0.05), (5.0, 0.005), (5.0, 0.05)]


def baseline_loops():
    """The baseline commit's ``_compiled`` module, compiled from its source (no numba cache)."""
    src = subprocess.run(["git", "show", f"{BASELINE}:solvers/engines/surface/_compiled.py"], cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout.replace("cache=True", "cache=False")
    path = Path(tempfile.mkdtemp(prefix="gp-loops-")) / "_compiled_baseline.py"
    path.write_text(src)
    spec = importlib.util.spec_from_file_location("_compiled_baseline", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def fastest(fn, repeat: int) -> tuple[float, object]:
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def rel(a, b) -> float:
    a, b = np.asarray(a), np.asarray(b)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def loops(plane, mesh_m: float, repeat: int, old) -> list[str]:
    from groundplane.design import Design, Soil
    from solvers.engines.surface import SurfaceSettings, pfft
    from solvers.engines.surface import _compiled as new
    from solvers.engines.surface.grid import Q3, Q7, quadrature_points
    from solvers.engines.surface.mesh import build_mesh

    settings = SurfaceSettings(spacing=mesh_m)
    prob = pfft.problem_of(build_mesh(Design(plane, Soil(*SOILS[0])), settings), "soil", settings.near_factor,
                           SOILS[0])
    model = pfft.fast_model(prob, True)
    k = 2 * np.pi * 76e6 / 299792458.0
    model.series(k)
    g, (ix, iy, wx, wy), (pts, w) = model.grid, model.stencils, model.points
    pairs = np.ascontiguousarray(model.pairs, dtype=np.int64)
    near = np.ascontiguousarray(model.near_pairs(True), dtype=np.int64)
    lev = model.level.astype(np.int64)
    direct = np.ascontiguousarray(pfft._offset_tables(model, k, True))
    kernels = prob.reflected_kernels(76e6, pfft.FAR_REACH_CELLS * g.h)
    reflected = np.ascontiguousarray(pfft._reflected_tables(model, kernels))
    p3, w3 = quadrature_points(prob.mesh, Q3)
    p7, w7 = quadrature_points(prob.mesh, Q7)
    grid_args = (pairs, ix, iy, wx, wy, lev, g.nx, g.ny, pts, w)
    soil_args = (kernels.zetas, np.ascontiguousarray(kernels.tables), kernels.step)

    def reflected_near(mod):
        out_a, out_q = np.zeros((6, len(near)), complex), np.zeros(len(near), complex)
        if mod is old:
            for (p, ww), sign in (((p7, w7), 1.0), ((p3, w3), -1.0)):
                mod.reflected_rule_moments(p, ww, p, ww, near, *soil_args, sign, out_a, out_q)
        else:  # today's loop takes every soil's tables at once (one soil here)
            (out_a,), (out_q,) = pfft._reflected_block(pfft._rule_points(prob.mesh, True), near,
                                                        pfft._stacked_tables([kernels]))
        return np.vstack([out_a, out_q[None]])

    cases = {  # name: (baseline call, new call, the rows the solve uses)
        "grid moments, direct + image (soil: image S0 only)": (
            lambda: old.grid_pair_moments(direct, *grid_args), lambda: new.grid_pair_moments(direct, *grid_args, 1),
            lambda m: np.concatenate([m[0].ravel(), m[1, 0]])),
        "grid moments, the soil's reflected kernels": (
            lambda: old.grid_pair_moments(reflected, *grid_args),
            lambda: new.grid_pair_moments(reflected, *grid_args, 1), lambda m: np.concatenate([m[0].ravel(), m[1, 0]])),
        "fill's 3 x 3 rule, direct + image": (
            lambda: old.rule_moments(p3, w3, p3, w3, pairs, k, True, True),
            lambda: new.rule_moments(p3, w3, p3, w3, pairs, k, True, True), lambda m: m),
        "soil's near corrections, 7 x 7 - 3 x 3": (lambda: reflected_near(old), lambda: reflected_near(new),
                                                   lambda m: m),
    }
    lines = [f"loops on {prob.rwg.n} unknowns: {len(pairs)} precorrection pairs, {len(near)} image near pairs, "
             f"grid {g.nx} x {g.ny} x {len(g.levels)} levels, 76 MHz, MRO soil; fastest of {repeat}"]
    for name, (f_old, f_new, used) in cases.items():
        f_old(), f_new()  # compile outside the clock
        t_old, m_old = fastest(f_old, repeat)
        t_new, m_new = fastest(f_new, repeat)
        lines.append(f"  {name:52s} {t_old:7.3f} -> {t_new:7.3f} s  {t_old / t_new:5.2f}x  "
                     f"largest relative difference {rel(used(m_new), used(m_old)):.1e}")
    return lines


def candidate(plane, mesh_m: float, freqs, old, repeat: int) -> list[str]:
    from solvers.engines.surface import _compiled

    new = {n: getattr(_compiled, n) for n in ("rule_moments", "reflected_rule_moments", "grid_pair_moments")}
    def old_reflected(po, wo, ps, ws, pairs, zetas, tables, steps, sizes, sign, out_a, out_q):
        """The baseline's one-soil loop behind today's signature (every soil's tables at once)."""
        for k in range(tables.shape[2]):
            one = np.ascontiguousarray(tables[:, :sizes[k], k, :].view(complex).transpose(0, 2, 1))  # [n_zeta, 2, n]
            old.reflected_rule_moments(po, wo, ps, ws, pairs, zetas, one, steps[k], sign, out_a[k], out_q[k])
    base = {"rule_moments": old.rule_moments, "reflected_rule_moments": old_reflected,
            "grid_pair_moments": lambda *a: old.grid_pair_moments(*a[:-1])}  # no n_full: every moment

    def loops(fns):
        return lambda: [setattr(_compiled, n, f) for n, f in fns.items()]
    return compare_candidates(plane, mesh_m, freqs, loops(base), loops(new), repeat)


def compare_candidates(plane, mesh_m: float, freqs, baseline, now, repeat: int) -> list[str]:
    """A search candidate (the five soils, in-process, beam cache off, the model warm, the Sommerfeld
    tables filled first) with the code set up by ``baseline()`` and by ``now()``, alternating; left as
    ``now``. Lines: wall times and their ratio, the largest rms gain difference, each soil's FoMs."""
    from bench_fastmath import fill_tables
    from bench_surface import foms, rms_db

    from groundplane.design import Design, Soil
    from solvers.engines.surface import SurfaceSettings, SurfaceSolver

    fill_tables(plane, mesh_m, freqs)
    times: dict[str, list[float]] = {"baseline": [], "now": []}
    beams = {}
    for _ in range(repeat):
        for name, setup in (("baseline", baseline), ("now", now)):
            setup()
            solver = SurfaceSolver(SurfaceSettings(spacing=mesh_m), workers=0, use_cache=False)
            solver.solve_many([Design(plane, Soil(*SOILS[0]))], freqs[:1])  # compiled, model built
            t0 = time.perf_counter()
            beams[name] = solver.solve_many([Design(plane, Soil(*s)) for s in SOILS], freqs)
            times[name].append(time.perf_counter() - t0)
    now()
    t_old, t_new = min(times["baseline"]), min(times["now"])
    lines = [f"candidate: {len(SOILS)} soils, {len(freqs)} frequencies, in-process, model warm, tables filled; "
             f"baseline {' '.join(f'{t:.1f}' for t in times['baseline'])} s, now "
             f"{' '.join(f'{t:.1f}' for t in times['now'])} s: {t_old / t_new:.2f}x (fastest of each)",
             f"  largest rms gain difference above 10 deg: "
             f"{max(float(np.max(rms_db(a, b))) for a, b in zip(beams['now'], beams['baseline'])):.1e} dB"]
    for s, a, b in zip(SOILS, beams["baseline"], beams["now"]):
        fa, fb = foms(a), foms(b)
        lines.append(f"  soil {s}: FoM 2 h {fa[1]:.3f} -> {fb[1]:.3f} mK, every 1 deg {fa[0]:.3f} -> {fb[0]:.3f} mK")
    return lines


def main() -> None:
    from bench_surface import one_design_args

    from groundplane.options import parse_freqs

    args, plane = one_design_args(__doc__, "results/robust_front/answer-600.json", 0.7, 3, "55:97:4",
                                  flags={"--candidate": "also a whole search candidate, both ways"})
    old = baseline_loops()
    lines = [f"{args.design} at {args.mesh:g} m; baseline: the loops of {BASELINE}"]
    lines += loops(plane, args.mesh, args.repeat, old)
    print("\n".join(lines), flush=True)
    if args.candidate:
        lines += candidate(plane, args.mesh, parse_freqs(args.freqs), old, 2)
    text = "\n".join(lines)
    if args.candidate:
        print("\n".join(lines[-(len(SOILS) + 2):]))
    if args.out:
        Path(args.out).write_text(text + "\n")


if __name__ == "__main__":
    main()
