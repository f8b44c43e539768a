"""The FDTD referee checked on what we hold before it referees: the blade alone (a lossless model
must radiate what it takes in), the blade over PEC against the surface engine (where both are
right, to the FoM), the absorbing layer's depth, and on a small plate over MRO soil the cell-size
ladder (10 / 7.5 / 5 cm) and the plate on the soil against one cell above it (the surface engine's
5 mm sheet lies between), and a ladder on a toothed plane (sawtooth-10-8), whose outline the grid
staircases. The FEKO 40 MHz comparison is a row of ``study feko-40mhz``."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from groundplane.comparison import direction_differences
from groundplane.design import Design, FreeSpace, InfinitePEC, Soil
from groundplane.options import parse_freqs
from groundplane.shapes import PRESETS
from solvers.engines.fdtd import FdtdSettings
from solvers.engines.surface import SurfaceSettings

from ..provenance import write_md
from . import study
from ._common import fom_and_binned_mk, solve, verdict, write_csv

BAND = np.asarray(parse_freqs("55:97:2"), float)  # the referee's frequencies
PEC_FREQS = np.arange(40.0, 101.0, 2.0)
PLATE = "square-10"
LADDER = (0.1, 0.075, 0.05)
TOOTHED = "sawtooth-10-8"  # a toothed outline, staircased by the grid where square-10's edges lie along it
TOOTHED_LADDER = (0.075, 0.05)


@dataclass(frozen=True)
class Check:
    """One FDTD model against one reference model of the same design."""

    case: str
    model: str
    design: Design
    fdtd: FdtdSettings
    reference: object  # the surface engine's settings, or an FDTD model (the finest cell)
    freqs: np.ndarray


def checks() -> list[Check]:
    """Every check, cheapest first."""
    blade_free, blade_pec = Design(None, FreeSpace()), Design(None, InfinitePEC())
    plate = Design(PRESETS[PLATE], Soil())
    surface = SurfaceSettings()
    out = [Check("blade in free space", "fdtd 5 cm", blade_free, FdtdSettings(cell=0.05), surface, PEC_FREQS)]
    out += [Check("blade over PEC", f"fdtd {c * 100:g} cm, {p} PML cells", blade_pec, FdtdSettings(cell=c, pml_cells=p),
                  surface, PEC_FREQS) for c, p in ((0.05, 10), (0.05, 20), (0.075, 20), (0.05, 40))]
    out += [Check(f"{PLATE} on MRO soil", f"fdtd {c * 100:g} cm, plate on the soil", plate, FdtdSettings(cell=c),
                  surface, BAND) for c in LADDER]
    out += [Check(f"{PLATE} on MRO soil", "fdtd 7.5 cm, plate one cell above", plate,
                  FdtdSettings(cell=0.075, plate_position="above"), surface, BAND)]
    toothed = Design(PRESETS[TOOTHED], Soil())
    out += [Check(f"{TOOTHED} on MRO soil", f"fdtd {c * 100:g} cm, plate on the soil", toothed, FdtdSettings(cell=c),
                  surface, BAND) for c in TOOTHED_LADDER]
    return out


def _row(check: Check, fdtd, ref) -> dict:
    d = direction_differences(ref, fdtd)
    every, binned = fom_and_binned_mk(fdtd)
    ref_every, ref_binned = fom_and_binned_mk(ref)
    balance = np.asarray(fdtd.meta["energy_balance"])
    return {"case": check.case, "model": check.model, "cells": fdtd.meta["n_cells"],
            "seconds": float(np.sum(fdtd.meta["seconds_per_frequency"])), "fom_mk": binned, "fom_every_lst_mk": every,
            "surface_fom_mk": ref_binned, "fom_change": binned / ref_binned - 1,
            "rms_db_mean": float(d["rms_db"].mean()), "rms_db_max": float(d["rms_db"].max()),
            "max_db": float(d["max_db"].max()), "balance_min": float(balance.min()), "balance_max": float(balance.max()),
            "loss_55_percent": 100 * float(fdtd.ground_loss()[0]), "surface_loss_55_percent": 100 * float(ref.ground_loss()[0])}


def _reading(rows: list[dict]) -> list[str]:
    """The checks' verdicts, conditions on the rows."""
    by = {(r["case"], r["model"]): r for r in rows}
    out = []
    free = by.get(("blade in free space", "fdtd 5 cm"))
    if free:
        out.append("- Lossless: the blade alone radiates " + verdict(
            free["balance_min"] > 0.995 and free["balance_max"] < 1.005, "what it accepts to within 0.5 %",
            "**not** what it accepts") + f" ({free['balance_min']:.4f}-{free['balance_max']:.4f}).")
    pec = [r for r in rows if r["case"] == "blade over PEC"]
    for r in pec:
        out.append(f"- Blade over PEC, {r['model']}: FoM {r['fom_mk']:.1f} mK against the surface engine's "
                   f"{r['surface_fom_mk']:.1f} ({100 * r['fom_change']:+.1f} %), gain {r['rms_db_mean']:.3f} dB rms: "
                   + verdict(abs(r["fom_change"]) < 0.05, "agrees.", "**does not agree** at the FoM level."))
    for plate in (PLATE, TOOTHED):
        ladder = [r for r in rows if r["case"].startswith(plate) and "on the soil" in r["model"]]
        if len(ladder) >= 2:
            foms = [r["fom_mk"] for r in ladder]
            step = abs(foms[-1] / foms[-2] - 1)
            out.append(f"- Cell ladder on {plate}: FoM " + " / ".join(f"{f:.1f}" for f in foms) + " mK at "
                       + " / ".join(r["model"].split(",")[0].removeprefix("fdtd ") for r in ladder)
                       + f" (the surface engine {ladder[-1]['surface_fom_mk']:.1f}); the last step moves it "
                       f"{100 * step:.1f} % (" + verdict(step < 0.05, "converged to 5 %", "**not converged** to 5 %")
                       + ").")
    above = by.get((f"{PLATE} on MRO soil", "fdtd 7.5 cm, plate one cell above"))
    on = by.get((f"{PLATE} on MRO soil", "fdtd 7.5 cm, plate on the soil"))
    if above and on:
        s = on["surface_fom_mk"]
        out.append(f"- The plate on the soil / one cell up at 7.5 cm: {on['fom_mk']:.1f} / {above['fom_mk']:.1f} mK, the "
                   f"surface engine's 5 mm sheet {s:.1f}: " + verdict(
                       min(on["fom_mk"], above["fom_mk"]) <= s <= max(on["fom_mk"], above["fom_mk"]),
                       "the sheet lies between the two, as its height does.",
                       "the sheet lies **outside** the bracket."))
    return out


def _markdown(rows: list[dict]) -> str:
    lines = ["# The FDTD referee checked", "", "gprMax FDTD against the surface engine (0.5 m, its defaults) on the same "
             "design and frequencies: blade cases 40-100 MHz every 2 MHz, the plate 55-97 MHz every 2 MHz (the "
             "referee's band); FoM in 2 h LST bins; gain differences over the sky above 10 deg, solid-angle weighted.",
             "", "| case | model | cells | run (s) | FoM (mK) | surface FoM (mK) | change | rms dB (mean / largest) | "
             "largest dB | radiated / accepted | loss 55 MHz (%) | surface loss (%) |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['case']} | {r['model']} | {r['cells'] / 1e6:.2f} M | {r['seconds']:.0f} | {r['fom_mk']:.1f} | "
              f"{r['surface_fom_mk']:.1f} | {100 * r['fom_change']:+.1f} % | {r['rms_db_mean']:.3f} / {r['rms_db_max']:.3f} | "
              f"{r['max_db']:.2f} | {r['balance_min']:.4f}-{r['balance_max']:.4f} | {r['loss_55_percent']:.3f} | "
              f"{r['surface_loss_55_percent']:.3f} |" for r in rows]
    return "\n".join(lines + ["", "## Reading (computed from the rows)", "", *_reading(rows)]) + "\n"


def referee_checks(out: Path, command: str) -> list[dict]:
    """Run every check (cached), rewriting the report after each."""
    rows = []
    for check in checks():
        fdtd, _ = solve(check.design, check.fdtd, check.freqs)
        ref, _ = solve(check.design, check.reference, check.freqs)
        rows.append(_row(check, fdtd, ref))
        write_csv(out / "referee_checks.csv", rows)
        write_md(out / "referee_checks.md", _markdown(rows), "study referee-checks", command)
    return rows


@study("referee-checks", "the FDTD referee against what we hold: the blade alone and over PEC (to the FoM), the "
       "absorbing layer, a cell ladder and the plate's height bracket on square-10 over MRO soil")
def _run(out: Path, settings, command: str) -> None:
    for r in referee_checks(out, command):
        print(f"{r['case']:24s} {r['model']:34s} {r['fom_mk']:8.1f} mK (surface {r['surface_fom_mk']:.1f})")
