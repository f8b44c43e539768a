"""NEC-2 adapter: golden values, engine guard, gain normalisation, mesh, cache, CLI.
CI solves stay small (blade alone, or a 3 m plate at a coarse mesh, few frequencies)."""
import numpy as np
import pytest

from groundplane.errors import SolveError
from groundplane.shapes import PRESETS, Plus, RegularPolygon, Square
from solvers.engines.nec import (
    NecSettings,
    check_wire_grid,
    plate_edges,
)


def test_plate_mesh_nodes_crossings_and_follows_outline():
    from shapely.geometry import Point

    for shape, sp in ((PRESETS["sawtooth-20-16"], 0.5), (Plus(4.0), 0.7), (RegularPolygon(7, 6.0), 0.8)):
        e = plate_edges(shape, sp)
        poly = shape.outline()
        mids = (e[:, 0] + e[:, 1]) / 2
        assert all(poly.buffer(1e-6).contains(Point(m)) for m in mids)
        lengths = np.hypot(*(e[:, 1] - e[:, 0]).T)
        assert lengths.min() > 0.15 * sp and lengths.max() < 1.6 * sp
        # every outline vertex (tooth tips, corners) is a node of the mesh
        nodes = np.unique(np.round(e.reshape(-1, 2), 6), axis=0)
        for v in np.asarray(poly.exterior.coords)[:-1]:
            assert np.min(np.hypot(*(nodes - v).T)) < 1e-6
        # no two edges cross or overlap except at shared ends (every crossing is a wire end)
        check_wire_grid(e, repr(shape))

def test_plate_mesh_valid_where_grid_lines_meet_outline_vertices():
    """Regression: sawtooth-15-12 at 1 m put a grid line through its tooth tips and NEC
    refused the mesh (WIRE #5 INTERSECTS WIRE #6); a sweep of sizes and spacings must mesh."""
    from groundplane.shapes import Sawtooth

    cases = [(PRESETS["sawtooth-15-12"], 1.0), (Square(15.0), 1.0), (Plus(5.0), 1.0)]
    rng = np.random.default_rng(1)
    for _ in range(25):
        side = float(rng.choice([8.0, 10.0, 12.5, 15.0])) + float(rng.uniform(-1e-9, 1e-9))
        teeth = int(rng.integers(2, 6))
        shape = Sawtooth(side, teeth, side / teeth, float(rng.choice([2.5, 4.0, 5.0])))
        cases.append((shape, float(rng.choice([0.5, 0.7, 1.0, 1.25]))))
    for shape, sp in cases:
        check_wire_grid(plate_edges(shape, sp), f"{shape!r} at {sp} m")
    # and the check itself fires on a wire running through another's end
    bad = np.array([[[0.0, -1.0], [0.0, 1.0]], [[0.0, 0.0], [1.0, 0.0]]])
    with pytest.raises(SolveError, match="away from their ends"):
        check_wire_grid(bad, "t")

def test_invalid_mesh_settings():
    with pytest.raises(ValueError, match="spacing"):
        NecSettings(spacing=-1)
    with pytest.raises(ValueError, match="3 wire radii"):
        NecSettings(plate_height=0.01, plate_wire_radius=0.01)
    with pytest.raises(ValueError, match="even"):
        NecSettings(blade_cells=(8, 7))

def test_graded_plate_mesh_is_finer_under_the_antenna_and_valid():
    coarse = plate_edges(Square(10.0), 1.0)
    graded = plate_edges(Square(10.0), 1.0, 0.3, 2.0, 4)
    check_wire_grid(graded, "graded square-10")
    mids = (graded[:, 0] + graded[:, 1]) / 2
    lengths = np.hypot(*(graded[:, 1] - graded[:, 0]).T)
    centre = np.all(np.abs(mids) < 2.5, axis=1)  # 2.0 m snaps out to the coarse line at 2.5 m
    assert lengths[centre].max() == pytest.approx(0.25) and lengths[~centre].max() == pytest.approx(1.0)
    assert len(graded) > len(coarse)
    # the refinement is part of the model's identity (its cache key), uniform or not
    assert NecSettings().as_dict()["refine_centre"] == [0.0, 1]
    assert NecSettings(refine_centre=(2.0, 2)).as_dict() != NecSettings().as_dict()
    with pytest.raises(ValueError, match="FACTOR"):
        NecSettings(refine_centre=(1.0, 0))



def test_rotational_fold_halves_the_model_and_drives_the_split_feed_both_ways():
    from groundplane.design import Design, InfinitePEC, Soil
    from solvers.engines.nec import build_model
    from solvers.engines.nec.mesh import fold_rotation

    full = build_model(Design(PRESETS["sawtooth-10-8"], Soil()), NecSettings(spacing=1.0, rotational_symmetry=False))
    half = build_model(Design(PRESETS["sawtooth-10-8"], Soil()), NecSettings(spacing=1.0))
    assert full.sections == 1 and half.sections == 2
    assert 2 * len(half.wires) == len(full.wires) and half.n_segments == full.n_segments
    # the two half-gap feed segments: one kept (+V/2), its rotated copy runs the other way (-V/2)
    (t1, v1), (t2, v2) = sorted(half.sources())
    assert v1 == 0.5 and v2 == -0.5 and t2 == t1 + len(half.wires)
    deck = half.to_deck([50.0, 51.0])
    assert f"GR {len(half.wires)} 2" in deck and deck.count("\nEX 0 ") == 2
    # every wire of the full model is a kept wire or the 180-degree image of one
    ends = {frozenset((tuple(np.round(w.p1, 6)), tuple(np.round(w.p2, 6)))) for w in full.wires}
    made = set()
    for w in half.wires:
        for s in (1, -1):
            made.add(frozenset((tuple(np.round([s * w.p1[0], s * w.p1[1], w.p1[2]], 6) + 0.0),
                                tuple(np.round([s * w.p2[0], s * w.p2[1], w.p2[2]], 6) + 0.0))))
    assert made == ends
    # the blade over PEC folds too; a model without the symmetry does not
    assert build_model(Design(None, InfinitePEC()), NecSettings()).sections == 2
    full.wires.append(type(full.wires[0])(len(full.wires) + 1, 1, (3.0, 0.2, 0.05), (3.0, 0.7, 0.05), 0.01))
    assert fold_rotation(full) is None


def test_far_field_interpolation_to_one_degree():
    """NEC's far field on a 3-degree grid, splined to 1 degree: a smooth dipole-like
    pattern comes back to 1e-5, on the quadrant and on the full circle."""
    from solvers.engines.patterns import to_one_degree

    t, p = np.meshgrid(np.radians(np.arange(91.0)), np.radians(np.arange(360.0)), indexing="ij")
    g = (1 - np.sin(t) ** 2 * np.cos(p) ** 2) * np.cos(t) ** 2 * (1 + 0.2 * np.sin(t) ** 2 * np.cos(2 * p))
    assert np.abs(to_one_degree(g[::3, 0:91:3], 3, quadrant=True) - g[:, :91]).max() < 1e-5
    g_asym = g * (1 + 0.1 * np.sin(t) * np.cos(p))
    assert np.abs(to_one_degree(g_asym[::3, ::3], 3, quadrant=False) - g_asym).max() < 1e-5
    with pytest.raises(Exception, match="far_field_step"):
        NecSettings(far_field_step=4)
