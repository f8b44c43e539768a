"""Mesh convergence of the FoM on the engine and settings given: the chosen presets solved at
several plate meshes, how far each step to a finer mesh moves each FoM, and the coarsest mesh
at which the next finer one moves every preset's FoM by no more than a tolerance: the rule
that picks the default mesh (``--mesh``). Runs through the sweep machinery: cached and
resumable; rows shared with any other study at the same settings are not solved again."""
from __future__ import annotations

from pathlib import Path

from groundplane.shapes import preset

from ..evaluate import Candidate, EvalSettings
from ..provenance import header, write_md
from ..sweep import run_sweep
from . import study
from ._common import write_csv

PRESETS = ("square-10", "sawtooth-20-16", "square-30")  # the small, the best and the largest plate of Table 3
MESHES = (0.7, 0.5, 0.35)  # m, coarse to fine
TOLERANCE_PCT = 2.0


def convergence_rows(settings: EvalSettings, out: Path, presets=PRESETS, meshes=MESHES,
                     progress: bool = True) -> list[dict]:
    """One row per (preset, mesh): FoM, unknowns and solver time (cached solves)."""
    rows = []
    for mesh in sorted(meshes, reverse=True):
        at = settings.with_spacing(mesh)
        done = run_sweep([Candidate(p, plane=preset(p)) for p in presets], at, out / "mesh_convergence_runs" / f"{mesh:g}",
                         progress=progress, retry_failed=True)
        by_name = {r["name"]: r for r in done}
        for p in presets:
            r = by_name.get(p, {})
            ok = r.get("status") == "ok"
            rows.append({"preset": p, "mesh_m": mesh, "status": r.get("status", "not run"),
                         "fom_mk": round(r["lst_averaged_fom_mk"], 2) if ok else None,
                         "unknowns": r.get("n_unknowns") or r.get("n_segments"),
                         "solver_cpu_s": r.get("solver_cpu_s"), "error": r.get("error", "")})
    return rows


def steps(rows: list[dict]) -> list[dict]:
    """For each preset and each mesh with a finer one solved: the FoM change (%) to it."""
    out = []
    for p in dict.fromkeys(r["preset"] for r in rows):
        mine = sorted((r for r in rows if r["preset"] == p and r["fom_mk"] is not None), key=lambda r: -r["mesh_m"])
        for a, b in zip(mine, mine[1:]):
            out.append({"preset": p, "mesh_m": a["mesh_m"], "finer_m": b["mesh_m"],
                        "change_pct": 100 * (b["fom_mk"] / a["fom_mk"] - 1)})
    return out


def chosen_mesh(rows: list[dict], tolerance_pct: float = TOLERANCE_PCT) -> tuple[float | None, str]:
    """(the coarsest mesh whose step to the next finer one moves every preset's FoM by at most
    ``tolerance_pct``, or None; the sentence that says so, computed from the rows)."""
    presets = list(dict.fromkeys(r["preset"] for r in rows))
    st = steps(rows)
    meshes = sorted({s["mesh_m"] for s in st}, reverse=True)
    for m in meshes:
        here = [s for s in st if s["mesh_m"] == m]
        if len(here) == len(presets) and all(abs(s["change_pct"]) <= tolerance_pct for s in here):
            worst = max(here, key=lambda s: abs(s["change_pct"]))
            return m, (f"**{m:g} m** is the coarsest mesh at which the next finer one ({worst['finer_m']:g} m) moves "
                       f"every preset's FoM by at most {tolerance_pct:g} % (largest: {worst['preset']} "
                       f"{worst['change_pct']:+.1f} %).")
    if not st:
        return None, "No preset has been solved at two meshes yet: no mesh can be chosen."
    worst = min(meshes)
    here = [s for s in st if s["mesh_m"] == worst]
    moved = ", ".join(f"{s['preset']} {s['change_pct']:+.1f} %" for s in here)
    return None, (f"**No mesh meets the rule**: even the finest step ({worst:g} m -> finer) moves the FoM by "
                  f"{moved} (tolerance {tolerance_pct:g} %, {len(here)} of {len(presets)} presets solved there).")


def write(out: Path, settings: EvalSettings, command: str, rows: list[dict]) -> None:
    """The table (markdown with a provenance comment, and CSV) and the rule's verdict."""
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "mesh_convergence.csv", rows)
    meshes = sorted({r["mesh_m"] for r in rows}, reverse=True)
    presets = list(dict.fromkeys(r["preset"] for r in rows))
    at = {(r["preset"], r["mesh_m"]): r for r in rows}
    st = {(s["preset"], s["mesh_m"]): s for s in steps(rows)}
    mesh, verdict = chosen_mesh(rows)
    lines = [header("study mesh-convergence", command, settings.identity()),
             f"# Mesh convergence of the FoM: {', '.join(presets)}", "",
             f"Command: `{command}` (resumable; cached solves).", f"Settings: {settings.describe()}.", "",
             "| preset | " + " | ".join(f"{m:g} m: FoM (mK), change to next finer" for m in meshes)
             + " | unknowns | solver time (s, summed over frequencies) |",
             "|---|" + "---|" * len(meshes) + "---|---|"]
    for p in presets:
        cells = []
        for m in meshes:
            r = at.get((p, m))
            if r is None or r["fom_mk"] is None:
                cells.append(r["status"] if r else "-")
                continue
            s = st.get((p, m))
            cells.append(f"{r['fom_mk']:.1f}" + (f" ({s['change_pct']:+.1f} %)" if s else ""))
        unknowns = " / ".join(str(at[(p, m)]["unknowns"]) for m in meshes if (p, m) in at)
        cpu = " / ".join(f"{at[(p, m)]['solver_cpu_s']:.0f}" for m in meshes
                         if (p, m) in at and at[(p, m)]["solver_cpu_s"] is not None)
        lines.append(f"| {p} | " + " | ".join(cells) + f" | {unknowns} | {cpu} |")
    lines += ["", f"Rule: the default mesh is the coarsest at which the next finer one moves each preset's FoM "
              f"by <= {TOLERANCE_PCT:g} %.", "", verdict, ""]
    write_md(out / "mesh_convergence.md", "\n".join(lines) + "\n", "study mesh-convergence", command)


@study("mesh-convergence", "FoM vs plate mesh on square-10, sawtooth-20-16 and square-30; the mesh the "
       f"<= {TOLERANCE_PCT:g} % rule picks", uses_settings=True)
def _run(out: Path, settings: EvalSettings, command: str, **extra) -> None:
    rows = convergence_rows(settings, out)
    write(out, settings, command, rows)
    print((out / "mesh_convergence.md").read_text())
