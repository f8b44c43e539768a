"""The antenna's extra parts (:class:`groundplane.antenna.AntennaParts`) as NEC-2 wire grids:
the balun's outer conductors, a floating top plate, an open shield box and a feed spread
along the gap. Sizes are the design's; the cell is fixed (about lambda/60 at 100 MHz)."""
from __future__ import annotations

import numpy as np

from groundplane.antenna import BladeDipole

from .mesh import NecModel

PART_CELL = 0.05  # wire-grid cell (m) of the top plate and shield
PART_WIRE_RADIUS = 0.002  # as the blade's wires
BALUN_TUBE_RADIUS = 0.01  # the Roberts balun's brass outer conductor (19.05 mm inside, SPEC section 1)


def add_parts(model: NecModel, antenna: BladeDipole, z: float, ground_z: float, blade_cells: tuple[int, int],
              blade_wire_radius: float) -> None:
    """Add ``antenna.parts`` to a model whose panels are at ``z`` over a ground (or plate) at ``ground_z``."""
    parts = antenna.parts
    if parts is None:
        return
    if parts.balun:  # the outer conductors join the panels' inner edges to the ground
        for x in (antenna.gap / 2, -antenna.gap / 2):
            model.add((x, 0.0, ground_z), (x, 0.0, z), BALUN_TUBE_RADIUS, 10)
    if parts.feed_span:
        ys = np.linspace(-antenna.panel_width / 2, antenna.panel_width / 2, blade_cells[1] + 1)
        for y in ys[(np.abs(ys) > 1e-9) & (np.abs(ys) <= parts.feed_span / 2 + 1e-9)]:
            tag = model.add((-antenna.gap / 2, y, z), (antenna.gap / 2, y, z), blade_wire_radius)
            model.feeds.append((tag, 1.0, False))  # in parallel with the default feed at y = 0
    if parts.top_plate:
        side, gap = parts.top_plate
        _grid_patch(model, (-side / 2, -side / 2, z + gap), (side, 0, 0), (0, side, 0), PART_WIRE_RADIUS)
    if parts.shield:
        sx, sy, sh = parts.shield
        corners = [(sx / 2, sy / 2), (-sx / 2, sy / 2), (-sx / 2, -sy / 2), (sx / 2, -sy / 2)]
        for a, b in zip(corners, corners[1:] + corners[:1]):
            # each wall's vertical wires stand on the ground; its top corner wires are shared
            # with the next wall, so each wall leaves out its last column
            _wall(model, a, b, ground_z, sh)


def _grid_patch(model: NecModel, origin, u, v, radius: float) -> None:
    """A rectangular wire grid spanning ``origin + s u + t v`` (s, t in [0, 1]), cells about
    PART_CELL, every crossing a wire end (NEC joins wires only at their ends)."""
    origin, u, v = (np.asarray(a, dtype=float) for a in (origin, u, v))
    nu = max(2, int(np.ceil(np.linalg.norm(u) / PART_CELL)))
    nv = max(1, int(np.ceil(np.linalg.norm(v) / PART_CELL)))
    node = [[origin + i / nu * u + j / nv * v for j in range(nv + 1)] for i in range(nu + 1)]
    for i in range(nu + 1):
        for j in range(nv + 1):
            if i < nu:
                model.add(tuple(node[i][j]), tuple(node[i + 1][j]), radius)
            if j < nv:
                model.add(tuple(node[i][j]), tuple(node[i][j + 1]), radius)


def _wall(model: NecModel, a, b, ground_z: float, height: float) -> None:
    """A vertical wire-grid wall from corner ``a`` toward corner ``b`` (not including b's
    column, which the next wall adds), standing on the ground (wires along the ground left
    out: they would lie in it)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n = max(2, int(np.ceil(np.linalg.norm(b - a) / PART_CELL)))
    m = max(1, int(np.ceil(height / PART_CELL)))
    zs = ground_z + np.linspace(0.0, height, m + 1)
    cols = [a + (b - a) * i / n for i in range(n + 1)]
    for i in range(n):
        p, q = cols[i], cols[i + 1]
        for k in range(m):
            model.add((p[0], p[1], zs[k]), (p[0], p[1], zs[k + 1]), PART_WIRE_RADIUS)
        for zz in zs[1:]:
            model.add((p[0], p[1], zz), (q[0], q[1], zz), PART_WIRE_RADIUS)
