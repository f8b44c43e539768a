"""The tolerance study's variants are the as-built errors they name, and its reading is a
condition on its rows (solves replaced by a stand-in FoM: the study's plumbing, not physics)."""
import csv

import numpy as np
import pytest

from groundplane.shapes import preset
from optimise.evaluate import EvalSettings
from optimise.studies import tolerance as tol


def test_variants_are_the_named_errors():
    plane = preset("extended")
    vs = tol.variants(plane, EvalSettings(), draws=2)
    groups = [v.group for v in vs]
    assert groups[0] == "nominal" and vs[0].plane == plane
    bases = sorted(v.plane.tooth_base for v in vs if v.group == "tooth base")
    assert bases == pytest.approx([4.6, 5.0])  # the paper's case: 4.8 m built for 5 m designed
    for err in tol.CORNER_ERRORS_M:
        drawn = [v for v in vs if v.group == f"corners +-{err * 100:g} cm"]
        assert len(drawn) == 2
        for v in drawn:
            moved = np.asarray(v.plane.vertices) - np.asarray(plane.outline().exterior.coords)[:-1]
            assert np.abs(moved).max() <= err and np.abs(moved).max() > 0.2 * err
    heights = sorted(v.settings.model.plate_height for v in vs if v.group == "plate height")
    assert heights == list(tol.PLATE_HEIGHTS_M)
    missing = next(v for v in vs if v.group == "missing sheet")
    assert plane.metal_area - missing.plane.metal_area > 0.5 * 2.4 * 6.0
    turned = [v for v in vs if v.group == "antenna turned"]
    assert [round(v.plane.metal_area, 6) for v in turned] == [plane.metal_area] * 2
    assert not any(all(v.plane.mirror_symmetry.values()) for v in turned)  # solved as the whole model
    off = [v for v in vs if v.group == "antenna off centre"]
    assert {tuple(np.round(v.plane.outline().centroid.coords[0], 6)) for v in off} == {(-0.1, 0.0), (0.0, -0.1)}
    # seeded: the same draws every run
    again = tol.variants(plane, EvalSettings(), draws=2)
    assert [v.plane for v in again] == [v.plane for v in vs]


def _fake_evaluate(by_group):
    def evaluate(candidate, settings, progress=False):
        group = candidate.name.split(":")[0]
        return {"status": "ok", "lst_averaged_fom_mk": by_group.get(group, 100.0), "n_unknowns": 1, "solver_cpu_s": 0.0}
    return evaluate


@pytest.mark.parametrize("turned, holds", [(112.0, True), (104.0, False)])
def test_the_reading_follows_the_rows(tmp_path, monkeypatch, turned, holds):
    monkeypatch.setattr(tol, "evaluate", _fake_evaluate({"antenna turned": turned, "tooth base": 103.0}))
    rows = tol.tolerance(tmp_path, EvalSettings(), "cmd", "sawtooth-10-8", draws=1, progress=False)
    assert rows[0]["fom_mk"] == 100.0
    md = (tmp_path / "tolerance.md").read_text()
    assert "matters most here is **antenna turned**" in md
    assert ("at least twice any other" in md) == holds
    assert ("Some as-built variants move the FoM by 5 % or more: antenna turned" in md) == holds
    assert ("Every as-built variant stays within 5 %" in md) == (not holds)
    with open(tmp_path / "tolerance.csv") as fh:
        assert len(list(csv.DictReader(fh))) == len(rows)


def test_a_design_file_is_studied_like_a_preset(tmp_path, monkeypatch):
    """`study tolerance --design best.json`: an optimiser's answer gets the same variants, named by its file."""
    import json

    from groundplane.cli import main

    design = tmp_path / "best.json"
    design.write_text(json.dumps({"shape": "teeth", "params": {"side": 4.6, "teeth_per_side": 1, "tooth_base": 2.25,
                                                               "tooth_height": 9.8, "tip_fraction": 0.96}}))
    monkeypatch.setattr(tol, "evaluate", _fake_evaluate({"tooth base": 130.0}))
    assert main(["study", "tolerance", "--design", str(design), "--draws", "1", "-o", str(tmp_path / "out")]) == 0
    md = (tmp_path / "out" / "tolerance.md").read_text()
    assert "tooth base 2.05 m (designed 2.25)" in md and "best.json: teeth side 4.6" in md
    assert main(["study", "tolerance", "--design", str(tmp_path / "nope.json"), "-o", str(tmp_path / "o2")]) == 2
    assert main(["study", "tolerance", "--design", str(design), "--preset", "extended", "-o", str(tmp_path / "o3")]) == 2
