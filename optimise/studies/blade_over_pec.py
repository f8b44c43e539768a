"""The blade over infinite PEC: blade mesh and a grounded balun."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from groundplane import paper
from groundplane.design import Design, InfinitePEC
from solvers.engines.nec import NecSettings

from . import study
from ._common import (
    FREQS,
    fom_mk,
    solve,
)


def _calibrated_band(model, freqs) -> np.ndarray:
    """Engine process: a blade-over-PEC model's calibrated gain [f, 91, 360], frequency by
    frequency exactly as NecSolver does it (the model is its own calibration reference)."""
    from solvers.engines.base import mirror_quadrant
    from solvers.engines.nec.engine import solve_frequency

    step = NecSettings().far_field_step
    return mirror_quadrant(np.stack([solve_frequency((model, model, 91, step, None), float(f))[0] for f in freqs]))


def blade_over_pec(out: Path, command: str) -> None:
    """Is the gap to the paper's FEKO FoM over infinite PEC the blade mesh or the missing
    balun? The default blade, a finer one, and the default one with a grounded balun (two
    1 cm tubes from the panels' feed edges down to the ground, as the Roberts balun's
    outer conductors are)."""
    from solvers.engines.nec.engine import engine_call
    from solvers.engines.nec.mesh import pec_reference_model

    pec = Design(None, InfinitePEC())
    lines = ["# The blade over infinite PEC: blade mesh and balun", "",
             f"Command: `{command}` (cached solves; the balun variant "
             "re-solves, ~2 min).", "",
             "| model | segments | E width at 75 MHz (deg) | H width (deg) | LST-averaged FoM (mK) |",
             "|---|---|---|---|---|"]

    def row(label: str, beam) -> None:
        lines.append(f"| {label} | {beam.meta.get('n_segments', '-')} | {beam.beam_width_3db(75, 0):.1f} | "
                     f"{beam.beam_width_3db(75, 90):.1f} | {fom_mk(beam):.1f} |")
        (out / "blade_over_pec.md").write_text("\n".join(lines) + "\n")

    for cells in ((12, 10), (24, 18)):
        beam, _ = solve(pec, NecSettings(blade_cells=cells))
        row(f"{cells[0]} x {cells[1]} blade", beam)
    model = pec_reference_model(pec, NecSettings())
    # the tubes join the panels' inner edges at the feed; the model is folded (half plus
    # NEC's 180-degree rotation), so the tube at +gap/2 brings its image at -gap/2 with it
    tubes = [1.0] if model.sections == 2 else [1.0, -1.0]
    for sign in tubes:
        x = sign * pec.antenna.gap / 2
        model.add((x, 0.0, 0.0), (x, 0.0, pec.antenna.height), 0.01, 10)
    from groundplane.beam import Beam

    gain = engine_call(_calibrated_band, model, FREQS)
    row("12 x 10 blade + grounded balun tubes",
        Beam(FREQS, np.arange(91.0), np.arange(360.0), gain, {"n_segments": model.n_segments}))
    lines += ["", f"The paper's FEKO model (balun, top plate, shield, solid panels) gives {paper.PEC_FOM_MK} mK and "
                  f"{paper.BEAM_WIDTH_E_DEG:g} / {paper.BEAM_WIDTH_H_DEG:g} deg."]
    (out / "blade_over_pec.md").write_text("\n".join(lines) + "\n")


@study("blade-over-pec", "the blade over infinite PEC: blade mesh and a grounded balun")
def _run(out: Path, settings, command: str, **extra) -> None:
    blade_over_pec(out, command, **extra)
