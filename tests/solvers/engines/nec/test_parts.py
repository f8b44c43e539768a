"""The antenna's parts as the NEC engine builds them (solvers/engines/nec/mesh.py, add_parts) are the
structures they say they are."""
from collections import Counter
from dataclasses import replace

import numpy as np

from groundplane.antenna import AntennaParts
from groundplane.design import Design, InfinitePEC
from solvers.engines.nec.mesh import PART_CELL, NecSettings, build_model, pec_reference_model

PEC = Design(None, InfinitePEC())


def _model(parts: AntennaParts):
    """The NEC model the engine builds for the blade over PEC with ``parts``."""
    return build_model(replace(PEC, antenna=replace(PEC.antenna, parts=parts)), NecSettings())


def _unfolded(parts: AntennaParts):
    """The model's wires with NEC's 180 deg copy of a folded half put back."""
    m = _model(parts)
    wires = [(np.array(w.p1), np.array(w.p2)) for w in m.wires]
    if m.sections == 2:
        turn = np.array([-1.0, -1.0, 1.0])
        wires += [(a * turn, b * turn) for a, b in wires]
    return m, wires


def test_parts_fold_and_add_only_their_wires():
    bare = pec_reference_model(PEC, NecSettings())
    for parts in (AntennaParts(balun=True), AntennaParts(top_plate=(0.4, 0.02)), AntennaParts(shield=(0.3, 0.2, 0.2))):
        m, _ = _unfolded(parts)
        assert m.sections == 2  # every part is symmetric under a half turn: NEC's fold still applies
        assert m.n_segments > bare.n_segments


def test_top_plate_is_a_connected_square_above_the_feed():
    side, gap = 0.4, 0.02
    _, wires = _unfolded(AntennaParts(top_plate=(side, gap)))
    z = PEC.antenna.height + gap
    plate = [(a, b) for a, b in wires if np.isclose(a[2], z) and np.isclose(b[2], z)]
    pts = np.array([p for w in plate for p in w])
    assert np.allclose(pts[:, :2].min(axis=0), -side / 2) and np.allclose(pts[:, :2].max(axis=0), side / 2)
    n = round(side / PART_CELL)
    assert len(plate) == 2 * n * (n + 1)  # a full grid of n x n cells, no wire twice
    ends = Counter(tuple(np.round(p, 6)) for p in pts)
    assert all(c >= 2 for c in ends.values())  # every node joins two or more wires (no dangling ends)


def test_shield_walls_close_a_box_standing_on_the_ground():
    sx, sy, sh = 0.3, 0.2, 0.2
    _, wires = _unfolded(AntennaParts(shield=(sx, sy, sh)))
    vertical = [(a, b) for a, b in wires if not np.isclose(a[2], b[2])]  # only the shield has any
    feet = Counter(tuple(np.round(a[:2], 6)) for a, b in vertical if np.isclose(min(a[2], b[2]), 0.0))
    perimeter = 2 * (sx + sy)
    assert len(feet) == round(perimeter / PART_CELL)  # one column per cell along the perimeter
    assert set(feet.values()) == {1}  # each corner column once, not once per wall
    for (x, y) in feet:
        assert np.isclose(abs(x), sx / 2) or np.isclose(abs(y), sy / 2)
    top = max(max(a[2], b[2]) for a, b in vertical)
    assert np.isclose(top, sh)


def test_feed_span_puts_a_source_on_every_gap_wire_it_covers():
    ant = PEC.antenna
    ny = NecSettings().blade_cells[1]
    for span, nodes in ((0.26, 3), (ant.panel_width, ny + 1)):  # panel-grid nodes with |y| <= span / 2
        m = _model(AntennaParts(feed_span=span))
        assert m.sections == 2
        crossing = [w for w in m.wires if np.isclose(w.p1[2], ant.height) and w.p1[1] == w.p2[1]
                    and np.isclose(abs(w.p1[0] - w.p2[0]), ant.gap)]
        # the kept half holds one of each +-y pair; NEC's half-turn copy brings the other
        assert 2 * len(crossing) == nodes - 1
        volts = sorted(abs(v) for _, v in m.sources())
        assert volts == [0.5, 0.5] + [1.0] * (nodes - 1)  # the split y = 0 feed, then one per wire (or its copy)
        fed = {tag for tag, _, _ in m.feeds}
        assert all(w.tag in fed for w in crossing)
