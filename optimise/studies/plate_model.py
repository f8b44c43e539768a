"""How the wire-grid plate is modelled over soil: height, wire radius and spacing, one at
a time, on ``square-10`` (issue: the plate model sets our FoM floor over soil).

SPEC section 2: the ground plane is a thin PEC sheet *on* the soil (a welded 5 cm mesh).
NEC-2 cannot put wires on the interface; they must stay at least 3 radii up. Each row
changes one thing against its neighbour, so height and radius are told apart. Columns:
FoM, FoM after a degree-12 smoothing of G(nu) per direction, the narrow-band structure
(`narrow rms`: rms(G - smoothed 12) / mean G over the upper hemisphere), the soil-loss
efficiency (upper-hemisphere mean gain / 2 at 75 MHz, calibrated) and the per-LST range.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from groundplane import paper
from groundplane.design import Design, Soil
from groundplane.fom import FomSettings, figure_of_merit, narrow_band_rms
from groundplane.shapes import PRESETS
from solvers.engines.nec import NecSettings

from ..provenance import write_md
from . import study
from ._common import efficiency, fom_mk, machine, solve, verdict, write_csv

# (spacing m, plate height m, wire radius m): radius at a fixed height, height at a fixed
# radius, the thickest wire NEC allows (r = h/3) as the plate comes down to the soil, then
# spacing at the lowest heights
GRID = (
    (0.5, 0.05, 0.01), (0.5, 0.05, 0.003),
    (0.5, 0.03, 0.003), (0.5, 0.02, 0.003), (0.5, 0.015, 0.003), (0.5, 0.01, 0.003),
    (0.5, 0.02, 0.001), (0.5, 0.01, 0.001), (0.5, 0.005, 0.001), (0.5, 0.003, 0.001),
    (0.5, 0.03, 0.01), (0.5, 0.02, 0.0066), (0.5, 0.005, 0.0016),
    (0.35, 0.01, 0.003), (0.35, 0.005, 0.001), (0.35, 0.005, 0.0016),
)


def plate_model(out: Path, command: str, grid=GRID, shape: str = "square-10") -> None:
    """Solve ``shape`` at every (spacing, height, radius) of ``grid``; a table and a CSV."""
    ref = paper.TABLE2_FOM_MK[paper.REFERENCE_SOLVER].get(shape, paper.TABLE3_FOM_MK.get(shape))
    lines = [f"# The plate model over soil: height, wire radius, spacing (`{shape}`)", "",
             f"Command: `{command}` (cached, resumable solves; 61 frequencies, 40-100 MHz).", "",
             f"Machine: {machine()}. Paper (FEKO, a sheet on the soil): {ref} mK.", "",
             "| spacing (m) | height (m) | wire radius (m) | segments | FoM (mK) | smoothed 12 (mK) | "
             "narrow rms | efficiency at 75 MHz | FoM per LST (mK) | NEC time (s) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    rows = []
    for sp, h, r in grid:
        beam, _ = solve(Design(PRESETS[shape], Soil()), NecSettings(spacing=sp, plate_height=h, plate_wire_radius=r))
        secs = float(sum(beam.meta["seconds_per_frequency"]))  # what the solve cost, cached or not
        res = figure_of_merit(beam, FomSettings().every_lst())
        row = {"spacing_m": sp, "height_m": h, "radius_m": r, "segments": beam.meta["n_segments"],
               "fom_mk": res.lst_averaged_mk, "smoothed12_mk": fom_mk(beam.frequency_smoothed(12)),
               "narrow_rms": narrow_band_rms(beam), "efficiency_75": efficiency(beam),
               "fom_lst_min_mk": float(np.min(res.fom)) * 1e3, "fom_lst_max_mk": float(np.max(res.fom)) * 1e3,
               "wall_s": secs}
        rows.append(row)
        lines.append(f"| {sp:g} | {h:g} | {r:g} | {row['segments']} | {row['fom_mk']:.1f} | "
                     f"{row['smoothed12_mk']:.1f} | {row['narrow_rms']:.1e} | {row['efficiency_75']:.3f} | "
                     f"{row['fom_lst_min_mk']:.0f}-{row['fom_lst_max_mk']:.0f} | {secs:.0f} |")
        write_md(out / "plate_model.md", "\n".join(lines) + "\n", "study plate-model", command)
    lines += _findings(rows)
    write_md(out / "plate_model.md", "\n".join(lines) + "\n", "study plate-model", command)
    write_csv(out / "plate_model.csv", rows)


FLAT = 0.05  # a step that moves the FoM by less than 5 % is "flat"


def _trend(values: list[float]) -> str:
    """How a series of FoMs moves, step by step (computed, for the findings)."""
    steps = [b / a - 1 for a, b in zip(values, values[1:])]
    if not steps:
        return "one row only."
    if all(x < 0 for x in steps):
        return verdict(abs(steps[-1]) < FLAT, f"the FoM falls at every step, the last by less than {FLAT:.0%}.",
                       f"the FoM falls at every step, the last by {abs(steps[-1]):.0%}.")
    if all(x > 0 for x in steps):
        return "the FoM rises at every step."
    k = int(np.argmax(np.abs(steps)))
    return f"not monotone; the largest step is {100 * steps[k]:+.0f} % (row {k + 1} -> {k + 2})."


def _findings(rows: list[dict]) -> list[str]:
    """What the table says: every sentence a condition on its rows."""
    f = {(r["spacing_m"], r["height_m"], r["radius_m"]): r for r in rows}

    def series(keys) -> tuple[str, list[float]]:
        have = [f[k]["fom_mk"] for k in keys if k in f]
        return " / ".join(f"{v:.0f}" for v in have), have

    d = NecSettings()
    out = ["", "## Findings", ""]
    for words, keys in (
            ("Height, 1 mm wires, 0.5 m: plate 2 / 1 / 0.5 / 0.3 cm up", [(0.5, h, 0.001) for h in (0.02, 0.01, 0.005, 0.003)]),
            ("Thickest wire NEC allows (r = h/3), 0.5 m: 3 / 2 / 1 / 0.5 cm",
             [(0.5, 0.03, 0.01), (0.5, 0.02, 0.0066), (0.5, 0.01, 0.003), (0.5, 0.005, 0.0016)]),
            ("3 mm wires, 5 / 3 / 2 / 1.5 / 1 cm", [(0.5, h, 0.003) for h in (0.05, 0.03, 0.02, 0.015, 0.01)])):
        text, values = series(keys)
        if values:
            out.append(f"- {words} -> {text} mK: {_trend(values)}")
    if (0.5, d.plate_height, d.plate_wire_radius) in f and (0.35, d.plate_height, d.plate_wire_radius) in f:
        a, b = f[(0.5, d.plate_height, d.plate_wire_radius)], f[(0.35, d.plate_height, d.plate_wire_radius)]
        out.append(f"- The default ({d.plate_height:g} m up, {d.plate_wire_radius:g} m wires): 0.5 m -> 0.35 m "
                   f"spacing moves the FoM {100 * (b['fom_mk'] / a['fom_mk'] - 1):+.1f} % ({a['fom_mk']:.1f} -> "
                   f"{b['fom_mk']:.1f} mK) and the efficiency {a['efficiency_75']:.3f} -> {b['efficiency_75']:.3f}.")
    old, low = f.get((0.5, 0.05, 0.01)), f.get((0.5, d.plate_height, d.plate_wire_radius))
    fine = f.get((0.35, d.plate_height, d.plate_wire_radius))
    if old and low and fine:
        out.append(f"- Against the earlier plate (5 cm up, 1 cm wires), the default's narrow-band structure "
                   f"{old['narrow_rms']:.1e} -> {low['narrow_rms']:.1e} ("
                   + verdict(low["narrow_rms"] < old["narrow_rms"], "less", "not less")
                   + f") and efficiency {old['efficiency_75']:.3f} -> {low['efficiency_75']:.3f} at 0.5 m ("
                   + verdict(low["efficiency_75"] < old["efficiency_75"], "it leaks more into the soil",
                             "it does not leak more") + f"); at 0.35 m {fine['efficiency_75']:.3f}.")
    out.append("- The default was chosen by this table's convergence (the lowest height at which halving it "
               "again moves the FoM by ~5 %, and the thickest wire it allows), not by the paper's value, "
               "which the header shows for orientation; Table 3 (`results/design_study_nec/design_study.md`) is the check.")
    return out


@study("plate-model", "square-10 over soil: plate height, wire radius and spacing, one at a time")
def _run(out: Path, settings, command: str, **extra) -> None:
    plate_model(out, command, **extra)
