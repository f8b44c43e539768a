"""Ranking reports of a sweep: report.md and report.html, results.csv/json, and figures
(outlines, FoM vs LST, residual spectra at a few LSTs, FoM vs metal area)."""
from __future__ import annotations

import csv
import html
import json
from pathlib import Path
from typing import Any

import numpy as np

from groundplane.cli import invocation
from groundplane.files import atomic_path
from groundplane.plots import pyplot, save_figure
from groundplane.shapes import from_dict

from . import provenance
from .evaluate import RESIDUAL_LSTS_H


def _write(path: Path, text: str) -> None:
    """Replace a report file atomically (a kill never leaves half a report)."""
    with atomic_path(path, suffix=".tmp" + path.suffix) as tmp:
        tmp.write_text(text)


def ranked(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Scored rows by FoM (best first), then the rows that were not scored."""
    sets = frequency_sets(rows)
    ok = sorted([r for r in rows if r.get("status") == "ok"],
                key=lambda r: (sets.get(_fit_key(r), 0), r["lst_averaged_fom_mk"]))
    return ok + [r for r in rows if r.get("status") != "ok"]


def _fit_key(r: dict[str, Any]) -> tuple:
    return tuple(round(float(f), 6) for f in r.get("fit_freqs_mhz") or ())


def frequency_sets(rows: list[dict[str, Any]]) -> dict[tuple, int]:
    """The distinct sets of fit frequencies the scored rows used, numbered from 1 (the most
    rows first): FoMs are compared only within one set (the same beam scores differently on
    another), so a report ranks within each."""
    from collections import Counter

    counts = Counter(_fit_key(r) for r in rows if r.get("status") == "ok")
    return {k: i for i, (k, _) in enumerate(counts.most_common(), 1)}


def _sets_note(rows: list[dict[str, Any]]) -> str:
    sets = frequency_sets(rows)
    if len(sets) < 2:
        return ""
    def describe(k: tuple) -> str:
        return f"{len(k)} frequencies {k[0]:g}-{k[-1]:g} MHz" if k else "no fit frequencies recorded"
    return ("These rows were scored on different frequency sets, so they are ranked within each set, not across: "
            + "; ".join(f"set {i}: {describe(k)}" for k, i in sets.items()) + ".")


def write_report(rows: list[dict[str, Any]], out_dir: str | Path, title: str = "Ground-plane sweep",
                 preamble: str = "") -> dict[str, Path]:
    """Write every report file into ``out_dir``; returns their paths by kind."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = ranked(rows)
    ok = [r for r in rows if r.get("status") == "ok"]
    paths = {"json": out / "results.json", "csv": out / "results.csv", "md": out / "report.md",
             "html": out / "report.html"}
    _write(paths["json"], json.dumps(rows, indent=1))
    with atomic_path(paths["csv"], suffix=".tmp.csv") as tmp, open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["rank", "name", "status", "shape", "params", "metal_area_m2", "extent_m",
                    "lst_averaged_fom_mk", "fom_smoothed_mk", "max_ground_loss", "solve_s", "error"])
        labels = _rank_labels(ok)
        for i, r in enumerate(rows):
            w.writerow([labels[i] if i < len(labels) else "", r["name"], r.get("status"), r.get("shape"),
                        json.dumps(r.get("params")), r.get("metal_area_m2"), r.get("extent_m"),
                        r.get("lst_averaged_fom_mk"), r.get("fom_smoothed_mk"),
                        r.get("max_loss", r.get("max_ground_loss")),
                        r.get("solve_s"), r.get("error", "")])
    figs = {}
    if ok:
        figs = _figures(ok, out)
    paths.update(figs)
    header, cells = _ranking(ok)
    bad = [r for r in rows if r.get("status") != "ok"]
    notes = ([MESH_NOTE] if any(r.get("shape") != "beam-file" for r in ok) else []) + \
        ([note] if (note := _sets_note(rows)) else []) + \
        sorted({f"**Coarse mesh**: {r['mesh_note']}." for r in ok if r.get("mesh_note")})
    md = [provenance.header("report", invocation()), f"# {title}", ""]
    if preamble:
        md += [preamble, ""]
    md += [" ".join(notes), ""] if notes else []
    md += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    md += ["| " + " | ".join(md_cell(x) for x in c) + " |" for c in cells]
    with_members = [r for r in ok if r.get("members")]
    if with_members:
        from .scenarios import member_table, sensitivity

        md += ["", "## Every scenario member", ""]
        for r in with_members:
            md += [f"**{r['name']}** ({r['scenario_set']}, aggregate {r['aggregate']}; figures show its worst member, "
                   f"{r.get('curves_of')}):", "", *member_table(r), ""]
            if (sens := sensitivity(r)) is not None and sens.rows:
                md += [*sens.table(), ""]
            if r.get("skipped_members"):
                md += [f"Not applicable to this design: {', '.join(r['skipped_members'])}.", ""]
    if bad:
        md += ["", "## Not scored", ""] + [f"- **{md_cell(r['name'])}** ({r.get('status')}): "
                                            f"{md_cell(str(r.get('error', '')))}" for r in bad]
    if figs:
        md += ["", "## Figures", ""] + [f"![{k}]({p.name})" for k, p in figs.items()]
    _write(paths["md"], "\n".join(md) + "\n")
    _write(paths["html"], _html(title, [preamble, *notes], header, cells, bad, figs))
    return paths


MESH_NOTE = ("Solved FoMs depend on the model's mesh (`groundplane study mesh-convergence` measures how much): "
             "compare candidates only at one mesh, and re-solve the best at a finer one. A '-' in the smoothed or "
             "narrow-band column: the band has too few frequencies for their degree-12 fit in frequency (25 needed); "
             "in the ground-loss column: the beam's gain is not normalised to its input power (an imported table).")


def _params(r: dict[str, Any]) -> str:
    """A candidate's shape parameters, compactly (names like sawtooth-10-2-3-5 need them)."""
    p = r.get("params") or {}
    return ", ".join(f"{k}={v:g}" if isinstance(v, (int, float)) else f"{k}={v}" for k, v in p.items()) or "-"


def _rank_labels(ok: list[dict[str, Any]]) -> list[str]:
    """Each scored row's rank within its frequency set (``ranked`` order), with the set when
    there is more than one."""
    sets = frequency_sets(ok)
    labels, rank = [], {}
    for r in ok:
        s = sets.get(_fit_key(r), 1)
        rank[s] = rank.get(s, 0) + 1
        labels.append(f"{rank[s]} (set {s})" if len(sets) > 1 else str(rank[s]))
    return labels


def _ranking(ok: list[dict[str, Any]]) -> tuple[list[str], list[list[str]]]:
    """The ranking table, once, for both the markdown and the HTML report."""
    scenario = any("scenario_set" in r for r in ok)
    header = ["rank", "candidate", "shape", "parameters", "metal area (m^2)", "extent (m)",
              "LST-averaged FoM (mK)" + (" (the set's aggregate)" if scenario else ""), "FoM, G(nu) smoothed (mK)",
              "narrow-band rms", "largest ground loss in the fit band (%)", "solve (s)"]
    if scenario:
        header[7:9] = ["worst member (mK)", "mean of the members (mK)", "meets the constraints"]
    cells = []
    for label, r in zip(_rank_labels(ok), ok):
        loss = r.get("max_loss", r.get("max_ground_loss"))
        if "scenario_set" in r:
            mid = [cell(r.get("worst_fom_mk")), cell(r.get("mean_fom_mk")),
                   "yes" if r.get("feasible") else "no: " + "; ".join(r.get("violations") or [])]
        elif scenario:
            mid = ["-", "-", "-"]
        else:
            mid = [cell(r.get("fom_smoothed_mk")), "-" if r.get("narrow_band_rms") is None else f"{r['narrow_band_rms']:.1e}"]
        cells.append([label, r["name"], str(r.get("shape")), _params(r), cell(r.get("metal_area_m2")),
                      cell(r.get("extent_m")), f"{r['lst_averaged_fom_mk']:.1f}", *mid,
                      "-" if loss is None else f"{100 * loss:.3f}", cell(r.get("solve_s"), 0)])
    return header, cells


def _html(title: str, paragraphs: list[str], header: list[str], cells: list[list[str]],
          bad: list[dict[str, Any]], figs: dict[str, Path]) -> str:
    """report.html: the same content as report.md (a page for people who would rather look)."""
    e = html.escape

    def inline(text: str) -> str:  # markdown `code` as <code>, the rest escaped
        parts = e(text).split("`")
        return "".join(f"<code>{p}</code>" if i % 2 else p for i, p in enumerate(parts))

    paras = "".join(f"<p>{inline(p)}</p>" for p in paragraphs if p)
    head = "".join(f"<th>{e(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{inline(c)}</td>" for c in row) + "</tr>" for row in cells)
    lost = ""
    if bad:
        lost = "<h2>Not scored</h2><ul>" + "".join(
            f"<li><b>{e(r['name'])}</b> ({e(str(r.get('status')))}): {e(str(r.get('error', '')))}</li>" for r in bad
        ) + "</ul>"
    imgs = "".join(f'<figure><img src="{e(p.name)}" alt="{e(k)}" style="max-width:100%"><figcaption>{e(k)}'
                   "</figcaption></figure>" for k, p in figs.items())
    return (f"<!doctype html><html><head><meta charset='utf-8'><title>{e(title)}</title></head><body>"
            f"<h1>{e(title)}</h1>{paras}<table border=1 cellpadding=4><tr>{head}</tr>{body}</table>{lost}"
            f"{('<h2>Figures</h2>' + imgs) if imgs else ''}</body></html>")


def md_cell(text: str) -> str:
    """Text as one markdown table cell: a '|' escaped, line breaks as spaces (a candidate's name
    may hold either)."""
    return " ".join(str(text).split("\n")).replace("\r", " ").replace("|", "\\|")


def cell(v: Any, nd: int = 1) -> str:
    """A number for a table, or - when there is none (or it is not finite)."""
    return "-" if v is None or not np.isfinite(v) else f"{v:.{nd}f}"


def _figures(ok: list[dict[str, Any]], out: Path) -> dict[str, Path]:
    """The sweep report's figures (outlines, FoM vs LST, residuals, FoM vs metal), each panel
    with the rows in the same order, so one candidate keeps one colour throughout."""
    figs: dict[str, Path] = {}
    shapes = [r for r in ok if r.get("shape") != "beam-file"]
    if shapes:
        figs["outlines"] = _outlines_figure(shapes, out / "outlines.png")
    # a figure only when some row has its curves: rows handed to write_report may carry only the averaged FoM
    if any(r.get("fom_mk") is not None for r in ok):
        figs["fom_vs_lst"] = _fom_vs_lst_figure(ok, out / "fom_vs_lst.png")
    if any(r.get("residuals_mk") for r in ok):
        figs["residuals"] = _residuals_figure(ok, out / "residuals.png")
    with_area = [r for r in ok if r.get("metal_area_m2") is not None]
    if with_area:
        figs["fom_vs_area"] = _fom_vs_area_figure(with_area, out / "fom_vs_area.png")
    return figs


def _saved(fig, path: Path) -> Path:
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    pyplot().close(fig)
    return path


def _outlines_figure(shapes: list[dict[str, Any]], path: Path) -> Path:
    """Every candidate's outline on one scale, titled with its metal and FoM."""
    from groundplane.cad import plot_outline

    n = len(shapes)
    cols = min(n, 4)
    nrows = int(np.ceil(n / cols))
    fig, axes = pyplot().subplots(nrows, cols, figsize=(3.2 * cols, 3.2 * nrows), squeeze=False)
    lim = max(r["extent_m"] for r in shapes) / 2 * 1.05
    for ax, r in zip(axes.ravel(), shapes):
        plot_outline(from_dict({"shape": r["shape"], **r["params"]}), ax)
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_title(f"{r['name']}\n{r['metal_area_m2']:.0f} m$^2$, {r['lst_averaged_fom_mk']:.0f} mK", fontsize=8)
        ax.set_xlabel("")
        ax.set_ylabel("")
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    return _saved(fig, path)


def _fom_vs_lst_figure(ok: list[dict[str, Any]], path: Path) -> Path:
    fig, ax = pyplot().subplots(figsize=(9, 4.5))
    for r in ok:
        if r.get("fom_mk") is not None:
            ax.plot(r["lst_hours"], r["fom_mk"], label=f"{r['name']} ({r['lst_averaged_fom_mk']:.0f} mK)")
    ax.set_yscale("log")
    ax.set_xlabel("LST (h)")
    ax.set_ylabel("FoM (mK)")
    ax.set_xlim(0, 24)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    return _saved(fig, path)


def _residuals_figure(ok: list[dict[str, Any]], path: Path) -> Path:
    fig, axes = pyplot().subplots(2, 2, figsize=(10, 6), sharex=True)
    for ax, h in zip(axes.ravel(), RESIDUAL_LSTS_H):
        for r in ok:
            res = (r.get("residuals_mk") or {}).get(f"{h:g}")
            if res:
                ax.plot(r["fit_freqs_mhz"], res, label=r["name"])
        ax.set_title(f"LST {h:g} h: residuals after LinLog", fontsize=9)
        ax.set_ylabel("mK")
        ax.grid(alpha=0.3)
    axes[1, 0].set_xlabel("frequency (MHz)")
    axes[1, 1].set_xlabel("frequency (MHz)")
    if axes[0, 0].get_legend_handles_labels()[0]:  # rows without stored residuals draw nothing
        axes[0, 0].legend(fontsize=6)
    return _saved(fig, path)


def _fom_vs_area_figure(with_area: list[dict[str, Any]], path: Path) -> Path:
    fig, ax = pyplot().subplots(figsize=(6, 4.5))
    for shape in sorted({r["shape"] for r in with_area}):
        sel = [r for r in with_area if r["shape"] == shape]
        ax.scatter([r["metal_area_m2"] for r in sel], [r["lst_averaged_fom_mk"] for r in sel], label=shape)
        for r in sel:
            ax.annotate(r["name"], (r["metal_area_m2"], r["lst_averaged_fom_mk"]), fontsize=6,
                        xytext=(3, 3), textcoords="offset points")
    ax.set_xlabel("metal area (m$^2$)")
    ax.set_ylabel("LST-averaged FoM (mK)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _saved(fig, path)
