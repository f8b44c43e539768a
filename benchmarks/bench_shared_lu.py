"""The soils of one design at one frequency sharing one near-matrix LU (GMRES's preconditioner,
factorised in a minimum-degree order on A^T + A) and each starting GMRES from the previous soil's
currents, against the baseline: each soil factorising its own LU in SuperLU's default order
(COLAMD) and starting from zero. The same design on the five soils of the ``soil`` set, in this one
process (``workers=0``), the beam cache off; the baseline run first (it also fills the Sommerfeld
tables, so neither run pays for them), then the shared one.

    .venv/bin/python benchmarks/bench_shared_lu.py [--design sawtooth-20-16] [--mesh 0.7]
        [--freqs 55:97:4] [-o results/bench/bench_shared_lu.txt]

Prints each run's wall time and their ratio, GMRES iterations per soil, the largest rms gain
difference above 10 deg elevation over frequencies and soils, and the FoM of every soil both
ways (every 1 deg of LST and in 2 h bins). Never fails on a time.
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
SOILS = [(3.5, 0.02), (2.5, 0.005), (2.5, 0.05), (5.0, 0.005), (5.0, 0.05)]


def run(plane, mesh: float, freqs, shared: bool):
    from groundplane.design import Design, Soil
    from solvers.engines.surface import SurfaceSettings, SurfaceSolver, pfft

    pfft.SHARE_PRECONDITIONER = pfft.WARM_START = shared
    pfft.LU_ORDERING = "MMD_AT_PLUS_A" if shared else "COLAMD"
    solver = SurfaceSolver(SurfaceSettings(spacing=mesh), workers=0, use_cache=False)
    t0 = time.perf_counter()
    beams = solver.solve_many([Design(plane, Soil(*s)) for s in SOILS], freqs)
    return time.perf_counter() - t0, beams


def main() -> None:
    from bench_surface import foms, rms_db

    from groundplane.options import parse_freqs
    from groundplane.shapes import PRESETS, from_file

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--design", default="sawtooth-20-16")
    ap.add_argument("--mesh", type=float, default=0.7)
    ap.add_argument("--freqs", default="55:97:4")  # >= 10 in the fit band: the FoM needs them
    ap.add_argument("-o", "--out")
    args = ap.parse_args()
    plane = from_file(args.design) if args.design.endswith(".json") else PRESETS[args.design]
    freqs = parse_freqs(args.freqs)
    t_own, own = run(plane, args.mesh, freqs, shared=False)
    print(f"baseline (each soil its own LU, COLAMD, GMRES from zero): {t_own:.1f} s", flush=True)
    t_shared, shared = run(plane, args.mesh, freqs, shared=True)
    print(f"shared LU, MMD(A^T+A), warm start: {t_shared:.1f} s", flush=True)
    lines = [f"{args.design} at {args.mesh:g} m, {len(freqs)} frequencies ({args.freqs}), the 5 soils, one process:",
             f"  baseline (each soil its own LU in COLAMD order, GMRES from zero): {t_own:.1f} s; one LU per frequency "
             f"shared by the soils (MMD on A^T+A), each soil's GMRES started from the previous soil's: {t_shared:.1f} s "
             f"(**{t_own / t_shared:.2f}x**)", "",
             "| soil (eps_r, sigma) | GMRES iterations, baseline | shared and warm | largest rms dB above 10 deg | "
             "FoM every 1 deg own / shared (mK) | FoM 2 h own / shared (mK) |", "|---|---|---|---|---|---|"]
    for s, a, b in zip(SOILS, own, shared):
        ia, ib = (np.asarray(x.meta["gmres_iterations"]) for x in (a, b))
        fa, fb = foms(a), foms(b)
        lines.append(f"| {s[0]:g}, {s[1]:g} | {ia.mean():.0f} ({ia.min():.0f}-{ia.max():.0f}) | {ib.mean():.0f} "
                     f"({ib.min():.0f}-{ib.max():.0f}) | {np.max(rms_db(a, b)):.1e} | {fa[0]:.3f} / {fb[0]:.3f} | "
                     f"{fa[1]:.3f} / {fb[1]:.3f} |")
    text = "\n".join(lines)
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n")


if __name__ == "__main__":
    main()
