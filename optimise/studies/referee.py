"""The referee: the surface engine, NEC-2 and gprMax's FDTD (three methods that share nothing:
a solid-sheet MoM, a wire-grid MoM, a volume time-domain grid) side by side on the designs
whose ranking the two MoM engines disagree on, on identical frequencies and grids: gain
differences per frequency, FoM in 2 h LST bins, the candidate's margin, ground loss, S11.

Each FDTD beam is also written beside the report (``beams/``) and read back when its cache
key matches, so a run of hours is never repeated on another machine. The report is rewritten
after every case: it states what has landed and which cases are still to run.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from groundplane import paper
from groundplane.beam import Beam, BeamFormatError
from groundplane.comparison import direction_differences
from groundplane.design import Design, Soil
from groundplane.errors import UserInputError
from groundplane.options import parse_freqs
from groundplane.s11 import db, input_impedance, reflection
from groundplane.shapes import GroundPlane, from_file, preset
from solvers.engines import make_solver

from ..provenance import write_md
from . import StudyOption, study
from ._common import cached, engine_settings, fom_and_binned_mk, solve, verdict, write_csv

ENGINES = ("surface", "nec", "fdtd")
SOILS = {"MRO": Soil(paper.MRO_EPS_R, paper.MRO_SIGMA_S_PER_M), "dry": Soil(2.5, 0.005)}
DEFAULT_FREQS = "55:97:2"
DEFAULT_CELL = 0.075
TABLE3_CASES = ("square-30", "plus-30")


@dataclass(frozen=True)
class RefereeCase:
    """One plane on one soil, solved by every engine."""

    name: str
    plane: GroundPlane
    soil_name: str

    @property
    def design(self) -> Design:
        return Design(self.plane, SOILS[self.soil_name])

    @property
    def slug(self) -> str:
        return re.sub(r"[^A-Za-z0-9.-]+", "_", f"{self.name}_{self.soil_name}")


def referee_cases(candidate: GroundPlane, candidate_name: str, reference: str) -> list[RefereeCase]:
    """The reference and the candidate on MRO soil, then on the dry corner, then Table 3's two
    planes our model puts at 0.6x the paper (MRO): cheapest verdict first."""
    ref = preset(reference)
    out = [RefereeCase(n, p, s) for s in ("MRO", "dry") for n, p in ((reference, ref), (candidate_name, candidate))]
    return out + [RefereeCase(name, preset(name), "MRO") for name in TABLE3_CASES]


def _fdtd_beam(case: RefereeCase, settings, freqs: np.ndarray, beams: Path, cached_only: bool = False) -> Beam | None:
    """The FDTD beam: the one kept beside the report when its cache key is this solve's, else the
    cache's, else solved (None with ``cached_only``)."""
    solver = make_solver("fdtd", settings, progress=True)
    key = solver.cache_key(case.design, freqs)
    kept = beams / f"{case.slug}.npz"
    if kept.exists():
        try:
            beam = Beam.load(kept)
            if beam.meta.get("cache_key") == key:
                return beam
        except BeamFormatError:
            pass
    if cached_only:
        return solver.cached(case.design, freqs)
    beam, _ = solve(case.design, settings, freqs)
    beams.mkdir(parents=True, exist_ok=True)
    beam.save(kept)
    return beam


def _summary(beam: Beam) -> dict:
    """FoM (2 h bins and every LST), ground loss and match of one engine's beam."""
    every, binned = fom_and_binned_mk(beam)
    loss = beam.ground_loss()
    z = input_impedance(beam)
    s11 = db(reflection(z)) if z is not None else np.full(beam.freqs_mhz.size, np.nan)
    return {"fom_mk": binned, "fom_every_lst_mk": every, "loss_55_percent": 100 * float(loss[0]),
            "loss_max_percent": 100 * float(loss.max()), "s11_max_db": float(np.nanmax(s11)),
            "s11_min_db": float(np.nanmin(s11))}


def _bins(beam: Beam) -> np.ndarray:
    from groundplane.fom import FomSettings, figure_of_merit

    return 1e3 * figure_of_merit(beam, FomSettings().every_lst()).in_lst_bins(paper.DATA_LST_BIN_HOURS).fom


def _run_case(case: RefereeCase, freqs: np.ndarray, cell: float, beams: Path,
              cached_only: bool = False) -> tuple[list, list, list] | None:
    """(rows per engine, gain differences per pair and frequency, FoM per LST bin) of one case; None
    when ``cached_only`` and some engine has not solved it."""
    solved = {}
    for engine in ENGINES:
        settings = engine_settings(engine, cell=cell)
        if engine == "fdtd":
            solved[engine] = _fdtd_beam(case, settings, freqs, beams, cached_only)
        else:
            solved[engine] = cached(case.design, settings, freqs) if cached_only else solve(case.design, settings, freqs)[0]
    if any(b is None for b in solved.values()):
        return None
    rows = [{"case": case.name, "soil": case.soil_name, "engine": e, **_summary(b)} for e, b in solved.items()]
    diffs = []
    for a, b in (("surface", "fdtd"), ("nec", "fdtd"), ("surface", "nec")):
        d = direction_differences(solved[a], solved[b])
        diffs += [{"case": case.name, "soil": case.soil_name, "pair": f"{b} vs {a}", "freq_mhz": float(f),
                   "rms_db": float(r), "max_db": float(m)} for f, r, m in zip(freqs, d["rms_db"], d["max_db"])]
    bins = [{"case": case.name, "soil": case.soil_name, "engine": e, "lst_bin": i, "fom_mk": float(v)}
            for e, b in solved.items() for i, v in enumerate(_bins(b))]
    return rows, diffs, bins


def _row(rows: list[dict], case: str, soil: str, engine: str) -> dict | None:
    return next((r for r in rows if (r["case"], r["soil"], r["engine"]) == (case, soil, engine)), None)


def _pct(x: float) -> str:
    return f"{100 * x:+.1f} %"


def _margins(rows: list[dict], candidate: str, reference: str) -> list[dict]:
    """Per soil and engine with both designs solved: the candidate's margin 1 - FoM_c / FoM_ref."""
    out = []
    for soil in SOILS:
        for e in ENGINES:
            c, r = _row(rows, candidate, soil, e), _row(rows, reference, soil, e)
            if c and r:
                out.append({"soil": soil, "engine": e, "reference_mk": r["fom_mk"], "candidate_mk": c["fom_mk"],
                            "margin": 1 - c["fom_mk"] / r["fom_mk"]})
    return out


def _margin_reading(margins: list[dict], candidate: str, reference: str) -> list[str]:
    """The verdict on the candidate, one line per soil the referee has solved: conditions on the rows."""
    lines = []
    for soil in SOILS:
        by = {m["engine"]: m for m in margins if m["soil"] == soil}
        if "fdtd" not in by:
            continue
        f = by["fdtd"]["margin"]
        line = (f"- On {soil} soil the referee (FDTD) puts {candidate} at {by['fdtd']['candidate_mk']:.1f} mK against "
                f"{reference}'s {by['fdtd']['reference_mk']:.1f} ({_pct(-f)}): " +
                verdict(f > 0, "the candidate **beats** the reference.", "the candidate does **not** beat the reference."))
        near = [e for e in ("surface", "nec") if e in by]
        if len(near) == 2:
            side = min(near, key=lambda e: abs(by[e]["margin"] - f))
            line += (f" Margins (candidate below the reference): surface {_pct(by['surface']['margin'])}, NEC-2 "
                     f"{_pct(by['nec']['margin'])}, FDTD {_pct(f)}; the referee's margin is nearer the **{side}** "
                     f"engine's" + verdict(np.sign(by[side]["margin"]) == np.sign(f), " (same sign).",
                                             " but of the other sign."))
        lines.append(line)
    return lines


def _side_reading(rows: list[dict]) -> list[str]:
    """Which MoM engine's FoM the referee's is nearer, case by case."""
    cases = sorted({(r["case"], r["soil"]) for r in rows if r["engine"] == "fdtd"})
    nearer = []
    for case, soil in cases:
        s, n, f = (_row(rows, case, soil, e) for e in ("surface", "nec", "fdtd"))
        if s and n and f:
            nearer.append("surface" if abs(f["fom_mk"] - s["fom_mk"]) <= abs(f["fom_mk"] - n["fom_mk"]) else "nec")
    if not nearer:
        return []
    k = nearer.count("surface")
    return [f"- FoM: the referee's is nearer the surface engine's in {k} of {len(nearer)} cases and NEC-2's in "
            f"{len(nearer) - k}."]


def _table3_reading(rows: list[dict]) -> list[str]:
    """Does the referee side with the paper (FEKO, Table 3) or with the surface engine on the planes
    our model puts at 0.6x the paper?"""
    lines = []
    for name in TABLE3_CASES:
        f, s = _row(rows, name, "MRO", "fdtd"), _row(rows, name, "MRO", "surface")
        if f and s:
            p = paper.TABLE3_FOM_MK[name]
            lines.append(f"- {name}: FDTD {f['fom_mk']:.1f} mK, surface {s['fom_mk']:.1f}, the paper {p:.0f} (FDTD / "
                         f"paper {f['fom_mk'] / p:.2f}): the referee sides with " +
                         verdict(abs(f["fom_mk"] - p) < abs(f["fom_mk"] - s["fom_mk"]), "**the paper**.",
                                 "**the surface engine**."))
    return lines


def _diff_table(diffs: list[dict]) -> list[str]:
    lines = ["| case | soil | pair | rms dB over the band (mean) | largest rms (at MHz) | largest |dB| |", "|---|---|---|---|---|---|"]
    keys = sorted({(d["case"], d["soil"], d["pair"]) for d in diffs}, key=lambda k: (k[0], k[1], k[2]))
    for key in keys:
        ds = [d for d in diffs if (d["case"], d["soil"], d["pair"]) == key]
        worst = max(ds, key=lambda d: d["rms_db"])
        lines.append(f"| {key[0]} | {key[1]} | {key[2]} | {np.mean([d['rms_db'] for d in ds]):.3f} | "
                     f"{worst['rms_db']:.3f} ({worst['freq_mhz']:g}) | {max(d['max_db'] for d in ds):.2f} |")
    return lines


def _report(rows, diffs, margins, pending, candidate, reference, freqs, cell) -> str:
    lines = [f"# The referee: three engines on {candidate} and {reference}", "",
             f"Surface engine and NEC-2 at their defaults (0.5 m), gprMax FDTD at {cell * 100:g} cm cells (plate on the "
             f"soil); {freqs.size} frequencies {freqs.min():g}-{freqs.max():g} MHz, the same for every engine; FoM in 2 h "
             "LST bins (Haslam, MRO, 5-term LinLog over 55-97 MHz). Gain differences over the sky above 10 deg "
             "elevation, solid-angle weighted.", "",
             "| case | soil | engine | FoM 2 h (mK) | FoM every LST (mK) | loss 55 MHz (%) | largest loss (%) | "
             "S11 worst (dB) |", "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['case']} | {r['soil']} | {r['engine']} | {r['fom_mk']:.1f} | {r['fom_every_lst_mk']:.1f} | "
              f"{r['loss_55_percent']:.3f} | {r['loss_max_percent']:.3f} | {r['s11_max_db']:.1f} |" for r in rows]
    lines += ["", "![FoM per 2 h LST bin, each engine](referee.png)"]
    lines += ["", "## Gain differences between the engines", ""] + _diff_table(diffs)
    lines += ["", "## Reading (computed from the rows)", ""]
    lines += _margin_reading(margins, candidate, reference) + _side_reading(rows) + _table3_reading(rows)
    if pending:
        lines += ["", "Not run yet (rerun the command: every finished solve is kept): "
                  + ", ".join(f"{c.name} on {c.soil_name}" for c in pending) + "."]
    return "\n".join(lines) + "\n"


def _figure(bins: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys((b["case"], b["soil"]) for b in bins))
    fig, axes = plt.subplots(1, max(1, len(cases)), figsize=(3.2 * max(1, len(cases)), 3.2), sharey=True, squeeze=False)
    for ax, (case, soil) in zip(axes[0], cases):
        for e, style in zip(ENGINES, ("-o", "--s", "-^")):
            v = [b["fom_mk"] for b in bins if (b["case"], b["soil"], b["engine"]) == (case, soil, e)]
            ax.semilogy(np.arange(len(v)) * paper.DATA_LST_BIN_HOURS + 1, v, style, ms=3, label=e)
        ax.set_title(f"{case[:24]}\n{soil}", fontsize=8)
        ax.set_xlabel("LST (h)")
    axes[0][0].set_ylabel("FoM per 2 h bin (mK)")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def referee(out: Path, command: str, candidate: GroundPlane, candidate_name: str, reference: str = "sawtooth-20-16",
            freqs: np.ndarray | None = None, cell: float = DEFAULT_CELL, cached_only: bool = False) -> list[dict]:
    """Solve every case on the three engines (cached; FDTD beams kept in ``out/beams``), rewriting
    the report after each; the rows. ``cached_only``: report the cases already solved, name the rest."""
    freqs = np.asarray(parse_freqs(DEFAULT_FREQS) if freqs is None else freqs, float)
    cases = referee_cases(candidate, candidate_name, reference)
    rows: list[dict] = []
    diffs: list[dict] = []
    bins: list[dict] = []
    missing: list[RefereeCase] = []
    for i, case in enumerate(cases):
        got = _run_case(case, freqs, cell, out / "beams", cached_only)
        if got is None:
            missing.append(case)
        else:
            rows, diffs, bins = rows + got[0], diffs + got[1], bins + got[2]
        write_csv(out / "referee.csv", rows)
        write_csv(out / "gain_differences.csv", diffs)
        write_csv(out / "fom_bins.csv", bins)
        _figure(bins, out / "referee.png")
        write_md(out / "referee.md", _report(rows, diffs, _margins(rows, candidate_name, reference), missing + cases[i + 1:],
                                             candidate_name, reference, freqs, cell), "study referee", command,
                 {"freqs_mhz": [float(f) for f in freqs], "fdtd_cell_m": cell, "reference": reference})
    return rows


def _design_file(path: Path) -> Path:
    from_file(path)  # a bad design file is refused here, before any solve
    return path


def _cell(value: float) -> float:
    if not 0.02 <= value <= 0.1:
        raise UserInputError(f"--cell {value}: the referee runs at 2-10 cm cells (7.5 cm or finer for its verdict)")
    return value


def _needs_design(extra: dict) -> None:
    if extra.get("design") is None:
        raise UserInputError("referee: give the candidate with --design FILE (e.g. "
                             "results/robust_front_0.5m/answer-600.json)")


@study("referee", "the candidate (--design FILE) and a reference preset on MRO and dry soil, then square-30 and "
       "plus-30, on the surface engine, NEC-2 and the FDTD referee side by side (hours: every solve is kept)",
       options=(StudyOption("--design", "design", "the candidate plane (a shape JSON or an optimiser's best.json)",
                            Path, "FILE", check=_design_file),
                StudyOption("--reference", "reference", "the preset it is measured against (default sawtooth-20-16)",
                            metavar="NAME", check=lambda n: preset(n) and n),
                StudyOption("--freqs", "freqs", f"frequencies (default {DEFAULT_FREQS}: the fit band every 2 MHz)",
                            parse_freqs, "LO:HI:STEP"),
                StudyOption("--cell", "cell", f"the FDTD cell (m, default {DEFAULT_CELL})", float, "M", check=_cell),
                StudyOption("--cached-only", "cached_only", "report the cases already solved and name the rest (a "
                            "long run's progress, without solving)", switch=True)),
       validate=_needs_design)
def _run(out: Path, settings, command: str, design: Path | None = None, reference: str = "sawtooth-20-16",
         freqs=None, cell: float = DEFAULT_CELL, cached_only: bool = False) -> None:
    plane = from_file(design)
    for r in referee(out, command, plane, design.stem, reference, freqs, cell, cached_only):
        print(f"{r['case']:28s} {r['soil']:4s} {r['engine']:8s} {r['fom_mk']:8.1f} mK  loss {r['loss_max_percent']:.3f} %")
