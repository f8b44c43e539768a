"""The function space on the grid: Rao-Wilton-Glisson (RWG) basis functions, one per interior
edge, their coefficients, and the driven symmetry class of a mirror-symmetric mesh
(:class:`MirrorSymmetry`: the same currents from a quarter of the unknowns)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .grid import TriMesh


@dataclass
class Rwg:
    """RWG basis on a mesh: edge n joins triangles ``plus[n]`` and ``minus[n]`` with free
    vertices (local indices) ``plus_free[n]``, ``minus_free[n]``; ``length[n]`` (m)."""

    edges: np.ndarray
    plus: np.ndarray
    minus: np.ndarray
    plus_free: np.ndarray
    minus_free: np.ndarray
    length: np.ndarray
    feed: np.ndarray  # indices of the driven edges

    @property
    def n(self) -> int:
        return len(self.length)


def rwg_basis(mesh: TriMesh) -> Rwg:
    """Every interior edge shared by exactly two triangles is one unknown."""
    t = mesh.tris
    local = np.array([[1, 2], [2, 0], [0, 1]])  # edge opposite local vertex 0, 1, 2
    e = np.sort(t[:, local], axis=2).reshape(-1, 2)
    tri = np.repeat(np.arange(len(t)), 3)
    free = np.tile(np.arange(3), len(t))
    keys, inv, counts = np.unique(e, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    if np.any(counts > 2):
        raise ValueError(f"surface engine: {int(np.sum(counts > 2))} edges shared by more than two triangles")
    shared = np.flatnonzero(counts == 2)
    order = np.argsort(inv, kind="stable")
    first = np.searchsorted(inv[order], shared)
    a, b = order[first], order[first + 1]
    edges = keys[shared]
    length = np.linalg.norm(mesh.nodes[edges[:, 0]] - mesh.nodes[edges[:, 1]], axis=1)
    feed = np.zeros(0, int)
    if len(mesh.feed_edges):
        fe = np.sort(np.asarray(mesh.feed_edges, int), axis=1)
        lookup = {tuple(k): i for i, k in enumerate(edges)}
        missing = [tuple(k) for k in fe if tuple(k) not in lookup]
        if missing:
            raise ValueError(f"surface engine: feed edge(s) {missing[:3]} are not interior edges of the mesh")
        feed = np.array([lookup[tuple(k)] for k in fe])
    return Rwg(edges, tri[a], tri[b], free[a], free[b], length, feed)


def rwg_coefficients(mesh: TriMesh, rwg: Rwg) -> tuple[sp.csr_matrix, list[sp.csr_matrix]]:
    """f_n = c (r - v) on each of its two triangles: C1[n, t] = c = +-l/(2A) and
    Cv[k][n, t] = c v_k (x, y of the free vertex), as sparse N x T matrices."""
    area = mesh.areas
    rows = np.concatenate([np.arange(rwg.n)] * 2)
    tris = np.concatenate([rwg.plus, rwg.minus])
    sign = np.concatenate([np.ones(rwg.n), -np.ones(rwg.n)])
    c = sign * np.concatenate([rwg.length] * 2) / (2 * area[tris])
    v = mesh.nodes[mesh.tris[tris, np.concatenate([rwg.plus_free, rwg.minus_free])]]
    shape = (rwg.n, len(mesh.tris))
    c1 = sp.csr_matrix((c, (rows, tris)), shape=shape)
    cv = [sp.csr_matrix((c * v[:, k], (rows, tris)), shape=shape) for k in range(2)]
    return c1, cv


@dataclass
class MirrorSymmetry:
    """The x-directed feed's symmetry class on a mesh symmetric about x = 0 and y = 0.

    Mirroring the structure maps each RWG function to +-1 times another; a current driven
    along x is odd under x -> -x (as a vector field: the mirror image of +x current is -x
    current) and even under y -> -y. Such currents are J = U a with one unknown per orbit
    of basis functions; the Galerkin system reduces exactly to Z[reps] U a = V[reps]
    (Z commutes with the mirrors), a quarter of the rows to fill and 1/64 of the LU."""

    reps: np.ndarray  # one representative basis per orbit that survives
    u: sp.csr_matrix  # N x n_reps: the symmetric-class function of each orbit

    @classmethod
    def of(cls, mesh: TriMesh, rwg: Rwg) -> "MirrorSymmetry | None":
        """The reduction, or None when the mesh is not symmetric about both axes."""
        key = {tuple(k): i for i, k in enumerate(np.round(mesh.nodes, 9))}
        edge_of = {tuple(e): i for i, e in enumerate(rwg.edges)}
        tri_of = {tuple(sorted(t)): i for i, t in enumerate(mesh.tris)}
        images = []
        for m in (np.array([-1.0, 1.0, 1.0]), np.array([1.0, -1.0, 1.0])):
            node = [key.get(tuple(k)) for k in np.round(mesh.nodes * m, 9)]
            if any(i is None for i in node):
                return None
            node = np.asarray(node)
            img = [edge_of.get(tuple(sorted(node[e]))) for e in rwg.edges]
            if any(i is None for i in img):
                return None
            img = np.asarray(img)
            plus_img = np.array([tri_of.get(tuple(sorted(node[mesh.tris[p]])), -1) for p in rwg.plus])
            sign = np.where(plus_img == rwg.plus[img], 1.0, -1.0)
            images.append((img, sign))
        (ix, sx), (iy, sy) = images
        group = [(np.arange(rwg.n), np.ones(rwg.n), 1.0), (ix, sx, -1.0), (iy, sy, 1.0),
                 (ix[iy], sy * sx[iy], -1.0)]  # identity, x -> -x, y -> -y, both; with the class characters
        seen = np.zeros(rwg.n, bool)
        reps, rows, cols, vals = [], [], [], []
        for n in range(rwg.n):
            if seen[n]:
                continue
            coeff: dict[int, float] = {}
            for idx, sgn, chi in group:
                seen[idx[n]] = True
                coeff[int(idx[n])] = coeff.get(int(idx[n]), 0.0) + chi * sgn[n]
            coeff = {i: c for i, c in coeff.items() if abs(c) > 1e-9}
            if not coeff:
                continue  # this orbit carries no current of the driven class
            o = len(reps)
            reps.append(n)
            for i, c in coeff.items():
                rows.append(i)
                cols.append(o)
                vals.append(c)
        u = sp.csr_matrix((vals, (rows, cols)), shape=(rwg.n, len(reps)))
        return cls(np.asarray(reps), u)
