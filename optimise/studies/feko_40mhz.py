"""Our NEC beams at 40 MHz against the FEKO low-band export (optional data in ../shared)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from groundplane.design import Design, Soil
from groundplane.errors import UserInputError
from groundplane.plots import pyplot
from groundplane.shapes import PRESETS
from solvers.engines.nec import NecSettings

from . import study
from ._common import (
    cached,
    solve,
)

FEKO_DIR = Path("../shared/data/beams")  # optional data beside a checkout; --feko-dir elsewhere
FEKO_CASES = [("square-10", 1.0, 0.0, 1), ("square-10", 0.7, 0.0, 1), ("square-10", 0.5, 0.0, 1),
              ("square-10", 0.35, 0.0, 1), ("square-10", 0.25, 0.0, 1), ("square-10", 1.0, 2.0, 4),
              ("extended", 1.0, 0.0, 1), ("extended", 0.5, 0.0, 1)]


def feko_40mhz(out: Path, command: str, feko_dir: Path | None = None) -> None:
    """Our NEC beams at 40 MHz against the FEKO low-band-over-soil export in ../shared (the
    only full-wave beam of this antenna we have): where and by how much the wire grid differs."""
    from solvers.io import load_beam

    feko_dir = Path(feko_dir or FEKO_DIR)
    files = sorted(feko_dir.glob("feko_lowband_soil_40MHz_*.ffe"))
    if len(files) != 4:
        raise UserInputError(f"feko-40mhz: need the four FEKO quadrant files in {feko_dir}; found {len(files)}")
    feko = load_beam(files)
    elev = [90, 60, 45, 30, 20, 10, 5]

    def cuts(b) -> dict:
        g = b.gain[int(np.argmin(np.abs(b.freqs_mhz - 40.0)))]
        db = 10 * np.log10(np.maximum(g[:91], 1e-30))
        w = b.solid_angle_weights()[:91]
        return {"E": b.beam_width_3db(40.0, 0), "H": b.beam_width_3db(40.0, 90), "db": db,
                "eff": float((g[:91] * w).sum() / w.sum() / 2)}

    ref = cuts(feko)
    rows = [("FEKO export", None, ref)]
    for name, sp, hw, k in FEKO_CASES:
        mesh = NecSettings(spacing=sp, refine_centre=(hw, k))
        design = Design(PRESETS[name], Soil())
        beam = cached(design, mesh)
        if beam is None:  # no full-band solve cached: solve 40 MHz alone
            beam, _ = solve(design, mesh, [40.0])
        label = f"NEC {name}, {sp:g} m" + (f", {sp / k:g} m inside {hw:g} m" if mesh.refined else "")
        rows.append((label, beam.meta.get("n_segments"), cuts(beam)))
    lines = [
        "# NEC-2 beams vs the FEKO low-band export at 40 MHz",
        "",
        f"Command: `{command}` (cached solves; reads the FEKO quadrants in "
        "`../shared/data/beams/`).",
        "The FEKO files do not say which ground plane they model; over soil the deployed low-band antenna "
        "sits on the `extended` plane. Efficiency = upper-hemisphere mean gain / 2 (1 = nothing lost in the soil).",
        "",
        "| beam | segments | E width (deg) | H width (deg) | efficiency | "
        + " | ".join(f"E {e} deg elev (dBi)" for e in elev) + " | " + " | ".join(f"H {e} deg" for e in elev)
        + " | rms dB vs FEKO, elev >= 10 deg |",
        "|" + "---|" * (6 + 2 * len(elev)),
    ]
    for label, seg, c in rows:
        e_cut = [c["db"][90 - e, 0] for e in elev]
        h_cut = [c["db"][90 - e, 90] for e in elev]
        rms = float(np.sqrt(np.mean((c["db"][:81] - ref["db"][:81]) ** 2)))
        lines.append(f"| {label} | {seg or '-'} | {c['E']:.1f} | {c['H']:.1f} | {c['eff']:.3f} | "
                     + " | ".join(f"{v:.2f}" for v in e_cut) + " | " + " | ".join(f"{v:.2f}" for v in h_cut)
                     + f" | {rms:.2f} |")
    (out / "feko_40mhz.md").write_text("\n".join(lines) + "\n")
    plt = pyplot()

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for ax, phi, plane in ((axes[0], 0, "E-plane"), (axes[1], 90, "H-plane")):
        for label, _, c in rows:
            ax.plot(90 - np.arange(91), c["db"][:, phi], lw=2.2 if label.startswith("FEKO") else 1.0,
                    color="k" if label.startswith("FEKO") else None, label=label)
        ax.set_title(f"{plane}, 40 MHz")
        ax.set_xlabel("elevation (deg)")
        ax.set_ylim(-30, 10)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("gain (dBi)")
    axes[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "feko_40mhz.png", dpi=120)
    plt.close(fig)


@study("feko-40mhz", "NEC beams vs the FEKO low-band export at 40 MHz (needs the FEKO files; --feko-dir)")
def _run(out: Path, settings, command: str, **extra) -> None:
    feko_40mhz(out, command, **extra)
