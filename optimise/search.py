"""nlopt search of a ground-plane family under a metal-area budget.

The continuous parameters are optimised with a derivative-free nlopt algorithm that takes
inequality constraints (metal area <= A, and the family's validity, e.g. teeth that fit);
integer parameters (teeth per side, polygon sides, star points) are enumerated, one nlopt
run each. Bounds are always set. Every evaluation is appended to ``history.jsonl`` as it
completes; a rerun replays the history (nlopt is deterministic given the same answers),
so an interrupted optimisation resumes without solving anything twice. A failed or
non-finite evaluation returns a finite penalty: nlopt's COBYLA can hang on NaN.
"""
from __future__ import annotations

import json
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from groundplane.shapes import GroundPlane, Plus, RegularPolygon, Sawtooth, ShapeError, Square, Star

from .objective import Candidate, EvalSettings, evaluate

CONSTRAINED_ALGORITHMS = ("LN_COBYLA", "GN_ISRES", "GN_ORIG_DIRECT", "GN_ORIG_DIRECT_L")


@dataclass(frozen=True)
class Family:
    """A shape family as the optimiser sees it."""

    names: tuple[str, ...]  # continuous parameters, in x order
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    integer: str | None  # name of the enumerated integer parameter
    integer_values: tuple[int, ...]
    build: Callable[[np.ndarray, int | None], GroundPlane]
    area: Callable[[np.ndarray, int | None], float]  # closed form, defined for invalid x too
    validity: tuple[Callable[[np.ndarray, int | None], float], ...]  # each <= 0 when valid
    start: Callable[[float, int | None], np.ndarray]  # a valid x with area below the budget


FAMILIES: dict[str, Family] = {
    "square": Family(("side",), (2.0,), (40.0,), None, (),
                     lambda x, n: Square(float(x[0])), lambda x, n: x[0] ** 2, (),
                     lambda a, n: np.array([math.sqrt(0.8 * a)])),
    "plus": Family(("arm",), (1.0,), (15.0,), None, (),
                   lambda x, n: Plus(float(x[0])), lambda x, n: 5 * x[0] ** 2, (),
                   lambda a, n: np.array([math.sqrt(0.8 * a / 5)])),
    "sawtooth": Family(
        ("side", "tooth_base", "tooth_height"), (4.0, 0.5, 0.5), (30.0, 10.0, 10.0),
        "teeth_per_side", (2, 3, 4, 5, 6),
        lambda x, n: Sawtooth(float(x[0]), int(n), float(x[1]), float(x[2])),
        lambda x, n: x[0] ** 2 + 2 * n * x[1] * x[2],
        (lambda x, n: n * x[1] - x[0],),  # teeth fit on the side
        lambda a, n: _sawtooth_start(a, n),
    ),
    "polygon-n": Family(("radius",), (1.0,), (25.0,), "n_sides", (6, 8, 12),
                        lambda x, n: RegularPolygon(int(n), float(x[0])),
                        lambda x, n: 0.5 * n * x[0] ** 2 * math.sin(2 * math.pi / n), (),
                        lambda a, n: np.array([math.sqrt(0.8 * a / (0.5 * n * math.sin(2 * math.pi / n)))])),
    "star": Family(("outer_radius", "inner_radius"), (2.0, 1.0), (25.0, 20.0), "n_points", (8, 12, 16),
                   lambda x, n: Star(int(n), float(x[0]), float(x[1])),
                   lambda x, n: n * x[0] * x[1] * math.sin(math.pi / n),
                   (lambda x, n: x[1] - 0.95 * x[0],),
                   lambda a, n: _star_start(a, n)),
}


def _sawtooth_start(a: float, n: int) -> np.ndarray:
    side = math.sqrt(0.5 * a)
    base = 0.8 * side / n
    height = min(10.0, 0.3 * a / (2 * n * base))
    return np.array([side, base, height])


def _star_start(a: float, n: int) -> np.ndarray:
    inner_over_outer = 0.7
    outer = math.sqrt(0.8 * a / (n * inner_over_outer * math.sin(math.pi / n)))
    return np.array([outer, inner_over_outer * outer])


class History:
    """Every evaluation, appended as it completes (fsync'd), keyed by (integer, x)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.rows: list[dict[str, Any]] = []
        self.index: dict[tuple, dict[str, Any]] = {}
        if path.exists():
            for line in path.read_text().splitlines():
                try:
                    row = json.loads(line)
                except json.JSONDecodeError:
                    continue  # torn last line after a kill: that point is simply evaluated again
                self.rows.append(row)
                self.index[self.key(row["integer"], row["x"])] = row

    @staticmethod
    def key(n: int | None, x) -> tuple:
        return (n, tuple(round(float(v), 9) for v in x))

    def get(self, n: int | None, x) -> dict[str, Any] | None:
        return self.index.get(self.key(n, x))

    def add(self, row: dict[str, Any]) -> None:
        self.rows.append(row)
        self.index[self.key(row["integer"], row["x"])] = row
        with open(self.path, "a") as fh:
            fh.write(json.dumps(row) + "\n")
            fh.flush()
            os.fsync(fh.fileno())


@dataclass
class OptimiseResult:
    best: dict[str, Any] | None
    history: list[dict[str, Any]]
    out_dir: Path


def optimise(
    shape: str,
    max_area: float,
    settings: EvalSettings,
    out_dir: str | Path,
    *,
    algorithm: str = "LN_COBYLA",
    budget: int = 30,
    integer_values: tuple[int, ...] | None = None,
    evaluate_fn: Callable[[Candidate, EvalSettings], dict[str, Any]] | None = None,
    progress: bool = True,
) -> OptimiseResult:
    """Minimise the LST-averaged FoM of ``shape`` with metal area <= ``max_area`` (m^2)."""
    import nlopt

    if shape not in FAMILIES:
        raise ValueError(f"unknown shape family '{shape}'; choose one of {', '.join(FAMILIES)}")
    if not (math.isfinite(max_area) and max_area > 0):
        raise ValueError(f"--max-area must be a positive number of m^2, got {max_area}")
    if algorithm not in CONSTRAINED_ALGORITHMS:
        raise ValueError(f"algorithm {algorithm} does not take the area constraint; use one of "
                         f"{', '.join(CONSTRAINED_ALGORITHMS)}")
    if budget < 1:
        raise ValueError("--budget must be >= 1 evaluation")
    fam = FAMILIES[shape]
    ints: tuple = tuple(integer_values) if integer_values else (fam.integer_values or (None,))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    hist = History(out / "history.jsonl")
    evaluate_fn = evaluate_fn or (lambda c, s: evaluate(c, s, progress=False))
    per_run = max(1, budget // len(ints))
    penalty_floor = 1.0e4  # mK: far above any real FoM, and finite

    def penalty() -> float:
        finite = [r["fom_mk"] for r in hist.rows if r["status"] == "ok"]
        return max([penalty_floor] + [10 * f for f in finite])

    for n in ints:
        def objective(x: np.ndarray, grad: np.ndarray, n=n) -> float:
            if grad.size:
                grad[:] = 0.0
            seen = hist.get(n, x)
            if seen is not None:  # replay: nlopt sees exactly what it saw before
                return float(seen["objective"])
            t0 = time.perf_counter()
            row: dict[str, Any] = {"integer": n, "x": [float(v) for v in x],
                                   "params": dict(zip(fam.names, map(float, x))), "area_m2": float(fam.area(x, n))}
            if fam.integer:
                row["params"][fam.integer] = n
            bad = [g(x, n) for g in fam.validity if g(x, n) > 0]
            if bad or not np.all(np.isfinite(x)):
                row.update(status="invalid", fom_mk=None, error="outside the family's valid region")
            elif row["area_m2"] > max_area * (1 + 1e-9):
                row.update(status="over-budget", fom_mk=None, error="metal area above the budget")
            else:
                try:
                    plane = fam.build(x, n)
                    res = evaluate_fn(Candidate(f"{shape}-{len(hist.rows)}", plane=plane), settings)
                    fom = res.get("lst_averaged_fom_mk")
                    if res.get("status") == "ok" and fom is not None and math.isfinite(fom):
                        row.update(status="ok", fom_mk=float(fom), name=plane.describe())
                    else:
                        row.update(status="failed", fom_mk=None, error=str(res.get("error", "non-finite FoM")))
                except ShapeError as exc:
                    row.update(status="invalid", fom_mk=None, error=str(exc))
            row["objective"] = row["fom_mk"] if row["status"] == "ok" else penalty()
            row["seconds"] = round(time.perf_counter() - t0, 2)
            hist.add(row)
            if progress:
                f = f"{row['fom_mk']:.1f} mK" if row["fom_mk"] is not None else row["status"]
                print(f"  eval {len(hist.rows):3d} {fam.integer or ''}={n} x={np.round(x, 3).tolist()} "
                      f"area={row['area_m2']:.1f} -> {f}", file=sys.stderr)
            return float(row["objective"])

        opt = nlopt.opt(getattr(nlopt, algorithm), len(fam.names))
        opt.set_lower_bounds(list(fam.lower))
        opt.set_upper_bounds(list(fam.upper))
        opt.set_min_objective(objective)
        opt.add_inequality_constraint(lambda x, g, n=n: _zero(g) + fam.area(x, n) - max_area, 1e-6 * max_area)
        for v in fam.validity:
            opt.add_inequality_constraint(lambda x, g, v=v, n=n: _zero(g) + v(x, n), 1e-9)
        opt.set_maxeval(per_run)
        opt.set_xtol_rel(1e-3)
        x0 = np.clip(fam.start(max_area, n), fam.lower, fam.upper)
        if algorithm == "LN_COBYLA":
            opt.set_initial_step([0.15 * (u - l) for l, u in zip(fam.lower, fam.upper)])
        try:
            opt.optimize(x0)
        except (nlopt.RoundoffLimited, ValueError, RuntimeError) as exc:
            if progress:
                print(f"  nlopt stopped early for {fam.integer}={n}: {exc}", file=sys.stderr)

    ok = [r for r in hist.rows if r["status"] == "ok" and r["area_m2"] <= max_area * (1 + 1e-9)]
    best = min(ok, key=lambda r: r["fom_mk"]) if ok else None
    (out / "best.json").write_text(json.dumps(best, indent=1))
    return OptimiseResult(best, hist.rows, out)


def _zero(grad: np.ndarray) -> float:
    if grad.size:
        grad[:] = 0.0
    return 0.0


def best_plane(shape: str, best: dict[str, Any]) -> GroundPlane:
    fam = FAMILIES[shape]
    return fam.build(np.array(best["x"]), best["integer"])
