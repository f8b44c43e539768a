"""How much a surface-engine FoM depends on the path of the solve: GMRES stops at ``pfft.GMRES_RTOL``
and starts from the currents the process solved last (the previous soil, the worker's previous
frequency: ``pfft.warm_start``), so the same design can read differently with another worker split,
with some soils or frequencies already cached, or in another order. Each variant solves one design on
the five soils of the ``soil`` set (beam cache off) and is compared with a reference solved from zero
to a 100x tighter tolerance in this process:

- ``default, 2 workers``: as a search or ``groundplane score`` solves it (spawned workers);
- ``default, in-process``: ``workers=0``, every frequency in order in one process;
- ``from zero``: ``workers=0``, no warm start (a beam that depends on nothing solved before it);
- ``reverse order``: ``workers=0``, the soils in the reverse order (another soil seeds each GMRES).

    .venv/bin/python benchmarks/check_solve_path.py [--design results/robust_front_0.5m/answer-600.json]
        [--mesh 0.5] [--freqs 55:97:1] [-o results/bench/check_solve_path.txt]

Prints per variant and soil the FoM (2 h bins) and its difference from the reference, the largest rms
gain difference above 10 deg, and GMRES iterations. A check of accuracy, not a benchmark: no time is
compared.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))


def soil_set() -> list[tuple[float, float]]:
    """The ``soil`` scenario set's soils, MRO first (``optimise.scenarios``: the corners and the paper's MRO)."""
    from groundplane import paper
    from optimise.scenarios import SOIL_CORNERS

    return [(paper.MRO_EPS_R, paper.MRO_SIGMA_S_PER_M), *SOIL_CORNERS]


def solve(plane, mesh: float, freqs, workers: int, warm: bool = True, rtol: float | None = None,
          soils=None) -> dict:
    """Beams by soil of one solve of ``plane`` with the warm start and tolerance given (in-process
    flags reach only ``workers=0``: spawned workers import the module's defaults)."""
    from groundplane.design import Design, Soil
    from solvers.engines.surface import SurfaceSettings, SurfaceSolver, pfft

    soils = soils or soil_set()
    saved = pfft.WARM_START, pfft.WARM_START_ACROSS_FREQUENCIES, pfft.GMRES_RTOL
    pfft.WARM_START = pfft.WARM_START_ACROSS_FREQUENCIES = warm
    pfft.GMRES_RTOL = rtol or saved[2]
    try:
        solver = SurfaceSolver(SurfaceSettings(spacing=mesh), workers=workers, use_cache=False)
        t0 = time.perf_counter()
        beams = solver.solve_many([Design(plane, Soil(eps_r=e, sigma=s)) for e, s in soils], freqs)
        print(f"  solved in {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    finally:
        pfft.WARM_START, pfft.WARM_START_ACROSS_FREQUENCIES, pfft.GMRES_RTOL = saved
    return dict(zip(soils, beams))


def main() -> None:
    from bench_surface import print_and_write, rms_db

    from groundplane.fom import FomSettings, figure_of_merit
    from groundplane.options import parse_freqs
    from groundplane.shapes import PRESETS, from_file
    from solvers.engines.surface import pfft

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--design", default="results/robust_front_0.5m/answer-600.json")
    ap.add_argument("--mesh", type=float, default=0.5)
    ap.add_argument("--freqs", default="55:97:1")
    ap.add_argument("-o", "--out")
    args = ap.parse_args()
    plane = PRESETS[args.design] if args.design in PRESETS else from_file(ROOT / args.design)
    freqs = parse_freqs(args.freqs)
    tight = pfft.GMRES_RTOL / 100
    print("reference: from zero, GMRES to", tight, file=sys.stderr)
    ref = solve(plane, args.mesh, freqs, 0, warm=False, rtol=tight)
    variants = {"default, 2 workers": lambda: solve(plane, args.mesh, freqs, 2),
                "default, in-process": lambda: solve(plane, args.mesh, freqs, 0),
                "from zero": lambda: solve(plane, args.mesh, freqs, 0, warm=False),
                "reverse order": lambda: solve(plane, args.mesh, freqs, 0, soils=soil_set()[::-1])}
    fom = {}

    def fom_of(beam) -> float:
        key = id(beam)
        if key not in fom:
            fom[key] = figure_of_merit(beam, FomSettings()).lst_averaged_mk  # the default: 2 h bins
        return fom[key]

    def iterations(beam) -> float:
        return float(np.nanmean(beam.meta.get("gmres_iterations", [np.nan])))

    lines = [f"`{args.design}` at {args.mesh} m, {len(freqs)} frequencies ({args.freqs}), the five soils of the "
             f"`soil` set, beam cache off. Reference: from zero, GMRES to {tight:g} (the default {pfft.GMRES_RTOL:g}).",
             "", "| variant | soil (eps_r, S/m) | FoM 2 h (mK) | minus reference (mK) | relative | "
             "largest rms dB above 10 deg | mean GMRES iterations |", "|---|---|---|---|---|---|---|"]
    for soil, beam in ref.items():
        lines.append(f"| reference | {soil[0]:g}, {soil[1]:g} | {fom_of(beam):.4f} | - | - | - | {iterations(beam):.1f} |")
    worst = {}
    for name, run in variants.items():
        print(name, file=sys.stderr)
        beams = run()
        diffs = []
        for soil in soil_set():
            b, r = beams[soil], ref[soil]
            d = fom_of(b) - fom_of(r)
            diffs.append(abs(d))
            lines.append(f"| {name} | {soil[0]:g}, {soil[1]:g} | {fom_of(b):.4f} | {d:+.4f} | {d / fom_of(r):+.2e} | "
                         f"{np.max(rms_db(r, b)):.1e} | {iterations(b):.1f} |")
        worst[name] = max(diffs)
    lines += ["", "Largest |FoM - reference| over the soils: "
              + "; ".join(f"{k} {v:.4f} mK" for k, v in worst.items())]
    print_and_write("\n".join(lines), args.out)


if __name__ == "__main__":
    main()
