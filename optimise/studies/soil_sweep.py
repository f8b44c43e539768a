"""The paper's soil study on ``square-10``: eps_r 2.5-5 at sigma 0.02 S/m and sigma
0.001-0.1 S/m at eps_r 3.5, through the sweep machinery (resumable, cached)."""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

from groundplane import paper
from groundplane.design import Soil
from groundplane.plots import pyplot
from groundplane.shapes import preset

from ..evaluate import Candidate, EvalSettings
from ..sweep import run_sweep
from . import study
from ._common import write_csv

EPS_R = paper.SOIL_SWEEP_EPS_R
SIGMA = paper.SOIL_SWEEP_SIGMA


@study("soil-sweep", "the paper's soil study: square-10 over eps_r 2.5-5 and sigma 0.001-0.1 S/m", uses_settings=True)
def _run(out: Path, settings: EvalSettings, command: str) -> None:
    for r in soil_sweep(settings, out, command, progress=True):
        print(r)


def soil_sweep(settings: EvalSettings, out_dir: str | Path, command: str, progress: bool = True) -> list[dict]:
    """square-10 under the paper's soil grid: eps_r 2.5-5 at sigma 0.02, sigma 0.001-0.1 at eps_r 3.5."""
    out = Path(out_dir)
    plane = preset("square-10")
    runs = [("eps_r", e, Soil(e, paper.MRO_SIGMA_S_PER_M)) for e in EPS_R] + [("sigma", s, Soil(paper.MRO_EPS_R, s)) for s in SIGMA]
    rows: list[dict[str, Any]] = []
    for kind, value, soil in runs:
        r = run_sweep([Candidate(f"square-10 {kind}={value:g}", plane=plane)], replace(settings, soil=soil),
                      out / "soil_sweep_runs", progress=progress, retry_failed=True)[0]
        rows.append({"varied": kind, "eps_r": soil.eps_r, "sigma": soil.sigma,
                     "fom_mk": r.get("lst_averaged_fom_mk"), "status": r.get("status")})
    write_csv(out / "soil_sweep.csv", rows)
    _soil_plot(rows, out / "soil_sweep.png")
    md = ["# Soil sweep on `square-10` (paper section 5) with NEC-2", "", f"Command: `{command}`.",
          f"Mesh: {json.dumps(settings.identity()['mesh'])}.", "",
          "| varied | eps_r | sigma (S/m) | LST-averaged FoM (mK) |", "|---|---|---|---|"]
    md += [f"| {r['varied']} | {r['eps_r']:g} | {r['sigma']:g} | "
           f"{'-' if r['fom_mk'] is None else format(r['fom_mk'], '.1f')} |" for r in rows]
    md += ["", "![soil sweep](soil_sweep.png)"]
    (out / "soil_sweep.md").write_text("\n".join(md) + "\n")
    return rows


def _soil_plot(rows: list[dict], path: Path) -> None:
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.8))
    e = [r for r in rows if r["varied"] == "eps_r" and r["fom_mk"] is not None]
    s = [r for r in rows if r["varied"] == "sigma" and r["fom_mk"] is not None]
    a.plot([r["eps_r"] for r in e], [r["fom_mk"] for r in e], "o-")
    a.set_xlabel("relative permittivity (sigma 0.02 S/m)")
    a.set_ylabel("LST-averaged FoM (mK)")
    b.semilogx([r["sigma"] for r in s], [r["fom_mk"] for r in s], "o-")
    b.set_xlabel("conductivity S/m (eps_r 3.5)")
    for ax in (a, b):
        ax.grid(alpha=0.3)
    fig.suptitle("square-10 over soil: FoM vs soil properties")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
