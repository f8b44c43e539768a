"""The grid (bempp-cl's first layer): flat horizontal triangles with the delta-gap feed, and
the quadrature rules every integral over them uses. Geometry only: no basis, no kernel."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# Barycentric quadrature on a triangle (weights sum to 1; multiply by the area).
Q3 = (np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]]), np.full(3, 1 / 3))
_a1, _b1, _a2, _b2 = 0.059715871789770, 0.470142064105115, 0.797426985353087, 0.101286507323456
Q7 = (np.array([[1 / 3, 1 / 3, 1 / 3],
                 [_a1, _b1, _b1], [_b1, _a1, _b1], [_b1, _b1, _a1],
                 [_a2, _b2, _b2], [_b2, _a2, _b2], [_b2, _b2, _a2]]),
       np.array([0.225] + [0.132394152788506] * 3 + [0.125939180544827] * 3))


def subdivided(rule: tuple[np.ndarray, np.ndarray], level: int) -> tuple[np.ndarray, np.ndarray]:
    """``rule`` on each of the 4**level congruent sub-triangles of the reference triangle."""
    bary, w = rule
    tris = [np.eye(3)]
    for _ in range(level):
        nxt = []
        for t in tris:
            m01, m12, m20 = (t[0] + t[1]) / 2, (t[1] + t[2]) / 2, (t[2] + t[0]) / 2
            nxt += [np.array([t[0], m01, m20]), np.array([m01, t[1], m12]), np.array([m20, m12, t[2]]),
                    np.array([m12, m20, m01])]
        tris = nxt
    return (np.concatenate([bary @ t for t in tris]), np.tile(w, len(tris)) / len(tris))


Q7_TOUCHING = subdivided(Q7, 2)  # 112 points: the outer rule where the inner integral has a log edge


@dataclass
class TriMesh:
    """Flat horizontal triangles: ``nodes`` [P, 3] (m), ``tris`` [T, 3] node indices, and the
    delta-gap feed: ``feed_edges`` (node pairs) each driven with ``feed_volts`` V/m x length."""

    nodes: np.ndarray
    tris: np.ndarray
    feed_edges: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), int))
    feed_volts: float = 1.0

    def __post_init__(self) -> None:
        self.nodes = np.asarray(self.nodes, dtype=float)
        self.tris = np.asarray(self.tris, dtype=np.int64)
        z = self.nodes[self.tris, 2]
        if np.ptp(z, axis=1).max(initial=0.0) > 1e-9:
            raise ValueError("surface engine: every triangle must be horizontal (flat, level metal only)")
        if np.any(self.areas <= 1e-12):
            raise ValueError("surface engine: degenerate (zero-area) triangle in the mesh")

    @property
    def areas(self) -> np.ndarray:
        p = self.nodes[self.tris]
        a, b = p[:, 1, :2] - p[:, 0, :2], p[:, 2, :2] - p[:, 0, :2]
        return 0.5 * np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])

    @property
    def centroids(self) -> np.ndarray:
        return self.nodes[self.tris].mean(axis=1)

    @property
    def sizes(self) -> np.ndarray:
        """Longest edge of each triangle (m)."""
        p = self.nodes[self.tris]
        return np.max(np.linalg.norm(p - np.roll(p, 1, axis=1), axis=2), axis=1)


def quadrature_points(mesh: TriMesh, rule: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature points [T, Q, 3] and weights [T, Q] (area included)."""
    bary, w = rule
    p = np.einsum("qk,tkd->tqd", bary, mesh.nodes[mesh.tris])
    p[..., 2] = mesh.nodes[mesh.tris[:, 0], 2][:, None]  # exactly the triangle's level: a self pair's
    return p, w[None, :] * mesh.areas[:, None]  # coincident points must be at R = 0, not 1e-17
