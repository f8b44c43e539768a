"""The soil-surface study end to end on tiny meshes (both engines really solve on soil)."""
import csv

import numpy as np
import pytest


def test_soil_surface_study_writes_its_table_reading_and_figure(tmp_path, monkeypatch):
    from optimise.studies.soil_surface import Row, soil_surface

    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "cache"))
    cells = (4, 4)
    todo = [Row("square-10", "nec", 2.5, 0.005, "nec", cells),
            Row("square-10", "surface", 2.5, 0.05, "height", cells),
            Row("square-10", "surface", 2.5, 0.02, "height", cells),
            Row("square-10", "surface", 2.5, 0.02, "design", cells),
            Row("square-20", "surface", 2.5, 0.02, "design", cells),
            Row("square-20", "surface", 2.5, 0.01, "check", cells)]
    soil_surface(tmp_path, "test", workers=1, todo=todo, freqs=np.arange(55.0, 98.0, 4.0))
    rows = list(csv.DictReader((tmp_path / "soil_surface.csv").open()))
    assert [r["engine"] for r in rows] == ["nec"] + ["surface"] * 5
    for r in rows:
        assert 0 < float(r["fom_mk"]) < 1e4 and 0.5 < float(r["efficiency_75"]) < 1.0
        assert 0 < float(r["fom_binned_mk"]) <= float(r["fom_mk"]) + 1e-9  # bin averages never add structure
    md = (tmp_path / "soil_surface.md").read_text()
    assert "## Reading" in md and "Plate height" in md and (tmp_path / "soil_surface.png").stat().st_size > 1000
    assert "design study on the sheet model" in md and "(i) on square-10 -> square-20" in md
    assert "**Check, square-20, sheet 1 cm up**" in md
    assert "**in 2 h LST bins**" in md and "in 2 h LST bins" in md.split("**Check")[1]  # one change from its design row, measured against it


def test_lst_correlation_tells_slow_from_fast_residuals():
    from optimise.studies.soil_surface import lst_correlation

    spectrum = np.sin(np.linspace(0, 3, 40))[:, None]
    assert lst_correlation(spectrum * np.ones((1, 360)), 8) == pytest.approx(1.0)
    flip = np.where(np.arange(352) % 16 < 8, 1.0, -1.0)  # sign changes every 8 LSTs (352: whole periods)
    assert lst_correlation(spectrum * flip[None, :], 8) == pytest.approx(-1.0)
