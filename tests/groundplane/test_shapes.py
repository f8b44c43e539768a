"""Ground-plane shapes (exact areas, validation) and CAD export (STEP/STL round trips)."""
import math

import pytest

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



def test_teeth_family_holds_the_papers_shapes_exactly():
    """Every Table 3 preset is a member of the optimiser's general family, outline and area."""
    from groundplane.shapes import PRESETS, Teeth

    for name, plane in PRESETS.items():
        member = Teeth.member(plane)
        assert member is not None, name
        assert member.outline().symmetric_difference(plane.outline()).area < 1e-9, name
        assert member.metal_area == pytest.approx(plane.metal_area, rel=1e-12), name


@pytest.mark.parametrize("params", [(12.0, 3, 3.0, 4.0, 0.0), (12.0, 3, 3.0, 4.0, 0.4), (8.0, 1, 8.0, 6.0, 1.0),
                                    (20.0, 6, 3.0, 2.5, 0.7)])
def test_teeth_area_is_the_outlines(params):
    from groundplane.shapes import Teeth

    t = Teeth(*params)
    assert t.outline().is_valid and t.metal_area == pytest.approx(t.outline().area, rel=1e-12)
    assert Teeth.area_of(t.params()) == pytest.approx(t.outline().area, rel=1e-12)


def test_teeth_that_do_not_fit_are_refused():
    from groundplane.errors import ShapeError
    from groundplane.shapes import Teeth

    with pytest.raises(ShapeError, match="4 teeth of base 3 m need 12 m but a side is 10 m"):
        Teeth(10.0, 4, 3.0, 2.0, 0.5)
    with pytest.raises(ShapeError, match="tip_fraction 1.5 must be <= 1"):
        Teeth(10.0, 2, 3.0, 2.0, 1.5)


def test_one_outline_one_key_whatever_the_parameters():
    import doctest

    from groundplane import shapes

    for test in doctest.DocTestFinder().find(shapes.GroundPlane.outline_key, globs=vars(shapes)):
        assert doctest.DocTestRunner().run(test).failed == 0
    xy = shapes.SHAPES["teeth-xy"]
    for name, plane in shapes.PRESETS.items():
        member = xy.member(plane)
        assert member is not None and member.outline_key() == plane.outline_key(), name
    assert shapes.Square(side=10).outline_key() != shapes.Square(side=10.001).outline_key()


def test_teeth_ending_microns_from_the_outlines_start_keep_their_corner():
    """A tooth (or corner tooth) ending tens of microns short of the outline's first corner is a
    plane, not a ring closing on itself: the 200 m^2 search lost 21 such designs on the area check."""
    from groundplane.shapes import Teeth, TeethXY

    xy = TeethXY(side=13.446868284729952, teeth_per_side=1, chamfer=4.101540891939196, base_x=1.4771717161276587,
                 height_x=7.40980823068446, tip_x=0.7477779916498858, base_y=5.160854148855616,
                 height_y=1.5149701362170305, tip_y=0.5948487315292351, base_d=5.800418188356838,
                 height_d=1.35295874213568, tip_d=0.3501701847162893)  # corner teeth 37 um short of the chamfers
    assert xy.chamfer * math.sqrt(2) - xy.base_d == pytest.approx(3.66e-5, rel=1e-2)
    assert xy.outline().area == pytest.approx(xy.metal_area, abs=1e-9) and len(xy.outline().exterior.coords) == 41
    t = Teeth(10.0, 1, 10.0 - 4e-5, 3.0, 0.5)  # the tooth's base ends 20 um from each corner
    assert t.outline().area == pytest.approx(t.metal_area, abs=1e-9)


def test_an_outline_that_disagrees_with_its_parts_names_by_how_much(monkeypatch):
    from groundplane.shapes import Square

    monkeypatch.setattr(Square, "area_of", classmethod(lambda cls, p: p["side"] ** 2 + 0.25))
    with pytest.raises(ShapeError, match=r"parts overlap .* outline area 100 m\^2, 100.25 m\^2 expected "
                                         r"\(a difference of -0.25 m\^2\)"):
        Square(side=10.0)
    monkeypatch.setattr(Square, "area_of", classmethod(lambda cls, p: p["side"] ** 2 - 5e-7))
    assert Square(side=10.0).metal_area == pytest.approx(100.0)  # below AREA_CHECK_M2: float noise, not metal
