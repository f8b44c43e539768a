"""The far field of a solved design by a type-3 non-uniform FFT (finufft, ``farfield.
horizontal_moments``) against the baseline, the direct sum over directions x quadrature points
(the compiled loop of the code before, kept here only as the reference), on the same solutions in
this one process: the search level's 3 deg quadrant, one metal level per sheet.

    .venv/bin/python benchmarks/bench_far_field.py [--design sawtooth-20-16] [--mesh 0.7]
        [--freqs 55,76,97] [-o results/bench/bench_far_field.txt]
    .venv/bin/python benchmarks/bench_far_field.py --candidate [--freqs 55:97:4] [-o ...]

Prints the far-field time both ways and their ratio, each solve's time for scale, and the largest
gain difference in dB above 10 deg elevation. ``--candidate``: a whole search candidate instead
(the design on the five soils of the ``soil`` set, in this process, the Sommerfeld tables filled
first, the direct sum's run first), both wall times and their ratio. Never fails on a time.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))


@numba.njit(cache=True, nogil=True)
def direct_sum(p, jw, level, n_levels, kx, ky, mirrored):
    """The baseline: sum_p jw_p exp(j (kx x_p + ky y_p)) direction by direction (the mirror
    class's four images as 4 cos cos and -4 sin sin), as ``_compiled.current_moments`` was."""
    out = np.zeros((kx.shape[0], n_levels, 2), np.complex128)
    for d in range(kx.shape[0]):
        for q in range(p.shape[0]):
            ax, ay = kx[d] * p[q, 0], ky[d] * p[q, 1]
            lev = level[q]
            if mirrored:
                out[d, lev, 0] += 4.0 * np.cos(ax) * np.cos(ay) * jw[q, 0]
                out[d, lev, 1] -= 4.0 * np.sin(ax) * np.sin(ay) * jw[q, 1]
            else:
                e = np.cos(ax + ay) + 1j * np.sin(ax + ay)
                out[d, lev, 0] += e * jw[q, 0]
                out[d, lev, 1] += e * jw[q, 1]
    return out


def candidate(plane, args) -> None:
    """The five soils of one design, in this process, with the direct sum and then the NUFFT."""
    from bench_fastmath import SOILS, fill_tables
    from bench_surface import print_and_write

    from groundplane.design import Design, Soil
    from groundplane.options import parse_freqs
    from solvers.engines.surface import SurfaceSettings, SurfaceSolver, farfield

    freqs = parse_freqs(args.freqs if ":" in args.freqs else "55:97:4")
    fill_tables(plane, args.mesh, freqs)
    nufft, times = farfield.horizontal_moments, {}
    for name, moments in (("direct sum", direct_sum), ("nufft", nufft)):
        farfield.horizontal_moments = moments
        solver = SurfaceSolver(SurfaceSettings(spacing=args.mesh), workers=0, use_cache=False)
        solver.solve_many([Design(plane, Soil(*SOILS[0]))], freqs[:1])  # compile and build outside the clock
        t0 = time.perf_counter()
        solver.solve_many([Design(plane, Soil(*s)) for s in SOILS], freqs)
        times[name] = time.perf_counter() - t0
        print(f"{name}: {times[name]:.1f} s", flush=True)
    text = (f"{args.design} at {args.mesh:g} m, {len(freqs)} frequencies, the 5 soils, one process, tables warm: far "
            f"field by the direct sum {times['direct sum']:.1f} s, by the NUFFT {times['nufft']:.1f} s "
            f"(**{times['direct sum'] / times['nufft']:.2f}x**)")
    print_and_write(text, args.out)


def main() -> None:
    from bench_surface import print_and_write

    from groundplane.design import Design, Soil
    from groundplane.shapes import PRESETS, from_file
    from solvers.engines.surface import SurfaceSettings, farfield, pfft
    from solvers.engines.surface.mesh import build_mesh
    from solvers.engines.surface.solver import FAR_FIELD_STEP

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--design", default="sawtooth-20-16")
    ap.add_argument("--mesh", type=float, default=0.7)
    ap.add_argument("--freqs", default="55,76,97")
    ap.add_argument("--candidate", action="store_true")
    ap.add_argument("-o", "--out")
    args = ap.parse_args()
    plane = from_file(args.design) if args.design.endswith(".json") else PRESETS[args.design]
    if args.candidate:
        return candidate(plane, args)
    settings = SurfaceSettings(spacing=args.mesh)
    soil = Soil(3.5, 0.02)
    mesh = build_mesh(Design(plane, soil), settings)
    prob = pfft.problem_of(mesh, "soil", settings.near_factor, (soil.eps_r, soil.sigma))
    th = np.arange(0.0, 91.0, FAR_FIELD_STEP)
    nufft = farfield.horizontal_moments
    lines = [f"{args.design} at {args.mesh:g} m over soil (3.5, 0.02 S/m), far field on the {FAR_FIELD_STEP} deg quadrant "
             f"({len(th) ** 2} directions), one process, one thread:"]
    worst, t_base, t_new = 0.0, 0.0, 0.0
    for f in (float(v) for v in args.freqs.split(",")):
        t0 = time.perf_counter()
        sol, stats = pfft.solve_fast(prob, f * 1e6, symmetric=True)
        t_solve = time.perf_counter() - t0
        farfield.horizontal_moments = direct_sum
        direct_sum(np.zeros((1, 3)), np.zeros((1, 2), complex), np.zeros(1, np.int64), 1, th[:1], th[:1], True)  # compile
        t0 = time.perf_counter()
        g_base = farfield.gain_pattern(prob, sol, th, th, mirrored_currents=stats.mirrored)
        tb = time.perf_counter() - t0
        farfield.horizontal_moments = nufft
        t0 = time.perf_counter()
        g_new = farfield.gain_pattern(prob, sol, th, th, mirrored_currents=stats.mirrored)
        tn = time.perf_counter() - t0
        up = th <= 80
        diff = np.abs(10 * np.log10(g_new[up] / g_base[up])).max()
        worst, t_base, t_new = max(worst, diff), t_base + tb, t_new + tn
        lines.append(f"  {f:g} MHz: solve {t_solve:.1f} s; far field direct {tb:.3f} s, nufft {tn:.3f} s "
                     f"({tb / tn:.1f}x); largest gain difference above 10 deg {diff:.1e} dB")
    lines.append(f"far field over the frequencies: {t_base:.2f} -> {t_new:.3f} s ({t_base / t_new:.1f}x); "
                 f"largest gain difference {worst:.1e} dB")
    text = "\n".join(lines)
    print_and_write(text, args.out)


if __name__ == "__main__":
    main()
