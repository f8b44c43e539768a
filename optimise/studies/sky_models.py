"""Does a design choice depend on the sky model? The design study's nine rows (the same beams,
cached) scored on each sky: Haslam scaled by one spectral index (the paper's), GSM2008 and
LFSM; the FoM per row per sky, Spearman between skies, and the paper's three conclusions on
each. An achromatic row (one beam at every frequency) measures each sky's own spectral
structure: what no ground plane can remove.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from groundplane.beam import Beam
from groundplane.fom import figure_of_merit
from groundplane.sky import SKY_MODELS

from ..evaluate import Candidate, EvalSettings, candidate_beam
from ..provenance import header, write_md
from . import study
from ._common import verdict, write_csv
from .design_study import DESIGN_STUDY, conclusions

ACHROMATIC_FROM = ("square-10", 75.0)  # the row whose beam at this frequency is used at every frequency


def achromatic(beam: Beam, at_mhz: float) -> Beam:
    """``beam`` at one frequency, repeated at every frequency: no chromaticity at all."""
    k = int(np.argmin(np.abs(beam.freqs_mhz - at_mhz)))
    gain = np.repeat(beam.gain[k:k + 1], beam.freqs_mhz.size, axis=0)
    return Beam(beam.freqs_mhz, beam.theta_deg, beam.phi_deg, gain, {**beam.meta, "achromatic_at_mhz": at_mhz})


def sky_models(out: Path, settings: EvalSettings, command: str, skies: tuple[str, ...] = tuple(SKY_MODELS),
               progress: bool = True) -> list[dict]:
    """Score every design-study row on every sky; write sky_models.md/.csv."""
    from groundplane.shapes import preset

    out.mkdir(parents=True, exist_ok=True)
    rows = []
    beams = {}
    for name, paper_fom in DESIGN_STUDY:
        beams[name], _ = candidate_beam(Candidate(name, plane=preset(name)), settings, progress)  # cached solves
    src, at = ACHROMATIC_FROM
    beams[f"achromatic ({src} at {at:g} MHz)"] = achromatic(beams[src], at)
    for name, beam in beams.items():
        row = {"preset": name, "paper_fom_mk": dict(DESIGN_STUDY).get(name)}
        for sky in skies:
            row[sky] = round(figure_of_merit(beam, replace(settings.fom, sky=sky), progress=progress)
                             .lst_averaged_mk, 1)
        rows.append(row)
        write_csv(out / "sky_models.csv", rows)
    write_md(out / "sky_models.md", _markdown(rows, skies, settings, command), "study sky-models", command)
    return rows


def _markdown(rows: list[dict], skies: tuple[str, ...], settings: EvalSettings, command: str) -> str:
    from scipy.stats import spearmanr

    design = [r for r in rows if r["paper_fom_mk"] is not None]
    floor = next(r for r in rows if r["paper_fom_mk"] is None)
    lines = [header("study sky-models", command, settings.identity()), "# The design study on three sky models", "", f"Command: `{command}` (cached solves).", "",
             f"Settings: {settings.describe()}. Skies: `haslam` (408 MHz map x (nu/408)^-{settings.fom.beta:g}, the "
             "paper's), `gsm2008` and `lfsm` (maps at 40-100 and 408 MHz, each pixel a cubic spline in ln T - ln nu; "
             "`groundplane/sky.py`).", "",
             "| row | Table 3 (mK) | " + " | ".join(f"{s} (mK)" for s in skies) + " |", "|---|---|" + "---|" * len(skies)]
    for r in rows:
        lines.append(f"| {r['preset']} | {r['paper_fom_mk'] if r['paper_fom_mk'] is not None else '-'} | "
                     + " | ".join(f"{r[s]:.1f}" for s in skies) + " |")
    lines += ["", "Spearman rank correlation of the nine rows between skies (and with Table 3):", ""]
    cols = ["paper_fom_mk", *skies]
    for i, a in enumerate(cols):
        for b in cols[i + 1:]:
            rho = spearmanr([r[a] for r in design], [r[b] for r in design]).statistic
            lines.append(f"- {a.replace('paper_fom_mk', 'Table 3')} vs {b}: **{rho:+.2f}**")
    for s in skies:
        lines += ["", f"### The paper's conclusions on `{s}`", "", *conclusions(design, s)]
    lines += ["", "## Each sky's own structure", ""]
    for s in skies:
        best = min(r[s] for r in design)
        lines.append(f"- `{s}`: the achromatic row scores {floor[s]:.1f} mK, the best design {best:.1f} mK: " + verdict(
            floor[s] < 0.5 * best, "the sky's own structure is under half the best design's FoM, so the ranking is "
                                  "the ground planes'.",
            "the sky's own structure is at least half the best design's FoM: on this sky the FoM measures the sky "
            "model as much as the ground plane."))
    return "\n".join(lines) + "\n"


@study("sky-models", "the design study's rows scored on Haslam, GSM2008 and LFSM: does a design choice depend on "
       "the sky model?", uses_settings=True)
def _run(out: Path, settings: EvalSettings, command: str) -> None:
    for r in sky_models(out, settings, command):
        print(f"{r['preset']:32s} " + "  ".join(f"{k} {v}" for k, v in r.items() if k in SKY_MODELS))
