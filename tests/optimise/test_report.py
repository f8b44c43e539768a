"""Sweeps (resume after kill -9, invalid members, beam files, Dask), the optimiser's
constraint handling and NaN guard, and the report writer. Solves are a 3 m plate at a
1 m mesh and 8 frequencies: seconds each."""
import json

from optimise.report import write_report

CHEAP = """
[solver]
mesh = 1.0
freqs = "55:97:4"
[fom]
n_lst = 24
"""



def test_report_writer(tmp_path):
    rows = [
        {"name": "a", "status": "ok", "shape": "square", "params": {"side": 10.0}, "metal_area_m2": 100.0,
         "extent_m": 10.0, "lst_averaged_fom_mk": 300.0, "fom_mk": [200.0, 400.0], "lst_hours": [0.0, 12.0],
         "fit_freqs_mhz": [55.0, 60.0], "residuals_mk": {"2": [1.0, -1.0]}, "solve_s": 3.0},
        {"name": "b", "status": "ok", "shape": "plus", "params": {"arm": 5.0}, "metal_area_m2": 125.0,
         "extent_m": 15.0, "lst_averaged_fom_mk": 200.0, "fom_mk": [150.0, 250.0], "lst_hours": [0.0, 12.0],
         "fit_freqs_mhz": [55.0, 60.0], "residuals_mk": {"2": [2.0, -2.0]}, "solve_s": 4.0},
        {"name": "c", "status": "invalid", "shape": "sawtooth", "params": {}, "error": "teeth do not fit",
         "metal_area_m2": None, "extent_m": None, "lst_averaged_fom_mk": None},
    ]
    paths = write_report(rows, tmp_path, title="t")
    md = paths["md"].read_text()
    assert md.index("| 1 | b |") < md.index("| 2 | a |")  # ranked by FoM
    assert "teeth do not fit" in md
    for k in ("outlines", "fom_vs_lst", "residuals", "fom_vs_area"):
        assert paths[k].stat().st_size > 5000
    data = json.loads(paths["json"].read_text())
    assert [r["name"] for r in data] == ["b", "a", "c"]
    assert paths["csv"].read_text().splitlines()[1].startswith("1,b,ok")
    assert "<table" in paths["html"].read_text()



def test_rows_without_curves_get_no_empty_figures(tmp_path):
    """Rows that carry only the LST-averaged FoM (no per-LST FoM, no residuals) still get the
    outlines and FoM-vs-metal figures, but no empty FoM-vs-LST or residual panels."""
    rows = [{"name": n, "status": "ok", "shape": "square", "params": {"side": s}, "metal_area_m2": s * s,
             "extent_m": s, "lst_averaged_fom_mk": f} for n, s, f in (("a", 10.0, 300.0), ("b", 20.0, 200.0))]
    paths = write_report(rows, tmp_path, title="t")
    assert "outlines" in paths and "fom_vs_area" in paths
    assert "fom_vs_lst" not in paths and "residuals" not in paths
    assert not (tmp_path / "fom_vs_lst.png").exists()
    assert "fom_vs_lst" not in paths["md"].read_text()


def test_html_report_carries_everything_the_markdown_does(tmp_path):
    """Parsed, not grepped: every table cell, the not-scored section, the notes and every
    figure of report.md are in report.html."""
    from html.parser import HTMLParser

    rows = [
        {"name": "sawtooth-10-2-3-5", "status": "ok", "shape": "sawtooth",
         "params": {"side": 10.0, "teeth_per_side": 2, "tooth_base": 3.0, "tooth_height": 5.0},
         "metal_area_m2": 160.0, "extent_m": 20.0, "lst_averaged_fom_mk": 250.0, "fom_smoothed_mk": 240.5,
         "fom_mk": [200.0, 300.0], "lst_hours": [0.0, 12.0], "fit_freqs_mhz": [55.0, 60.0],
         "residuals_mk": {"2": [1.0, -1.0]}, "solve_s": 123.0},
        {"name": "broken", "status": "failed", "shape": "square", "params": {"side": 3.0}, "error": "worker died <oom>",
         "metal_area_m2": None, "extent_m": None, "lst_averaged_fom_mk": None},
    ]
    paths = write_report(rows, tmp_path, title="t", preamble="Settings: mesh 0.5 m; 61 frequencies")

    class Cells(HTMLParser):
        def __init__(self):
            super().__init__()
            self.text, self.imgs, self._cell = [], [], None

        def handle_starttag(self, tag, attrs):
            if tag == "img":
                self.imgs.append(dict(attrs)["src"])

        def handle_data(self, data):
            self.text.append(data)

    parser = Cells()
    parser.feed(paths["html"].read_text())
    text = "\n".join(parser.text)
    md = paths["md"].read_text()
    for line in md.splitlines():
        if line.startswith("| 1 |"):
            for cell in line.strip("|").split("|"):
                assert cell.strip() in text
    for needle in ("240.5", "123", "teeth_per_side=2", "worker died <oom>", "Not scored", "mesh 0.5 m", "mesh-convergence"):
        assert needle in md and needle in text, needle
    assert sorted(parser.imgs) == sorted(p.split("(")[1].rstrip(")") for p in md.splitlines() if p.startswith("!["))


def test_html_report_shows_code_not_backticks(tmp_path):
    from optimise.report import write_report

    rows = [{"name": "a", "status": "ok", "shape": "square", "params": {"side": 10}, "metal_area_m2": 100.0,
             "extent_m": 10.0, "lst_averaged_fom_mk": 200.0, "fom_mk": [200.0], "lst_hours": [0.0],
             "fit_freqs_mhz": [], "residuals_mk": {}}]
    html = write_report(rows, tmp_path, preamble="Command: `groundplane sweep x.toml`.")["html"].read_text()
    assert "<code>groundplane sweep x.toml</code>" in html and "`" not in html
    assert "too few frequencies for their degree-12 fit" in (tmp_path / "report.md").read_text()


def test_rows_on_different_frequency_sets_are_ranked_within_each(tmp_path):
    """Issue 25 item 2: a beam sampled every 7 MHz ranked first above the same design at 1 MHz."""
    from optimise.report import write_report

    def row(name, fom, freqs):
        return {"name": name, "status": "ok", "shape": "square", "params": {"side": 10}, "metal_area_m2": 100.0,
                "extent_m": 10.0, "lst_averaged_fom_mk": fom, "fom_mk": [fom], "lst_hours": [0.0],
                "fit_freqs_mhz": freqs, "residuals_mk": {}}
    fine, coarse = list(range(55, 98)), list(range(55, 98, 4))
    rows = [row("a-1mhz", 240.0, fine), row("b-1mhz", 200.0, fine), row("a-4mhz", 90.0, coarse)]
    md = write_report(rows, tmp_path)["md"].read_text()
    assert "ranked within each set, not across" in md
    assert "| 1 (set 1) | b-1mhz" in md and "| 2 (set 1) | a-1mhz" in md and "| 1 (set 2) | a-4mhz" in md
    single = write_report(rows[:2], tmp_path / "one")["md"].read_text()
    assert "not across" not in single and "| 1 | b-1mhz" in single
