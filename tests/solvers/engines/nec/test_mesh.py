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
    # a uniform grid keeps its cache identity: no refinement fields in the key
    assert "refine_factor" not in NecSettings().as_dict()
    assert NecSettings(refine_centre=(2.0, 2)).as_dict()["refine_factor"] == 2
    with pytest.raises(ValueError, match="FACTOR"):
        NecSettings(refine_centre=(1.0, 0))

