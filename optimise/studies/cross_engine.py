"""NEC-2 (wire grids) against the surface engine (solid plates, RWG) on the cases both can
do: the blade over infinite PEC, and a finite plate above PEC ground (the paper's Table 2
method: one antenna, several solvers, side by side)."""
from __future__ import annotations

import csv
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from groundplane import paper
from groundplane.beam import Beam
from groundplane.design import Design, InfinitePEC
from groundplane.shapes import PRESETS
from solvers.engines import make_solver
from solvers.engines.nec import NecSettings
from solvers.engines.surface import SurfaceSettings

from . import study
from ._common import FREQS, fom_mk, machine

PLATE = "square-10"
PLATE_HEIGHT_M = 0.05


@dataclass(frozen=True)
class Case:
    """One model of one design: which engine, with which settings."""

    case: str
    model: str
    design: Design
    engine: str
    settings: object


def cases(plate_mesh: float, blade_cells_fine: tuple[int, int] = (24, 20)) -> list[Case]:
    """The blade over PEC (NEC; the surface engine at two blade meshes) and ``PLATE``
    ``PLATE_HEIGHT_M`` above PEC ground (both engines at ``plate_mesh``)."""
    blade = Design(None, InfinitePEC())
    plate = Design(PRESETS[PLATE], InfinitePEC())
    return [
        Case("blade over PEC", "NEC-2, 12 x 10 wire-grid panels", blade, "nec", NecSettings()),
        Case("blade over PEC", "surface, 12 x 10 solid panels", blade, "surface", SurfaceSettings()),
        Case("blade over PEC", f"surface, {blade_cells_fine[0]} x {blade_cells_fine[1]} solid panels", blade,
             "surface", SurfaceSettings(blade_cells=blade_cells_fine)),
        Case(f"{PLATE} {PLATE_HEIGHT_M * 100:g} cm above PEC", f"NEC-2, {plate_mesh:g} m wire grid", plate, "nec",
             NecSettings(spacing=plate_mesh, plate_height=PLATE_HEIGHT_M)),
        Case(f"{PLATE} {PLATE_HEIGHT_M * 100:g} cm above PEC", f"surface, {plate_mesh:g} m triangles", plate,
             "surface", SurfaceSettings(spacing=plate_mesh, plate_height=PLATE_HEIGHT_M)),
    ]


def _size(beam: Beam) -> str:
    if "n_segments" in beam.meta:
        return f"{beam.meta['n_segments']} segments"
    return f"{beam.meta.get('n_unknowns', '?')} unknowns"


def _row(c: Case, beam: Beam, ref: Beam | None) -> dict:
    zen = beam.gain[:, 0, 0]
    row = {
        "case": c.case, "model": c.model, "size": _size(beam),
        "fom_mk": fom_mk(beam),
        "e_width_deg": beam.beam_width_3db(paper.BEAM_WIDTH_FREQ_MHZ, 0),
        "h_width_deg": beam.beam_width_3db(paper.BEAM_WIDTH_FREQ_MHZ, 90),
        "zenith_gain_75": float(zen[np.argmin(np.abs(beam.freqs_mhz - 75))]),
        "seconds_per_frequency": float(np.mean(beam.meta["seconds_per_frequency"])),
        "mean_gain_range": "-",
        "fom_vs_nec": "-", "zenith_vs_nec_max": "-",
    }
    if "energy_balance" in beam.meta:
        m = np.asarray(beam.meta["energy_balance"])
        row["mean_gain_range"] = f"{m.min():.4f}-{m.max():.4f}"
    if ref is not None:
        row["fom_vs_nec"] = f"{row['fom_mk'] / fom_mk(ref) - 1:+.1%}"
        dev = zen / ref.gain[:, 0, 0] - 1
        k = int(np.argmax(np.abs(dev)))
        row["zenith_vs_nec_max"] = f"{dev[k]:+.1%} at {beam.freqs_mhz[k]:g} MHz"
    return row


def _plot(beams: list[tuple[Case, Beam]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from groundplane.plots import save_figure

    groups = list(dict.fromkeys(c.case for c, _ in beams))
    fig, axes = plt.subplots(1, len(groups), figsize=(6 * len(groups), 4), squeeze=False)
    for ax, g in zip(axes[0], groups):
        for c, b in beams:
            if c.case == g:
                ax.plot(b.freqs_mhz, b.gain[:, 0, 0], label=c.model, lw=1.2)
        ax.set(title=g, xlabel="frequency (MHz)", ylabel="zenith gain (linear)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def cross_engine(out: Path, command: str, plate_mesh: float = 0.35, workers: int = 2) -> None:
    """Solve every case (cached, resumable), then tabulate FoM, widths, zenith gain against
    NEC per frequency, energy balance and cost."""
    rows, beams = [], []
    nec_ref: dict[str, Beam] = {}
    for c in cases(plate_mesh):
        beam = make_solver(c.engine, c.settings, workers=workers, progress=True).solve(c.design, FREQS)
        beams.append((c, beam))
        if c.engine == "nec":
            nec_ref[c.case] = beam
        rows.append(_row(c, beam, None if c.engine == "nec" else nec_ref.get(c.case)))
        _write(out, command, rows, plate_mesh)
    _plot(beams, out / "cross_engine.png")
    _write(out, command, rows, plate_mesh, done=True)


def _write(out: Path, command: str, rows: list[dict], plate_mesh: float, done: bool = False) -> None:
    with open(out / "cross_engine.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = [
        "# NEC-2 against the surface engine (RWG) on the cases both can do",
        "",
        f"Command: `{command}` (cached, resumable solves). Machine: {machine()}.",
        f"Frequencies: {FREQS[0]:g}-{FREQS[-1]:g} MHz in 1 MHz steps for every model (FoMs compared on identical "
        "frequencies); FoM with the paper's settings. NEC is gain-calibrated on the blade over PEC "
        "(solvers/engines/nec/solver.py); the surface engine is not calibrated: its mean gain over the upper "
        "hemisphere (the energy balance, 2 for a lossless model) is shown instead.",
        f"Plate case: `{PLATE}` {PLATE_HEIGHT_M:g} m above infinite PEC ground, both engines at a {plate_mesh:g} m mesh.",
        "",
        "| case | model | size | FoM (mK) | FoM vs NEC | zenith gain vs NEC, largest | E / H width at 75 MHz (deg) "
        "| mean gain (energy) | s per frequency |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['case']} | {r['model']} | {r['size']} | {r['fom_mk']:.1f} | {r['fom_vs_nec']} | "
                     f"{r['zenith_vs_nec_max']} | {r['e_width_deg']:.1f} / {r['h_width_deg']:.1f} | "
                     f"{r['mean_gain_range']} | {r['seconds_per_frequency']:.1f} |")
    lines += ["", f"Paper (Table 1/2, FEKO): blade over PEC {paper.PEC_FOM_MK} mK, widths "
                  f"{paper.BEAM_WIDTH_E_DEG:g} / {paper.BEAM_WIDTH_H_DEG:g} deg."]
    if done:
        lines += ["", "![zenith gain](cross_engine.png)"]
    else:
        lines += ["", "(in progress: rows are added as their solves finish)"]
    (out / "cross_engine.md").write_text("\n".join(lines) + "\n")
    (out / "cross_engine.json").write_text(json.dumps(rows, indent=1))


@study("cross-engine", "NEC-2 vs the surface (RWG) engine: blade over PEC, square-10 5 cm above PEC")
def _run(out: Path, settings, command: str, **extra) -> None:
    cross_engine(out, command, **extra)
