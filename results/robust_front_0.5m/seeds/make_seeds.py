"""The seeds of the 0.5 m searches: each budget's best distinct designs from its 0.7 m search.

    .venv/bin/python results/robust_front_0.5m/seeds/make_seeds.py [--budgets 400] [--top 6]

The 0.7 m search (``results/robust_front/budget-<A>/history.jsonl``) is the global stage: its
exploration (the presets, its seeds, a Sobol sample) and its refinement. Its feasible solved rows
are taken best first (worst soil member at 0.7 m), skipping any within DISTINCT of a design already
taken in every parameter (relative to the parameter's range: a remeshing of the same plane is not
another start), and each is checked against the 0.5 m mesh's rules; the first ``--top`` are written
here as design files (``budget-<A>-<i>.json``) for ``groundplane optimise --seed ... --explore``.
A budget with no feasible row (200 m^2) takes the rows that break the loss limit least.
"""
import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))
from optimise.search import family, row_plane, too_fine_for  # noqa: E402

DISTINCT = 0.05  # of each parameter's range: two starts differ by at least this in some parameter
MESH = 0.5


def best_distinct(rows: list[dict], span: np.ndarray, top: int) -> list[dict]:
    """The best feasible solved rows (with none feasible, as the search's answer does: those breaking
    the constraints least), each at least DISTINCT x ``span`` from every one taken before."""
    scored = [r for r in rows if r["status"] == "ok" and "same_metal_as" not in r]
    ok = sorted((r for r in scored if r.get("feasible", True)), key=lambda r: r["fom_mk"]) or sorted(
        scored, key=lambda r: (max(r.get("margins") or [0.0]), r["fom_mk"]))
    taken: list[dict] = []
    for r in ok:
        x = np.asarray(r["x"], float) / span
        if all(np.abs(x - np.asarray(t["x"], float) / span).max() >= DISTINCT for t in taken):
            taken.append(r)
        if len(taken) == top:
            break
    return taken


def main() -> None:
    """Write each budget's seeds beside this script."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budgets", type=float, nargs="+", default=[400.0])
    ap.add_argument("--top", type=int, default=6)
    args = ap.parse_args()
    here = Path(__file__).parent
    for b in args.budgets:
        folder = ROOT / f"results/robust_front/budget-{b:g}"
        shape = json.loads((folder / "search.json").read_text())["shape"]
        fam = family(shape)
        span = np.array(fam.upper, float) - np.array(fam.lower, float)
        rows = [json.loads(line) for line in (folder / "history.jsonl").read_text().splitlines() if line.strip()]
        kept = [r for r in best_distinct(rows, span, 10 * args.top) if too_fine_for(row_plane(fam, r), MESH) is None]
        for i, r in enumerate(kept[:args.top], 1):
            plane = row_plane(fam, r)
            out = here / f"budget-{b:g}-{i}.json"
            out.write_text(json.dumps({"shape": shape, **{k: v for k, v in r["params"].items()}}, indent=1) + "\n")
            broken = "" if r.get("feasible", True) else f", breaks {max(r.get('margins') or [0.0]):+.3f} (relative)"
            print(f"{out.name}: {r['fom_mk']:.1f} mK at 0.7 m (solve phase {r['phase']}), {plane.metal_area:.1f} m^2"
                  + broken)


if __name__ == "__main__":
    main()
