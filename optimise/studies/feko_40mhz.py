"""Our beams at 40 MHz against the FEKO low-band export (optional data in ../shared): NEC-2's
wire grid and the surface engine's sheet, over MRO soil."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from groundplane.comparison import direction_differences, shared_grid, upper_hemisphere_efficiency
from groundplane.design import Design, Soil
from groundplane.errors import UserInputError
from groundplane.plots import pyplot, save_figure
from groundplane.shapes import PRESETS
from solvers.engines import make_solver
from solvers.engines.nec import NecSettings

from ..provenance import write_md
from . import StudyOption, study
from ._common import engine_settings

FEKO_DIR = Path("../shared/data/beams")  # optional data beside a checkout; --feko-dir elsewhere
SHEET_HEIGHT = 0.005  # the sheet model of results/soil_surface.md (fixed there before this comparison)


@dataclass(frozen=True)
class Case:
    """One of our models of one preset, solved at 40 MHz."""

    preset: str
    engine: str
    spacing: float  # the plate mesh (NEC, surface) or the FDTD cell (m)
    refine: tuple[float, int] = (0.0, 1)  # NEC only: a finer grid inside HALF_WIDTH

    def settings(self):
        # the sheet 5 mm up; NEC's production plate is at the same height (its default)
        return engine_settings(self.engine, spacing=self.spacing, cell=self.spacing, refine_centre=self.refine,
                               plate_height=SHEET_HEIGHT)  # each engine takes what it has (fdtd: the cell)

    def label(self) -> str:
        return f"{self.preset}, {self.settings().label()}"


FEKO_CASES = [Case("square-10", "nec", sp) for sp in (1.0, 0.7, 0.5, 0.35, 0.25)] + [
    Case("square-10", "nec", 1.0, (2.0, 4)), Case("extended", "nec", 1.0), Case("extended", "nec", 0.5),
    Case("square-10", "surface", 0.7), Case("square-10", "surface", 0.5),
    Case("sawtooth-20-16", "surface", 0.7), Case("extended", "surface", 0.7), Case("extended", "surface", 0.5),
    Case("sawtooth-20-16", "fdtd", 0.075)]  # the referee (gprMax): a volume, time-domain model of the same plane
ELEVATIONS = (90, 60, 45, 30, 20, 10, 5)
ELEVATION_CUT_DEG = 10.0


def feko_40mhz(out: Path, command: str, feko_dir: Path | None = None) -> None:
    """Our beams at 40 MHz against the FEKO low-band-over-soil export in ../shared (the only
    full-wave beam of this antenna we have): which of our plate models is FEKO's, and by how much
    the others differ."""
    from solvers.io import load_beam

    feko_dir = Path(feko_dir or FEKO_DIR)
    files = sorted(feko_dir.glob("feko_lowband_soil_40MHz_*.ffe"))
    if len(files) != 4:
        raise UserInputError(f"feko-40mhz: need the four FEKO quadrant files in {feko_dir}; found {len(files)}")
    feko = load_beam(files)

    def cuts(b) -> dict:
        k = int(np.argmin(np.abs(b.freqs_mhz - 40.0)))
        db = 10 * np.log10(np.maximum(b.gain[k, :91], 1e-30))
        return {"E": b.beam_width_3db(40.0, 0), "H": b.beam_width_3db(40.0, 90), "db": db, "beam": b,
                "eff": float(upper_hemisphere_efficiency(b)[k])}

    ref = cuts(feko)
    rows = [("FEKO export", None, None, ref)]  # (label, engine, segments / unknowns, cuts)
    for case in FEKO_CASES:
        solver = make_solver(case.engine, case.settings(), workers=1, progress=True)
        beam = solver.solve(Design(PRESETS[case.preset], Soil()), [40.0])  # cached
        rows.append((case.label(), case.engine, beam.meta.get("n_segments", beam.meta.get("n_unknowns")), cuts(beam)))
    lines = [
        "# Our beams vs the FEKO low-band export at 40 MHz",
        "",
        f"Command: `{command}` (cached solves; reads the FEKO quadrants in `../shared/data/beams/`).",
        "The FEKO files do not say which ground plane they model; over soil the deployed low-band antenna "
        "sits on the `extended` plane. Our models: NEC-2's wire grid (production settings, "
        f"{NecSettings().plate_height * 1e3:g} mm above the soil) and the surface engine's solid sheet "
        f"{SHEET_HEIGHT * 1e3:g} mm above it (`results/soil_surface.md`), both on MRO soil. Efficiency = "
        "upper-hemisphere mean gain / 2 (1 = nothing lost in the soil). Differences from FEKO as "
        f"`groundplane compare` gives them: rms weighted by solid angle, and the largest, over the sky "
        f"{ELEVATION_CUT_DEG:g} deg or more above the horizon.",
        "",
        "| beam | segments / unknowns | E width (deg) | H width (deg) | efficiency | "
        + " | ".join(f"E {e} deg elev (dBi)" for e in ELEVATIONS) + " | " + " | ".join(f"H {e} deg" for e in ELEVATIONS)
        + " | rms dB vs FEKO | largest dB vs FEKO |",
        "|" + "---|" * (7 + 2 * len(ELEVATIONS)),
    ]
    diffs = {}
    for label, _, seg, c in rows:
        e_cut = [c["db"][90 - e, 0] for e in ELEVATIONS]
        h_cut = [c["db"][90 - e, 90] for e in ELEVATIONS]
        a, b = shared_grid([ref["beam"], c["beam"]], ["FEKO export", label])
        d = direction_differences(a, b, ELEVATION_CUT_DEG)  # groundplane compare's numbers
        diffs[label] = (float(d["rms_db"][0]), float(d["max_db"][0]))
        lines.append(f"| {label} | {seg or '-'} | {c['E']:.1f} | {c['H']:.1f} | {c['eff']:.3f} | "
                     + " | ".join(f"{v:.2f}" for v in e_cut) + " | " + " | ".join(f"{v:.2f}" for v in h_cut)
                     + f" | {diffs[label][0]:.2f} | {diffs[label][1]:.2f} |")
    lines += ["", "## Reading", "", *_reading(rows, diffs)]
    lines += ["", "![E- and H-plane cuts at 40 MHz](feko_40mhz.png)"]
    write_md(out / "feko_40mhz.md", "\n".join(lines) + "\n", "study feko-40mhz", command)
    _plot(rows, out / "feko_40mhz.png")


def _plot(rows: list, path: Path) -> None:
    """Gain cuts (top) and each model's difference from FEKO (bottom): NEC dashed, sheet solid."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
    elev = 90 - np.arange(91)
    ref = rows[0][3]["db"]
    colours = plt.get_cmap("tab20")
    for col, (phi, plane) in enumerate(((0, "E-plane"), (90, "H-plane"))):
        top, bottom = axes[0, col], axes[1, col]
        engines = list(dict.fromkeys(e for _, e, *_ in rows if e is not None))  # one line style per engine
        for k, (label, engine, _, c) in enumerate(rows):
            feko = engine is None
            style = dict(lw=2.4, color="k") if feko else dict(lw=1.1, color=colours(k % 20),
                                                               ls=("-", "--", ":", "-.")[engines.index(engine) % 4])
            top.plot(elev, c["db"][:, phi], label=label, **style)
            if not feko:
                bottom.plot(elev, c["db"][:, phi] - ref[:, phi], **style)
        top.set(title=f"{plane}, 40 MHz", ylim=(-30, 10))
        bottom.set(xlabel="elevation (deg)", ylim=(-4, 8))
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("gain (dBi)")
    axes[1, 0].set_ylabel("ours - FEKO (dB)")
    axes[0, 1].legend(fontsize=6.5, loc="lower right")
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)


def _reading(rows: list, diffs: dict[str, tuple[float, float]]) -> list[str]:
    """Which of our models is FEKO's, computed from the table."""
    best = min((label for label, *_ in rows[1:]), key=lambda k: diffs[k][0])
    c = next(c for label, _, _, c in rows if label == best)
    ref = rows[0][3]
    best_engine = next(engine for label, engine, *_ in rows if label == best)
    out = [f"- **Closest to FEKO: {best}**: rms {diffs[best][0]:.2f} dB, at most {diffs[best][1]:.2f} dB over "
           f"the sky above {ELEVATION_CUT_DEG:g} deg; widths {c['E']:.1f} / {c['H']:.1f} deg (FEKO {ref['E']:.1f} / {ref['H']:.1f}), "
           f"efficiency {c['eff']:.3f} (FEKO {ref['eff']:.3f})."]
    for engine in dict.fromkeys(e for _, e, *_ in rows[1:] if e != best_engine):  # each other engine's best
        closest = min((label for label, e, *_ in rows[1:] if e == engine), key=lambda k: diffs[k][0])
        out.append(f"- The {engine} engine comes no closer than {diffs[closest][0]:.2f} dB rms ({closest}).")
    others = [label for label, engine, *_ in rows[1:] if engine == best_engine and label != best]
    out += [f"- {label}: rms {diffs[label][0]:.2f} dB, at most {diffs[label][1]:.2f} dB." for label in others]
    return out


@study("feko-40mhz", "our beams (NEC grid, surface sheet) vs the FEKO low-band export at 40 MHz (needs the FEKO "
       "files; --feko-dir)", options=(StudyOption("--feko-dir", "feko_dir", "folder of the four FEKO quadrant files",
                                                  Path, "DIR"),))
def _run(out: Path, settings, command: str, **extra) -> None:
    feko_40mhz(out, command, **extra)
