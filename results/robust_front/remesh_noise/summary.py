"""One plane remeshed: the 600 m^2 answer with its side lengthened by 0-20 mm, the FoM at MRO on the
search level's 0.7 m mesh and on the default 0.5 m, both at 55-97 MHz every 3 MHz, 2 h bins (the
sweeps of mesh-0.7.toml and mesh-0.5.toml). Prints summary.md's table and spreads.
Run from the checkout: python results/robust_front/remesh_noise/summary.py"""
import json
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
BASE_SIDE = json.loads((HERE.parent / "answer-600.json").read_text())["side"]


def rows(mesh: str) -> list[dict]:
    """The sweep's scored rows at this mesh."""
    return [r for r in map(json.loads, (HERE / f"mesh-{mesh}" / "results.jsonl").open()) if r["status"] == "ok"]


def foms(mesh: str) -> dict[float, float]:
    """Side change (mm) -> FoM (mK) of the sweep at this mesh."""
    return {round(1000 * (r["params"]["side"] - BASE_SIDE), 3): r["lst_averaged_fom_mk"] for r in rows(mesh)}


def median_solve_s(mesh: str) -> tuple[float, int]:
    """Median wall time of the rows actually solved (a row found in the beam cache takes < 1 s)."""
    t = [r["solve_s"] for r in rows(mesh) if r.get("solve_s", 0) > 1]
    return float(np.median(t)), len(t)


meshes = {m: foms(m) for m in ("0.7", "0.5")}
steps = sorted(set.intersection(*(set(f) for f in meshes.values())))
print("| side + (mm) | " + " | ".join(f"FoM at {m} m (mK)" for m in meshes) + " |")
print("|---|" + "---|" * len(meshes))
for d in steps:
    print(f"| {d:g} | " + " | ".join(f"{meshes[m][d]:.1f}" for m in meshes) + " |")
print()
for m, f in meshes.items():
    v = np.array([f[d] for d in steps])
    print(f"- {m} m: {len(v)} designs, {v.min():.1f}-{v.max():.1f} mK, range {100 * (v.max() - v.min()) / v.min():.1f} % "
          f"of the lowest, standard deviation {100 * v.std(ddof=1) / v.mean():.1f} % of the mean")
(t7, n7), (t5, n5) = median_solve_s("0.7"), median_solve_s("0.5")
print(f"- median wall time of a solved candidate (one soil, 15 frequencies, 2 workers): {t7:.1f} s at 0.7 m ({n7} solves), "
      f"{t5:.1f} s at 0.5 m ({n5}): {t5 / t7:.2f}x")
