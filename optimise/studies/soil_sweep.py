"""The paper's soil study (section 5): ``square-10`` over eps_r 2.5-5 at sigma 0.02 S/m and
sigma 0.001-0.1 S/m at eps_r 3.5, and the extended plane at the conductivity range's ends, which tests the
paper's remark that the smaller plane's beam is the more sensitive to the soil. Through the
sweep machinery (resumable, cached), with whichever engine the settings name."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from groundplane import paper
from groundplane.design import Soil
from groundplane.plots import pyplot, save_figure
from groundplane.shapes import preset

from ..evaluate import Candidate, EvalSettings
from ..provenance import write_md
from ..sweep import run_sweep
from . import study
from ._common import write_csv

EPS_R = paper.SOIL_SWEEP_EPS_R
SIGMA = paper.SOIL_SWEEP_SIGMA
PLANES = ("square-10", "extended")
# the extended plane (7300 unknowns on the sheet model, ~5x square-10's cost per frequency:
# 42 vs 9 s, results/soil_surface.md)
# at MRO and the ends of the conductivity range only: the paper finds the beam "not very
# sensitive to the relative permittivity", and conductivity moves square-10 most
EXTENDED_SOILS = ((paper.MRO_EPS_R, paper.MRO_SIGMA_S_PER_M), (paper.MRO_EPS_R, SIGMA[0]), (paper.MRO_EPS_R, SIGMA[-1]))


@study("soil-sweep", "the paper's soil study: square-10 over eps_r 2.5-5 and sigma 0.001-0.1 S/m, the extended "
       "plane at the ends of the sigma range", uses_settings=True)
def _run(out: Path, settings: EvalSettings, command: str) -> None:
    for r in soil_sweep(settings, out, command, progress=True):
        print(r)


def runs() -> list[tuple[str, str, Soil]]:
    """(plane, varied, soil) in solve order: the square-10 grid, then the extended plane."""
    grid = [("eps_r", Soil(e, paper.MRO_SIGMA_S_PER_M)) for e in EPS_R] + [("sigma", Soil(paper.MRO_EPS_R, s)) for s in SIGMA]
    out = [("square-10", kind, soil) for kind, soil in grid]
    return out + [("extended", kind, soil) for kind, soil in grid if kind == "sigma"
                  and (soil.eps_r, soil.sigma) in EXTENDED_SOILS]


def soil_sweep(settings: EvalSettings, out_dir: str | Path, command: str, progress: bool = True) -> list[dict]:
    """Solve and score every run twice: every 1 deg of LST and in the paper's 2 h LST bins."""
    out = Path(out_dir)
    # the two FoM columns whatever --lst-bin says: every LST, and the paper's 2 h bins
    every = replace(settings, fom=settings.fom.every_lst())
    binned = replace(settings, fom=replace(settings.fom, lst_bin_hours=paper.DATA_LST_BIN_HOURS))
    rows: list[dict[str, Any]] = []
    for plane, kind, soil in runs():
        c = [Candidate(f"{plane} {kind}={soil.eps_r if kind == 'eps_r' else soil.sigma:g}", plane=preset(plane))]
        r, b = (run_sweep(c, replace(s, soil=soil), out / "soil_sweep_runs", progress=progress, retry_failed=True)[0]
                for s in (every, binned))
        rows.append({"plane": plane, "varied": kind, "eps_r": soil.eps_r, "sigma": soil.sigma,
                     "fom_mk": r.get("lst_averaged_fom_mk"), "fom_binned_mk": b.get("lst_averaged_fom_mk"),
                     "status": r.get("status")})
    write_csv(out / "soil_sweep.csv", rows)
    _soil_plot(rows, out / "soil_sweep.png")
    md = [f"# Soil sweep (paper section 5): `square-10` and the extended plane, engine {settings.engine}", "",
          f"Command: `{command}` (resumable; cached solves).", "",
          f"Model: {settings.describe()}.",
          "FoM: every 1 deg of LST (SPEC section 3), and with the spectra averaged into 2 h LST bins (the paper's "
          "binning when it compares simulations with data, section 6; `results/soil_surface.md`). The paper "
          "shows this sweep only as residual differences from the data (its Figure 12), with no FoM per soil; "
          "it notes the 10 m plane's beam is the more sensitive to the soil.", "",
          "| plane | varied | eps_r | sigma (S/m) | FoM (mK) | FoM, 2 h LST bins (mK) |", "|---|---|---|---|---|---|"]
    md += [f"| {r['plane']} | {r['varied']} | {r['eps_r']:g} | {r['sigma']:g} | {_mk(r['fom_mk'])} | "
           f"{_mk(r['fom_binned_mk'])} |" for r in rows]
    md += ["", "## Reading", "", *_reading(rows), "", "![soil sweep](soil_sweep.png)"]
    write_md(out / "soil_sweep.md", "\n".join(md) + "\n", "study soil-sweep", command, settings.identity())
    return rows


def _mk(v: float | None) -> str:
    return "-" if v is None else f"{v:.1f}"


def _reading(rows: list[dict]) -> list[str]:
    """How far each plane's FoM moves over each of the paper's ranges (computed from the rows)."""
    out = []
    for kind, unit in (("sigma", "S/m"), ("eps_r", "")):
        for column, what in (("fom_mk", "every 1 deg of LST"), ("fom_binned_mk", "2 h LST bins")):
            parts = []
            for plane in PLANES:
                v = {r[kind]: r[column] for r in rows if r["plane"] == plane and r["varied"] == kind
                     and r[column] is not None}
                mro = v.get(paper.MRO_SIGMA_S_PER_M if kind == "sigma" else paper.MRO_EPS_R)
                if len(v) > 1 and mro:
                    parts.append(f"`{plane}` {min(v.values()):.1f}-{max(v.values()):.1f} mK "
                                 f"({100 * (max(v.values()) - min(v.values())) / mro:.0f} % of its MRO value)")
            if parts:
                lo, hi = (SIGMA[0], SIGMA[-1]) if kind == "sigma" else (EPS_R[0], EPS_R[-1])
                out.append(f"- {kind} {lo:g}-{hi:g}{' ' + unit if unit else ''}, {what}: " + "; ".join(parts) + ".")
    return out


def _soil_plot(rows: list[dict], path: Path) -> None:
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    for plane, marker in zip(PLANES, "os"):
        for column, style in (("fom_mk", "-"), ("fom_binned_mk", "--")):
            label = f"{plane}, {'every 1 deg LST' if column == 'fom_mk' else '2 h LST bins'}"
            for ax, kind in ((a, "eps_r"), (b, "sigma")):
                pts = sorted((r[kind], r[column]) for r in rows if r["plane"] == plane and r["varied"] == kind
                             and r[column] is not None)
                if pts:
                    ax.plot(*zip(*pts), marker + style, label=label)
    a.set_xlabel(f"relative permittivity (sigma {paper.MRO_SIGMA_S_PER_M:g} S/m)")
    a.set_ylabel("LST-averaged FoM (mK)")
    b.set_xscale("log")
    b.set_xlabel(f"conductivity S/m (eps_r {paper.MRO_EPS_R:g})")
    for ax in (a, b):
        ax.grid(alpha=0.3)
    b.legend(fontsize=7)
    fig.suptitle("FoM vs soil properties")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
