"""The dense assembler and its direct solve: every Galerkin entry of Z (or the rows of the
driven symmetry class), LU-solved; the reference the fast solve (``pfft.py``) is checked against."""
from __future__ import annotations

import numpy as np

from .excitation import Solution, feed_signs
from .grid import Q3, quadrature_points
from .halfspace import C0, EPS0, MU0
from .operators import Problem, block_moments, near_corrections
from .space import MirrorSymmetry


def impedance_matrix(prob: Problem, freq_hz: float, rows: np.ndarray | None = None, block: int = 96) -> np.ndarray:
    """The Galerkin EFIE matrix (ohm) at one frequency: all N x N, or only the ``rows``
    (testing functions) given, against every basis function. One piece: the block loop shares
    its gathered moments between the vector and scalar parts (split, each block is gathered twice).

    With f_n = c (r - v) on each of its triangles, (r - va).(r' - vb) expands into the pair
    moments, and Z = C1 X1 + Cx X2 + Cy X3 where the X are [T, N] products of the moment
    matrices with the coefficients: each basis has two triangles, so every product is two
    column (or row) gathers, not a matrix product. Only the triangles of ``rows`` are
    observation triangles, so a quarter of the rows costs a quarter of the fill."""
    mesh, k = prob.mesh, 2 * np.pi * freq_hz / C0
    omega = 2 * np.pi * freq_hz
    c_a = 1j * omega * MU0 / (4 * np.pi)
    c_phi = -1j / (4 * np.pi * omega * EPS0)
    t = len(mesh.tris)
    rwg = prob.rwg
    rows = np.arange(prob.n) if rows is None else np.asarray(rows)
    tri = (rwg.plus, rwg.minus)
    needed = np.unique(np.concatenate([rwg.plus[rows], rwg.minus[rows]]))
    slot = -np.ones(t, int)
    slot[needed] = np.arange(len(needed))
    q3 = quadrature_points(mesh, Q3)
    zt = mesh.nodes[mesh.tris[:, 0], 2]
    area = mesh.areas
    coef = [sgn * rwg.length / (2 * area[tr]) for sgn, tr in ((1.0, rwg.plus), (-1.0, rwg.minus))]
    free = [mesh.nodes[mesh.tris[tr, fr], :2] for tr, fr in ((rwg.plus, rwg.plus_free), (rwg.minus, rwg.minus_free))]
    weights, kernels = prob.image_weights(freq_hz), prob.reflected_kernels(freq_hz)
    pairs, corr, corr_q, bounds = _corrections_by_block(prob, k, slot, weights, kernels, len(needed), block)
    x1 = np.empty((len(needed), prob.n), dtype=complex)
    x2 = np.empty_like(x1)
    x3 = np.empty_like(x1)

    def right(m: np.ndarray, weight: int | None = None) -> np.ndarray:
        """m @ C^T for C = C1 (weight None) or Cx/Cy (weight 0/1): two column gathers."""
        out = 0
        for s in (0, 1):
            c = coef[s] if weight is None else coef[s] * free[s][:, weight]
            out = out + m[:, tri[s]] * c
        return out

    for b, start in enumerate(range(0, len(needed), block)):
        sel = needed[start:start + block]
        obs = (q3[0][sel], q3[1][sel])
        mo, s0_q = block_moments(obs[0][:, None], obs[1][:, None], q3[0][None], q3[1][None], zt[None], k,
                                  weights, kernels)
        lo, hi = bounds[b], bounds[b + 1]
        at = (slot[pairs[lo:hi, 0]] - start, pairs[lo:hi, 1])
        for i in range(6):  # near pairs: the accurate values replace the 3-point ones
            np.add.at(mo[i], at, corr[i, lo:hi])
        np.add.at(s0_q, at, corr_q[lo:hi])
        s0, sx, sy, srr, sxs, sys_ = mo
        out = slice(start, start + len(sel))
        x1[out] = c_a * (right(srr) - right(sx, 0) - right(sy, 1)) + 4.0 * c_phi * right(s0_q)  # div f = 2c
        x2[out] = c_a * (right(s0, 0) - right(sxs))
        x3[out] = c_a * (right(s0, 1) - right(sys_))
    return _rows_of(rows, prob.n, (x1, x2, x3), coef, free, tri, slot)


def _corrections_by_block(prob: Problem, k: float, slot: np.ndarray, weights, kernels, n_needed: int, block: int):
    """The near pairs' corrections (:func:`near_corrections`) ordered by observation slot, and
    where each block of ``block`` observation triangles starts in them."""
    pairs, corr, corr_q = near_corrections(prob, k, slot >= 0, weights, kernels)
    order = np.argsort(slot[pairs[:, 0]], kind="stable")
    pairs, corr, corr_q = pairs[order], corr[:, order], corr_q[order]
    return pairs, corr, corr_q, np.searchsorted(slot[pairs[:, 0]], np.arange(0, n_needed + block, block))


def _rows_of(rows: np.ndarray, n: int, xs: tuple, coef: list, free: list, tri: tuple, slot: np.ndarray) -> np.ndarray:
    """Z[rows] = C1 X1 + Cx X2 + Cy X3: each testing function's two triangles' rows gathered."""
    x1, x2, x3 = xs
    z = np.zeros((len(rows), n), dtype=complex)
    for s in (0, 1):
        c = coef[s][rows, None]
        at = slot[tri[s][rows]]
        z += c * x1[at] + (c * free[s][rows, 0:1]) * x2[at] + (c * free[s][rows, 1:2]) * x3[at]
    return z


def solve(prob: Problem, freq_hz: float, symmetry: MirrorSymmetry | None = None) -> Solution:
    """Currents for a 1 V delta gap across the feed edges (in parallel); with ``symmetry``
    the reduced system of the driven symmetry class (the same currents, ~4x less fill)."""
    import scipy.linalg

    if len(prob.rwg.feed) == 0:
        raise ValueError("surface engine: the mesh has no feed edges")
    sign = feed_signs(prob)
    v = np.zeros(prob.n, dtype=complex)
    v[prob.rwg.feed] = sign * prob.rwg.length[prob.rwg.feed] * prob.mesh.feed_volts
    if symmetry is None:
        z = impedance_matrix(prob, freq_hz)
        i = scipy.linalg.solve(z, v, overwrite_a=True, check_finite=False)
    else:
        zr = np.asarray((symmetry.u.T @ impedance_matrix(prob, freq_hz, symmetry.reps).T).T)
        a = scipy.linalg.solve(zr, v[symmetry.reps], overwrite_a=True, check_finite=False)
        i = symmetry.u @ a
    i_in = complex(np.sum(sign * prob.rwg.length[prob.rwg.feed] * i[prob.rwg.feed]))
    return Solution(freq_hz, i, i_in, prob.mesh.feed_volts)
