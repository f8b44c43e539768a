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

import csv
from pathlib import Path

import numpy as np

from groundplane import paper
from groundplane.design import Design, Soil
from groundplane.fom import FomSettings, figure_of_merit
from groundplane.shapes import PRESETS
from solvers.engines.nec import NecSettings

from . import study
from ._common import efficiency, fom_mk, machine, narrow_rms, solve

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
             "narrow rms | efficiency at 75 MHz | FoM per LST (mK) | wall (s) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    rows = []
    for sp, h, r in grid:
        beam, secs = solve(Design(PRESETS[shape], Soil()), NecSettings(spacing=sp, plate_height=h, plate_wire_radius=r))
        res = figure_of_merit(beam, FomSettings())
        row = {"spacing_m": sp, "height_m": h, "radius_m": r, "segments": beam.meta["n_segments"],
               "fom_mk": res.lst_averaged_fom_mk, "smoothed12_mk": fom_mk(beam.frequency_smoothed(12)),
               "narrow_rms": narrow_rms(beam.upper_hemisphere()), "efficiency_75": efficiency(beam),
               "fom_lst_min_mk": float(np.min(res.fom)) * 1e3, "fom_lst_max_mk": float(np.max(res.fom)) * 1e3,
               "wall_s": secs}
        rows.append(row)
        lines.append(f"| {sp:g} | {h:g} | {r:g} | {row['segments']} | {row['fom_mk']:.1f} | "
                     f"{row['smoothed12_mk']:.1f} | {row['narrow_rms']:.1e} | {row['efficiency_75']:.3f} | "
                     f"{row['fom_lst_min_mk']:.0f}-{row['fom_lst_max_mk']:.0f} | {secs:.0f} |")
        (out / "plate_model.md").write_text("\n".join(lines) + "\n")
    with open(out / "plate_model.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


@study("plate-model", "square-10 over soil: plate height, wire radius and spacing, one at a time")
def _run(out: Path, settings, command: str, **extra) -> None:
    plate_model(out, command, **extra)
