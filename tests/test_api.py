"""The public Python API, used only through its public names, each on tiny settings; the
docstring examples that do not solve run as doctests."""
from __future__ import annotations

import doctest

import numpy as np
import pytest

import groundplane as gp
from tests.conftest import ROOT

TINY = {"mesh": 1.5, "blade_cells": (4, 4), "freqs": "55:97:4", "workers": 1, "n_lst": 24}


def test_every_public_name_is_documented_with_an_example():
    for name in gp.__all__:
        obj = getattr(gp, name)
        assert obj.__doc__, name
        if name != "shapes":  # the module: its families and presets carry the examples
            assert ">>>" in obj.__doc__, f"{name}: no example in its docstring"


def test_the_core_docstring_examples_run(monkeypatch):
    """Every public name's example that needs no solve runs here as a doctest (the solving
    ones, solve / score / optimise / sweep, run below on tiny settings)."""
    monkeypatch.chdir(ROOT)
    finder, runner = doctest.DocTestFinder(), doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    tried = set()
    for name in gp.__all__:
        obj = getattr(gp, name)
        if name in ("solve", "solve_soils", "score", "optimise", "sweep", "shapes") or not obj.__doc__ or ">>>" not in obj.__doc__:
            continue
        for test in finder.find(obj, name, globs={"gp": gp, **vars(gp), **vars(gp.shapes)}):
            if test.examples and test.name == name:
                runner.run(test)
                tried.add(name)
    assert runner.failures == 0
    assert set(gp.__all__) - {"shapes", "solve", "solve_soils", "score", "optimise", "sweep"} <= tried


def test_the_api_reference_builds_without_warnings(tmp_path):
    """docs/api (Sphinx autodoc of the public names) with warnings as errors: a broken
    docstring or a public name the reference lost fails here."""
    import subprocess
    import sys

    pytest.importorskip("sphinx")
    out = subprocess.run([sys.executable, "-m", "sphinx", "-W", "-q", "-b", "html", str(ROOT / "docs" / "api"),
                          str(tmp_path / "html")], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr + out.stdout
    html = (tmp_path / "html" / "index.html").read_text()
    for name in gp.__all__:
        if name != "shapes":
            assert f"groundplane.{name}" in html, name


def test_solve_then_fom_compare_and_the_beams_own_fom(tmp_path, monkeypatch):
    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path))
    beam = gp.solve(gp.shapes.preset("square-10"), **{k: v for k, v in TINY.items() if k != "n_lst"})
    assert isinstance(beam, gp.Beam) and beam.freqs_mhz.size == 11
    result = gp.fom(beam, n_lst=24)
    assert np.isfinite(result.lst_averaged_mk) and result.fom_mk.shape == (12,)
    assert result.ground_loss is not None and np.all((result.ground_loss > 0) & (result.ground_loss < 0.2))
    assert beam.fom(n_lst=24).lst_averaged_mk == pytest.approx(result.lst_averaged_mk)
    pec = gp.solve(None, ground="pec", **{k: v for k, v in TINY.items() if k != "n_lst"})
    c = gp.compare(beam, pec, labels=["soil", "pec"], n_lst=24)
    assert c.pairs[0].rms_db.max() > 0.1
    with pytest.raises(gp.UserInputError, match="unknown key"):
        gp.solve("square-10", mesh_size=1.0)


def test_solve_soils_gives_each_soils_own_beam_solved_together(tmp_path, monkeypatch):
    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path))
    opts = {"mesh": 2.0, "blade_cells": (4, 4), "freqs": "60:70:10", "workers": 0}
    dry, wet = gp.solve_soils("square-10", [(2.5, 0.005), gp.Soil(5.0, 0.05)], **opts)
    alone = gp.solve("square-10", eps_r=5.0, sigma=0.05, cache=False, **opts)
    assert np.allclose(wet.gain, alone.gain, rtol=1e-6)
    assert not np.allclose(dry.gain, wet.gain, rtol=1e-3)  # each soil its own beam, not one copied
    with pytest.raises(gp.UserInputError, match="eps_r come from soils"):
        gp.solve_soils("square-10", [(2.5, 0.005)], eps_r=3.0)
    with pytest.raises(gp.UserInputError, match=r"soils\[1\] = 3.0 is neither"):
        gp.solve_soils("square-10", [(2.5, 0.005), 3.0])
    with pytest.raises(gp.UserInputError, match=r"soils\[0\]: .*eps_r must be >= 1"):
        gp.solve_soils("square-10", [(0.5, 0.005)])


def test_score_optimise_sweep_and_fabrication_plan(tmp_path, monkeypatch):
    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "cache"))
    row = gp.score(gp.shapes.Square(4.0), scenarios="nominal", max_loss=None, **TINY)
    assert row["feasible"] and len(row["members"]) == 1 and np.isfinite(row["lst_averaged_fom_mk"])
    res = gp.optimise("square", 30.0, tmp_path / "opt", budget=2, scenarios="nominal", max_loss=None, **TINY)
    assert res.best is not None and res.best["area_m2"] <= 30.0
    cfg = tmp_path / "s.toml"
    cfg.write_text('[solver]\nmesh = 1.5\nblade_cells = [4, 4]\nfreqs = "55:97:4"\nworkers = 1\n[fom]\nn_lst = 24\n'
                   '[[candidate]]\nshape = "square"\nside = 4.0\n')
    rows = gp.sweep(cfg, tmp_path / "sweep")
    assert rows[0]["status"] == "ok"
    plan = gp.fabrication_plan("square-10", tmp_path / "fab")
    assert plan["sheets_bought"] > 0 and (tmp_path / "fab" / "outline.dxf").exists()


def test_compare_stays_the_function_after_every_module_is_imported():
    import importlib

    for mod in ("groundplane.comparison", "groundplane.fabricate", "groundplane.fom", "groundplane.shapes"):
        importlib.import_module(mod)
    for name in gp.__all__:
        assert not isinstance(getattr(gp, name), type(gp)) or name == "shapes", name
