r"""Where the 0.5 % ground-loss limit starts to be met: plain squares scored on the `soil` set at the
search's level (0.5 m, 55-97 MHz every 3 MHz), beside the searched 200 and 400 m^2 rows. The 0.5 m
search at 200 m^2 found no plane within the limit and the 400 m^2 answer meets it, so the least metal
that meets it lay somewhere between; a square is the family's plane with no teeth, so a square that
meets the limit bounds that least metal from above.

    for s in 18 17 17.5 16 20 15; do .venv/bin/groundplane score square --side $s --scenarios soil \
      --max-loss 0.005 --mesh 0.5 --freqs 55:97:3 --workers 1 \
      -o results/robust_front_0.5m/loss_floor/square-$s; done
    .venv/bin/python results/robust_front_0.5m/loss_floor/loss_floor.py > results/robust_front_0.5m/loss_floor/README.md

Prints a markdown table; every verdict is a condition on its numbers.
"""
import csv
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
LIMIT = 0.005


def squares() -> list[tuple[float, float, float, str]]:
    """(metal m^2, worst-member FoM mK, largest loss, source) of each square scored here (presets.csv's
    squares are not used: they were scored at 1 MHz steps, another frequency set)."""
    rows = []
    for f in sorted(HERE.glob("square-*/results.json")):
        r = json.loads(f.read_text())[0]
        rows.append((r["metal_area_m2"], r["worst_fom_mk"], r["max_loss"], str(f.parent.relative_to(ROOT))))
    return sorted(rows)


def crossing(rows) -> tuple[float, float] | None:
    """The bracketing pair of metal areas where the squares' loss crosses LIMIT, or None."""
    for (a0, _, l0, _), (a1, _, l1, _) in zip(rows, rows[1:]):
        if l0 > LIMIT >= l1:
            return a0, a1
    return None


def main() -> None:
    """Print the table and the bound it gives."""
    rows = squares()
    print(f"<!-- .venv/bin/python {Path(__file__).relative_to(ROOT)} > {(HERE / 'README.md').relative_to(ROOT)} -->")
    print("# Where the 0.5 % ground-loss limit starts to be met\n")
    print("Plain squares on the five soils of the `soil` set at the search's level (surface engine v4, 0.5 m, "
          "55-97 MHz every 3 MHz; worst member = the largest FoM in 2 h bins; loss = the largest over the band "
          "and the members).\n")
    print("| square | metal (m^2) | worst member (mK) | largest ground loss (%) | within 0.5 %? | from |")
    print("|---|---|---|---|---|---|")
    for area, fom, loss, src in rows:
        print(f"| {np.sqrt(area):g} m | {area:.1f} | {fom:.1f} | {100 * loss:.3f} | "
              f"{'yes' if loss <= LIMIT else f'no (by {100 * (loss - LIMIT):.3f} points)'} | `{src}` |")
    with open(HERE.parent / "front.csv") as fh:
        front = {float(r["budget_m2"]): r for r in csv.DictReader(fh)}
    print("\nThe searched rows at the same level (`results/robust_front_0.5m/front.csv`, the teeth-xy family):\n")
    print("| budget (m^2) | metal (m^2) | worst member (mK) | largest ground loss (%) | within 0.5 %? |")
    print("|---|---|---|---|---|")
    for b in (200.0, 400.0):
        if b in front:
            r = front[b]
            loss = float(r["search_max_loss"])
            print(f"| {b:g} | {float(r['area_m2']):.1f} | {float(r['search_fom_mk']):.1f} | {100 * loss:.3f} | "
                  f"{'yes' if loss <= LIMIT else 'no'} |")
    pair = crossing(rows)
    print()
    if pair is None:
        print("The squares here do not bracket the limit: no bound on the least metal follows from them.")
        return
    (a0, a1) = pair
    # loss ~ area^p between the bracketing squares (the loss falls as a power of the metal): where it meets LIMIT
    (l0,), (l1,) = ([r[2] for r in rows if r[0] == a0], [r[2] for r in rows if r[0] == a1])
    p = np.log(l1 / l0) / np.log(a1 / a0)
    at = a0 * (LIMIT / l0) ** (1 / p)
    print(f"A square meets the limit from {a1:.0f} m^2 and not at {a0:.0f} m^2 (the loss falls as metal^{p:.2f} "
          f"between them: {at:.0f} m^2 at the limit). So the least metal a plane of the family needs to meet the "
          f"limit is at most {a1:.0f} m^2.")
    # the squares' trend over all of them (a power law fitted in log-log), read at the searched 200 m^2 row's metal
    area, loss = np.array([r[0] for r in rows]), np.array([r[2] for r in rows])
    slope, icept = np.polyfit(np.log(area), np.log(loss), 1)
    print(f"\nOver all {len(rows)} squares ({area.min():.0f}-{area.max():.0f} m^2) the loss falls as metal^{slope:.2f}.")
    if 200.0 in front:
        r = front[200.0]
        got, a = float(r["search_max_loss"]), float(r["area_m2"])
        trend = float(np.exp(icept) * a ** slope)
        near = abs(got / trend - 1) <= 0.1
        print(f"At the 200 m^2 search's {a:.1f} m^2 that trend reads {100 * trend:.3f} %; the search's least loss, "
              f"{100 * got:.3f} %, is {100 * (got / trend - 1):+.1f} % from it: "
              + ("within 10 %, so the searched teeth lowered the loss no further than a square of that metal would."
                 if near else ("below it by more than 10 %: the searched shape loses less than a square of that metal."
                               if got < trend else "above it by more than 10 %: the searched shape loses more than a "
                               "square of that metal.")))

if __name__ == "__main__":
    sys.exit(main())
