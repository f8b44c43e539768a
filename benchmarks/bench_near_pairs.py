"""The near-pair lists of one design (``operators.Problem``: built by the solve's plan in the parent
and again by each worker, for every candidate of a search) with numpy's ``np.unique`` (the baseline)
and ``operators.sorted_unique``, alternating in this process; the lists must be equal.

    .venv/bin/python benchmarks/bench_near_pairs.py [--design sawtooth-20-16] [--mesh 0.5] [--repeat 3]

Prints each build's time and the ratio of the fastest of each. Never fails on a time.
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
    ap.add_argument("--design", default="sawtooth-20-16")
    ap.add_argument("--mesh", type=float, default=0.5)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT))
    from groundplane.design import Design, Soil
    from groundplane.shapes import PRESETS, from_file
    from solvers.engines.surface import SurfaceSettings, operators
    from solvers.engines.surface.mesh import build_mesh
    from solvers.engines.surface.space import rwg_basis

    plane = from_file(args.design) if args.design.endswith(".json") else PRESETS[args.design]
    mesh = build_mesh(Design(plane, Soil(3.5, 0.02)), SurfaceSettings(spacing=args.mesh))
    rwg = rwg_basis(mesh)
    ours = operators.sorted_unique
    times: dict[str, list[float]] = {"np.unique": [], "sorted_unique": []}
    lists = {}
    for _ in range(args.repeat):
        for name, fn in (("np.unique", np.unique), ("sorted_unique", ours)):
            operators.sorted_unique = fn
            t0 = time.perf_counter()
            prob = operators.Problem(mesh, rwg, "soil", 2.5, (3.5, 0.02))
            times[name].append(time.perf_counter() - t0)
            lists[name] = prob.near
    operators.sorted_unique = ours
    same = all(np.array_equal(a, b) for a, b in zip(lists["np.unique"], lists["sorted_unique"]))
    print(f"{args.design} at {args.mesh:g} m: {len(mesh.tris)} triangles, near pairs "
          f"{' + '.join(str(len(p)) for p in lists['sorted_unique'])} (direct + image), lists equal: {same}; "
          f"numpy {np.__version__}")
    for name, t in times.items():
        print(f"  Problem with {name:14s} " + " ".join(f"{x:6.2f}" for x in t) + " s")
    print(f"  ratio (fastest of each): {min(times['np.unique']) / min(times['sorted_unique']):.2f}x")


if __name__ == "__main__":
    main()
