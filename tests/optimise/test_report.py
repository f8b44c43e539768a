"""Sweeps (resume after kill -9, invalid members, beam files, Dask), the optimiser's
constraint handling and NaN guard, and the report writer. Solves are a 3 m plate at a
1 m mesh and 8 frequencies: seconds each."""
import json

from optimise.report import write_report

CHEAP = """
[solver]
mesh = 1.0
freqs = "55:97:6"
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

