"""Each budget's search read from its history: the stopping rule's verdict, how often the best's own
plane was solved and its median's gap above the best (optimise.search.remeshings_of_best), how far
the best design moved over the second half (largest parameter change, m), and, as a what-if only,
the verdict had the tolerance been that gap. Rows a later check refuses (too fine for the 0.7 m
search mesh) are dropped as the search's resume drops them; the search's other checks are not
repeated, so a count can exceed the search's own (the 400 m^2 history at 2026-12-05 15:15: 281 here, 266 in its log). Run from the checkout: python results/robust_front/convergence_facts.py [--folder DIR] [BUDGET ...]
(--folder: another front's folder, e.g. results/robust_front_0.5m; its searches' mesh is read from it)."""
import argparse
import json
from pathlib import Path

import numpy as np

from groundplane.shapes import ShapeError
from optimise.search import best_so_far, family, flat_over_last_half, solved_rows, too_fine_for

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--folder", type=Path, default=Path(__file__).parent)
ap.add_argument("budgets", nargs="*", default=["200", "400", "600", "900"])
args = ap.parse_args()
HERE = args.folder
fam = family("teeth-xy")
span = np.array(fam.upper, float) - np.array(fam.lower, float)


def refused(row: dict) -> bool:
    """Whether the search, resumed today, refuses this solved row (too fine for its mesh)."""
    if row["status"] != "ok":
        return False
    try:
        return bool(too_fine_for(fam.build(np.asarray(row["x"], float), row.get("integer")), SEARCH_MESH_M))
    except ShapeError:
        return True


SEARCH_MESH_M = json.loads((HERE / f"budget-{args.budgets[0]}" / "search.json").read_text())["settings"]["mesh"]["spacing"]
print("| budget (m^2) | solves | best at | tolerance | flat | best plane solved | median above best | "
      "largest move of the best, second half (m) | what-if: tolerance = that gap |")
print("|---|---|---|---|---|---|---|---|---|")
for budget in args.budgets:
    rows = [json.loads(line) for line in (HERE / f"budget-{budget}" / "history.jsonl").open()]
    rows = [r for r in rows if "same_metal_as" not in r and not refused(r)]
    stop = flat_over_last_half(rows, span=span)
    solved = solved_rows(rows)
    curve = best_so_far(solved)
    move, whatif = "-", "-"
    if stop["measure"] == "fom":
        ok = [(i, r) for i, r in enumerate(solved) if r["status"] == "ok" and r.get("feasible", True)]
        half = [r for i, r in ok if i < len(solved) // 2]
        best = min((r for _, r in ok), key=lambda r: r["fom_mk"])
        if half:
            first = min(half, key=lambda r: r["fom_mk"])
            move = f"{np.abs(np.array(best['x']) - np.array(first['x'])).max():.3f}"
        gap = stop.get("best_plane_gap")
        if gap is not None:
            tol = max(stop["tolerance"], gap)
            at = next(i for i, v in enumerate(curve, 1) if v <= curve[-1] * (1 + tol))
            whatif = f"best at {at} of {len(solved)}: " + ("flat" if at <= len(solved) / 2 else "not flat")
    print(f"| {budget} | {stop['solves']} | {stop['best_at']} | {100 * stop['tolerance']:.1f} % | {stop['flat']} | "
          f"{stop.get('best_plane_solves', '-')} | "
          + (f"{100 * stop['best_plane_gap']:.1f} %" if stop.get("best_plane_gap") is not None else "-")
          + f" | {move} | {whatif} |")
