"""The fast solve's matvec with the pruned grid FFTs (``FastModel.spectrum`` / ``potentials``: the
rows a level cannot reach skipped) against the full zero-padded ``fft2`` / ``ifft2`` it replaced,
on one design's operator, in one process, interleaved, one BLAS thread.

    .venv/bin/python benchmarks/bench_pruned_fft.py [--design results/robust_front/field/teeth-xy-600/design.json]
        [--mesh 0.7] [--freq 70] [--repeats 40] [-o results/bench/bench_pruned_fft.txt]

Prints each variant's fastest and median matvec, their ratio, and the largest difference of the
two matvecs (they must agree to rounding). Never fails on a time.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--design", default="results/robust_front/field/teeth-xy-600/design.json",
                    help="a preset name or a design file (relative paths from the repository)")
    ap.add_argument("--mesh", type=float, default=0.7)
    ap.add_argument("--freq", type=float, default=70.0, help="MHz")
    ap.add_argument("--repeats", type=int, default=40)
    ap.add_argument("-o", "--out")
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT))
    import scipy.fft
    from threadpoolctl import threadpool_limits

    from groundplane.design import Design, Soil
    from groundplane.shapes import PRESETS, from_file
    from solvers.engines.surface import pfft
    from solvers.engines.surface.mesh import SurfaceSettings, build_mesh
    from solvers.engines.surface.operators import Problem
    from solvers.engines.surface.space import MirrorSymmetry, rwg_basis

    threadpool_limits(1)
    plane = from_file(ROOT / args.design) if args.design.endswith(".json") else PRESETS[args.design]
    design = Design(plane, Soil(3.5, 0.02))
    settings = SurfaceSettings(spacing=args.mesh)
    mesh = build_mesh(design, settings)
    prob = Problem(mesh, rwg_basis(mesh), "soil", settings.near_factor, (3.5, 0.02))
    model = pfft.build_fast_model(prob, MirrorSymmetry.of(mesh, prob.rwg))
    op = pfft.FastOperator(model, args.freq * 1e6)
    g, (sx, sy) = model.grid, model.shape

    def full_spectrum(src):
        padded = np.zeros(src.shape[:-2] + (sx, sy), complex)
        padded[..., :g.nx, :g.ny] = src
        return scipy.fft.fft2(padded, axes=(-2, -1), workers=1)

    def full_potentials(spec):
        return scipy.fft.ifft2(spec, axes=(-2, -1), workers=1)[..., :g.nx, :g.ny]

    pruned = (model.spectrum, model.potentials)
    x = model.u @ (np.random.default_rng(0).normal(size=model.u.shape[1]) + 0j)
    times = {"full fft2 (before)": [], "pruned (now)": []}
    out = {}
    for r in range(args.repeats):
        for name, (fwd, inv) in (("full fft2 (before)", (full_spectrum, full_potentials)), ("pruned (now)", pruned)):
            model.spectrum, model.potentials = fwd, inv  # instance attributes shadow the methods
            t0 = time.perf_counter()
            out[name] = op.matvec(x)
            times[name].append(time.perf_counter() - t0)
    del model.spectrum, model.potentials
    a, b = out.values()
    diff = float(np.abs(a - b).max() / np.abs(a).max())
    rows = [f"{args.design} at {args.mesh:g} m, {args.freq:g} MHz, MRO soil: {prob.n} unknowns, {len(model.rows)} "
            f"solved, grid {g.nx} x {g.ny} x {len(g.levels)} levels (FFT {sx} x {sy}), level rows "
            f"{[(s.start, s.stop) for s in model.rows_of_level]}; {args.repeats} matvecs each, interleaved"]
    for name, t in times.items():
        rows.append(f"  {name:20s} fastest {min(t) * 1e3:7.1f} ms   median {np.median(t) * 1e3:7.1f} ms")
    full, now = times.values()
    rows.append(f"  ratio (before / now): fastest {min(full) / min(now):.2f}x, median "
                f"{np.median(full) / np.median(now):.2f}x; largest matvec difference {diff:.1e} of its largest entry")
    text = "\n".join(rows)
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n")


if __name__ == "__main__":
    main()
