"""Ground-plane shapes (exact areas, validation) and CAD export (STEP/STL round trips)."""
import json
import math

import pytest

from groundplane import cad
from groundplane.cli import main
from groundplane.shapes import (
    PRESETS,
    Plus,
    PolygonPlane,
    RegularPolygon,
    Sawtooth,
    ShapeError,
    Square,
    Star,
    from_dict,
    to_dict,
)

# SPEC section 4 (paper Table 3) areas, and the deployed plane: 400 + 16 * (4.8 * 5 / 2)
SPEC_AREAS = {
    "square-10": 100, "square-20": 400, "square-30": 900, "plus-15": 125, "plus-30": 500,
    "sawtooth-10-8": 200, "sawtooth-15-12": 375, "sawtooth-20-16": 600, "sawtooth-20-20": 600,
    "extended": 592,
}
SPEC_EXTENT = {"plus-15": 15, "plus-30": 30, "extended": 30, "sawtooth-20-16": 30, "square-10": 10}


@pytest.mark.parametrize("name", sorted(SPEC_AREAS))
def test_preset_areas_exact(name):
    s = PRESETS[name]
    assert s.metal_area == pytest.approx(SPEC_AREAS[name], abs=1e-9)
    assert s.outline().area == pytest.approx(SPEC_AREAS[name], abs=1e-9)
    if name in SPEC_EXTENT:
        assert s.extent == pytest.approx(SPEC_EXTENT[name])
    assert s.mirror_symmetry == {"x": True, "y": True}
    assert s.outline().contains(__import__("shapely.geometry").geometry.Point(0, 0))


def test_teeth_counts_and_edges():
    assert PRESETS["sawtooth-20-16"].n_teeth == 16
    assert PRESETS["sawtooth-20-20"].n_teeth == 20
    assert PRESETS["extended"].edge_count == 52  # 16 teeth x 2 + 5 gaps per side x 4
    assert Square(3).edge_count == 4 and Plus(2).edge_count == 12


def test_keys_are_stable_and_distinct():
    assert Square(10.0).key() == Square(10).key() == PRESETS["square-10"].key()
    assert len({s.key() for s in PRESETS.values()}) == len(PRESETS)
    assert from_dict(to_dict(PRESETS["extended"])).key() == PRESETS["extended"].key()


def test_new_shapes_areas():
    p = RegularPolygon(8, 10.0)
    assert p.metal_area == pytest.approx(p.outline().area) == pytest.approx(200 * math.sqrt(2))
    st = Star(12, 15.0, 10.0)
    assert st.metal_area == pytest.approx(st.outline().area)
    assert st.edge_count == 24 and st.mirror_symmetry == {"x": True, "y": True}
    assert RegularPolygon(5, 1.0).mirror_symmetry["x"] is True
    assert RegularPolygon(5, 1.0).mirror_symmetry["y"] is False
    poly = PolygonPlane([(-1, -1), (2, -1), (2, 1), (-1, 1)])
    assert poly.metal_area == pytest.approx(6.0) and poly.mirror_symmetry["y"] is False


@pytest.mark.parametrize("make,msg", [
    (lambda: Square(0), "side must be a positive"),
    (lambda: Square(float("inf")), "side must be a positive"),
    (lambda: Plus(-2), "arm must be a positive"),
    (lambda: Sawtooth(10, 3, 5, 5), r"3 teeth of base 5 m need 15 m but a side is 10 m; use teeth_per_side <= 2"),
    (lambda: Sawtooth(10, 0, 5, 5), "whole number >= 1"),
    (lambda: Sawtooth(10, 2.5, 1, 1), "whole number"),
    (lambda: Sawtooth(10, 2, 5, float("nan")), "tooth_height must be a positive"),
    (lambda: RegularPolygon(2, 1.0), "n_sides"),
    (lambda: Star(6, 1.0, 1.5), "inner_radius"),
    (lambda: PolygonPlane([(0, 0), (1, 1), (1, 0), (0, 1)]), "not a simple polygon"),
    (lambda: PolygonPlane([(1, 1), (2, 1), (2, 2)]), "feed .* inside"),
    (lambda: from_dict({"shape": "square", "side": 1, "arm": 2}), "unknown parameter"),
    (lambda: from_dict({"shape": "hexagon"}), "unknown shape"),
])
def test_invalid_parameters_rejected(make, msg):
    with pytest.raises(ShapeError, match=msg):
        make()


def test_stl_watertight_with_expected_volume(tmp_path):
    import trimesh

    s = PRESETS["sawtooth-20-16"]
    p = cad.export(s, tmp_path / "p.stl", thickness=0.002)
    m = trimesh.load(p)
    assert m.is_watertight
    assert m.volume == pytest.approx(600 * 0.002, rel=1e-6)
    top_bottom = 2 * 600
    assert m.area == pytest.approx(top_bottom + s.outline().length * 0.002, rel=1e-6)


def test_step_roundtrip_in_metres(tmp_path):
    s = PRESETS["extended"]
    p = cad.export(s, tmp_path / "p.step", thickness=0.003)
    text = p.read_text()
    assert "SI_UNIT($,.METRE.)" in text
    assert cad.import_step_volume(p) == pytest.approx(592 * 0.003, rel=1e-6)


def test_step_assembly_with_named_parts(tmp_path):
    s = PRESETS["square-10"]
    p = cad.export(s, tmp_path / "a.step", with_antenna=True)
    text = p.read_text()
    for name in ("ground_plane", "blade_pos", "blade_neg"):
        assert f"PRODUCT('{name}'" in text
    assert "SI_UNIT($,.METRE.)" in text
    blades = 2 * 1.252 * 0.964 * 0.003
    assert cad.import_step_volume(p) == pytest.approx(100 * 0.002 + blades, rel=1e-6)


def test_drawings(tmp_path):
    for suffix in ("svg", "png"):
        p = cad.export(PRESETS["plus-30"], tmp_path / f"d.{suffix}")
        assert p.stat().st_size > 5000
    with pytest.raises(ValueError, match="unknown output format"):
        cad.export(PRESETS["plus-30"], tmp_path / "d.dxf")


def test_cli_shapes_json(capsys):
    assert main(["shapes", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    by = {r["name"]: r for r in rows}
    assert set(by) == set(SPEC_AREAS)
    assert by["sawtooth-20-16"]["metal_area_m2"] == pytest.approx(600)
    assert by["plus-30"]["extent_m"] == pytest.approx(30)
    assert all({"name", "shape", "metal_area_m2", "extent_m"} <= set(r) for r in rows)


def test_cli_export_and_errors(tmp_path, capsys):
    out = tmp_path / "s.stl"
    assert main(["export", "sawtooth", "--side", "20", "--teeth-per-side", "4", "--tooth-base", "5",
                 "--tooth-height", "5", "-o", str(out)]) == 0
    assert out.exists()
    assert main(["export", "--preset", "plus-15", "-o", str(tmp_path / "p.png")]) == 0
    capsys.readouterr()
    assert main(["export", "sawtooth", "--side", "10", "--teeth-per-side", "3", "--tooth-base", "5",
                 "--tooth-height", "5", "-o", str(out)]) == 2
    assert "use teeth_per_side <= 2" in capsys.readouterr().err
    assert main(["export", "square", "-o", str(out)]) == 2
    assert "square needs --side" in capsys.readouterr().err
    assert main(["export", "square", "--side", "3", "--arm", "2", "-o", str(out)]) == 2
    assert "does not take --arm" in capsys.readouterr().err
