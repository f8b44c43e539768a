"""Sheet plans: the layout covers the outline, pieces are real cuts of real sheets, the
numbers (sheets, waste, seams, mass) are what the geometry says, and bad input is one line."""
import json
import math

import ezdxf
import numpy as np
import pytest
from shapely import affinity
from shapely.geometry import Polygon, box
from shapely.ops import unary_union

from groundplane import fabricate as fab
from groundplane.cli import main
from groundplane.errors import ShapeError, UserInputError
from groundplane.shapes import Square, from_file, preset


def _dxf_polygons(path, layer):
    doc = ezdxf.readfile(path)
    return [Polygon([tuple(v[:2]) for v in e.get_points("xy")])
            for e in doc.modelspace().query(f'LWPOLYLINE[layer=="{layer}"]')]


def test_fabricate_extended_writes_the_plan_and_a_dxf_of_the_metal(tmp_path, capsys):
    out = tmp_path / "fab"
    assert main(["fabricate", "--preset", "extended", "--sheet", "2.4", "6.0", "-o", str(out)]) == 0
    for name in ("outline.dxf", "plan.png", "plan.svg", "cutlist.csv", "plan.json"):
        assert (out / name).stat().st_size > 0, name
    summary = json.loads((out / "plan.json").read_text())
    for key in ("sheets_full", "sheets_cut", "waste_percent", "seam_length_m", "mass_kg", "metal_area_m2"):
        assert key in summary
    plane = preset("extended")
    outline = _dxf_polygons(out / "outline.dxf", "OUTLINE")
    assert len(outline) == 1
    assert outline[0].area == pytest.approx(plane.metal_area, rel=1e-3)
    assert ezdxf.readfile(out / "outline.dxf").units == ezdxf.units.M
    # the sheets' pieces, read back from the DXF, cover the outline with no gap and stay inside it
    pieces = _dxf_polygons(out / "outline.dxf", "SHEETS")
    assert plane.outline().difference(unary_union(pieces)).area < 1e-6
    assert unary_union(pieces).difference(plane.outline()).area < 1e-6
    rows = (out / "cutlist.csv").read_text().splitlines()
    assert len(rows) == 1 + len(pieces)
    assert summary["sheets_full"] + summary["sheets_cut"] == summary["sheets_bought"]


@pytest.mark.parametrize("name", ["extended", "sawtooth-10-8", "plus-15", "square-10"])
def test_every_piece_is_a_cut_of_its_sheet_and_no_mesh_is_used_twice(name):
    plan = fab.plan_sheets(preset(name), fab.MeshSheet())
    sheet = box(0, 0, plan.sheet.length, plan.sheet.width)
    by_sheet: dict[int, list[Polygon]] = {}
    for p in plan.pieces:
        assert sheet.buffer(1e-6).contains(p.in_sheet), p.label
        # the sheet-frame piece, oriented and moved, is the piece laid in the plane
        q = fab._oriented(p.in_sheet, p.rotation_deg, p.flipped)
        dx, dy = fab._to_plane(p.in_sheet, p.in_plane, p.rotation_deg, p.flipped)
        assert affinity.translate(q, dx, dy).symmetric_difference(p.in_plane).area < 1e-6, p.label
        for cut in fab._plane_cuts(p):  # cut lines lie on the piece's edges where it is laid
            assert p.in_plane.exterior.buffer(1e-5).contains(cut), p.label
        by_sheet.setdefault(p.sheet, []).append(p.in_sheet)
    assert set(by_sheet) == set(range(1, plan.bought + 1))
    for n, parts in by_sheet.items():
        used = sum(q.area for q in parts)
        assert unary_union(parts).area == pytest.approx(used, abs=1e-6), f"sheet {n}: pieces overlap"
    assert fab.check_layout(plan) < 1e-6


def test_an_exact_tiling_buys_whole_sheets_and_its_numbers_are_the_geometry():
    sheet = fab.MeshSheet(size=(2.5, 5.0), overlap=0.0, grid=0.05, wire_diameter=0.003)
    plan = fab.plan_sheets(Square(side=10.0), sheet)
    s = plan.summary()
    assert (s["sheets_bought"], s["sheets_full"], s["sheets_cut"]) == (8, 8, 0)
    assert s["waste_percent"] == pytest.approx(0.0, abs=1e-9)
    assert s["cut_length_m"] == pytest.approx(0.0, abs=1e-9)
    assert s["seam_length_m"] == pytest.approx(40.0, abs=1e-3)  # one 10 m join one way, three the other
    per_m2 = 2 / 0.05 * math.pi * 0.003 ** 2 / 4 * fab.STEEL_DENSITY  # 40 m of 3 mm wire per m^2
    assert s["mass_kg"] == pytest.approx(100.0 * per_m2, rel=1e-9)
    # an overlap lays more mesh than the metal area and makes the joins overlap strips
    lapped = fab.plan_sheets(Square(side=10.0), fab.MeshSheet(size=(2.5, 5.0), overlap=0.1))
    assert lapped.laid_area > 100.0
    assert lapped.summary()["sheets_bought"] > 8


def test_small_pieces_come_from_offcuts():
    plan = fab.plan_sheets(preset("extended"), fab.MeshSheet())
    reused = [p for p in plan.pieces if p.from_offcut]
    assert reused, "the teeth's tips fit in earlier sheets' offcuts"
    assert plan.bought < len({(round(p.in_plane.bounds[0], 3), round(p.in_plane.bounds[1], 3)) for p in plan.pieces})


def test_snap_to_sheet_turns_the_designed_teeth_into_the_built_ones():
    snapped, moved = fab.snap_to_sheet(preset("sawtooth-20-16"), fab.MeshSheet())
    assert snapped == preset("extended")  # 5 m teeth -> 4.8 m, two 2.4 m sheets: the paper's as-built plane
    assert moved == {"tooth_base": (5.0, 4.8)}
    same, moved = fab.snap_to_sheet(preset("square-10"), fab.MeshSheet())
    assert same == preset("square-10") and moved == {}
    narrow, _ = fab.snap_to_sheet(preset("sawtooth-10-8"), fab.MeshSheet(size=(3.0, 6.0)))
    assert narrow.tooth_base * narrow.teeth_per_side <= narrow.side  # snapped teeth still fit the side
    with pytest.raises(UserInputError, match="snap-to-sheet knows"):
        fab.snap_to_sheet(_star(), fab.MeshSheet())


def _star():
    from groundplane.shapes import Star

    return Star(n_points=8, outer_radius=10.0, inner_radius=6.0)


@pytest.mark.parametrize("argv, message", [
    (["--sheet", "0.05", "6"], "overlap (0.1 m) must be smaller than the sheet"),
    (["--sheet", "0", "6"], "sheet width must be a positive number"),
    (["--sheet", "2.4", "-6"], "sheet length must be a positive number"),
    (["--overlap", "-0.1"], "overlap must be >= 0"),
    (["--wire-diameter", "0.06"], "wire diameter (0.06 m) must be smaller than the grid"),
])
def test_bad_sheets_are_one_line_exit_2(tmp_path, capsys, argv, message):
    assert main(["fabricate", "--preset", "square-10", *argv, "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1


def test_design_files(tmp_path, capsys):
    best = tmp_path / "best.json"
    best.write_text(json.dumps({"params": {"side": 10.0}, "name": "Square(side=10.0)", "fom_mk": 1.0}))
    assert from_file(best) == Square(side=10.0)
    (tmp_path / "d.json").write_text(json.dumps({"shape": "square", "side": 12.0}))
    assert from_file(tmp_path / "d.json") == Square(side=12.0)
    (tmp_path / "p.json").write_text(json.dumps({"preset": "extended"}))
    assert from_file(tmp_path / "p.json") == preset("extended")
    (tmp_path / "bad.json").write_text("[1, 2]")
    with pytest.raises(ShapeError, match="not a design file"):
        from_file(tmp_path / "bad.json")
    (tmp_path / "nameless.json").write_text(json.dumps({"params": {"side": 10.0}}))
    with pytest.raises(ShapeError, match="family is not named"):
        from_file(tmp_path / "nameless.json")
    assert main(["fabricate", "--design", str(tmp_path / "bad.json"), "-o", str(tmp_path / "o")]) == 2
    assert "not a design file" in capsys.readouterr().err
    assert main(["fabricate", "--design", str(best), "-o", str(tmp_path / "o2")]) == 0
    assert json.loads((tmp_path / "o2" / "plan.json").read_text())["metal_area_m2"] == pytest.approx(100.0)
    assert np.isfinite(json.loads((tmp_path / "o2" / "plan.json").read_text())["mass_kg"])
