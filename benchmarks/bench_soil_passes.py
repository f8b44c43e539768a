"""The soils' reflected near terms in one pass over the point pairs, in real arithmetic
(``pfft.reflected_near``, ``SOILS_TOGETHER = True``), against the code of ``d67d437`` (one pass a
soil, complex arithmetic: its compiled loop read from git and compiled here), in this one process
on one design: first the terms alone (the five soils of the ``soil`` set at one frequency; also
today's loop one soil a pass, to split the two changes), then with ``--candidate`` a whole search
candidate (the five soils, in-process, beam cache off, the design's model warm and the Sommerfeld
tables filled first), alternating.

    .venv/bin/python benchmarks/bench_soil_passes.py [--design sawtooth-20-16] [--mesh 0.5]
        [--repeat 3] [--candidate --freqs 55:97:4] [-o results/bench/bench_soil_passes.txt]

Prints the fastest time each way and the ratios, whether the terms are equal, and with
``--candidate`` the wall times, ratio, the largest rms gain difference above 10 deg and each soil's
FoM both ways. Never fails on a time.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
SOILS = [(3.5, 0.02), (2.5, 0.005), (2.5, 0.05), (5.0, 0.005), (5.0, 0.05)]
NOW = None  # today's (pfft._stacked_tables, pfft._reflected_block), set in main
BASELINE = "d67d437"


def baseline_moments():
    """``pfft``'s per-block moments as they were at BASELINE: the loop of that commit (complex
    arithmetic), one soil a call; as (tables, block) functions for ``pfft._stacked_tables`` and
    ``pfft._reflected_block``."""
    import bench_compiled_moments

    bench_compiled_moments.BASELINE = BASELINE
    old = bench_compiled_moments.baseline_loops()

    def stacked(kernels):
        return kernels

    def block(rules, pairs, kernels):
        pairs = np.ascontiguousarray(pairs, dtype=np.int64)
        out_a = np.zeros((len(kernels), 6, len(pairs)), complex)
        out_q = np.zeros((len(kernels), len(pairs)), complex)
        for i, k in enumerate(kernels):
            for p, w, sign in rules:
                old.reflected_rule_moments(p, w, p, w, pairs, k.zetas, np.ascontiguousarray(k.tables), k.step, sign,
                                           out_a[i], out_q[i])
        return out_a, out_q
    return stacked, block


def use(mode: str, old) -> None:
    """Set the code up as ``mode``: "baseline", "one a pass" (today's loop) or "now"."""
    from solvers.engines.surface import pfft

    pfft._stacked_tables, pfft._reflected_block = old if mode == "baseline" else NOW
    pfft.SOILS_TOGETHER = mode == "now"


def terms_alone(plane, mesh_m: float, freq_mhz: float, repeat: int, old) -> list[str]:
    """The five soils' reflected near terms at one frequency, each way, interleaved."""
    from groundplane.design import Design, Soil
    from solvers.engines.surface import SurfaceSettings, pfft
    from solvers.engines.surface.mesh import build_mesh

    settings = SurfaceSettings(spacing=mesh_m)
    prob = pfft.problem_of(build_mesh(Design(plane, Soil(*SOILS[0])), settings), "soil", settings.near_factor,
                           SOILS[0])
    model = pfft.fast_model(prob, True)
    terms = pfft.frequency_terms(model, freq_mhz * 1e6)
    prob.reflected_kernels_many(freq_mhz * 1e6, SOILS, pfft.FAR_REACH_CELLS * model.grid.h)  # tables outside the clock
    modes = ("baseline", "one a pass", "now")
    best = dict.fromkeys(modes, np.inf)
    out = {}
    for _ in range(repeat):
        for mode in modes:
            use(mode, old)
            pfft._SOIL_NEAR.clear()
            t0 = time.perf_counter()
            out[mode] = pfft.reflected_near(model, terms, SOILS)
            best[mode] = min(best[mode], time.perf_counter() - t0)
    use("now", old)
    pfft._SOIL_NEAR.clear()
    equal = all(np.array_equal(a, b) for a, b in zip(out["now"], out["one a pass"]))
    diff = max(float(np.abs(a - b).max() / np.abs(b).max()) for a, b in zip(out["now"], out["baseline"]))
    return [f"reflected near terms of {len(SOILS)} soils at {freq_mhz:g} MHz ({len(model.pairs)} precorrection "
            f"pairs, {len(model.near_pairs(True))} image near pairs, {prob.rwg.n} unknowns), fastest of {repeat}:",
            f"  baseline (complex, one pass a soil) {best['baseline']:.3f} s; real arithmetic, one pass a soil "
            f"{best['one a pass']:.3f} s ({best['baseline'] / best['one a pass']:.2f}x); real, one pass "
            f"{best['now']:.3f} s ({best['baseline'] / best['now']:.2f}x)",
            f"  terms: one pass {'equal to the last bit to' if equal else 'DIFFERENT from'} one a pass; largest "
            f"relative difference from the baseline {diff:.1e}"]


def candidate(plane, mesh_m: float, freqs, repeat: int, old) -> list[str]:
    """A search candidate (five soils, in-process) both ways, alternating; beams compared."""
    from bench_compiled_moments import compare_candidates

    return compare_candidates(plane, mesh_m, freqs, lambda: use("baseline", old), lambda: use("now", old), repeat)


def main() -> None:
    from bench_surface import one_design_args

    from groundplane.options import parse_freqs

    args, plane = one_design_args(__doc__, "sawtooth-20-16", 0.5, 3, "55:97:4", "MHz, for the terms alone",
                                  {"--candidate": "also a whole search candidate, both ways"})
    from solvers.engines.surface import pfft

    global NOW
    NOW = (pfft._stacked_tables, pfft._reflected_block)
    old = baseline_moments()
    lines = [f"{args.design} at {args.mesh:g} m; baseline: the code of {BASELINE} (one pass over the point pairs "
             "a soil, complex arithmetic)"]
    lines += terms_alone(plane, args.mesh, args.freq, args.repeat, old)
    print("\n".join(lines), flush=True)
    if args.candidate:
        more = candidate(plane, args.mesh, parse_freqs(args.freqs), 2, old)
        print("\n".join(more), flush=True)
        lines += more
    if args.out:
        Path(args.out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
