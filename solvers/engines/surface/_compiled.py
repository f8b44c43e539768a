"""Compiled (numba) inner loops of the fast solve. Hand-written because each is a small
stencil contraction per point pair that numpy can only express with gathers of tens of
millions of elements (the gathered temporaries, not the arithmetic, were the cost);
no library offers the pFFT's precorrection. Compiled once per machine (``cache=True``)."""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def grid_pair_values(table: np.ndarray, pairs: np.ndarray, ix: np.ndarray, iy: np.ndarray, wx: np.ndarray,
                     wy: np.ndarray, level: np.ndarray, nx: int, ny: int) -> tuple[np.ndarray, np.ndarray]:
    """For each (obs, src) triangle pair and each of its 3 x 3 point pairs, the grid's value of
    the vector and scalar kernels: sum over the two 4 x 4 stencils of w_o w_s K[node_o - node_s]
    (``table`` [n_lev, n_lev, 2, 2nx-1, 2ny-1] on grid offsets). The x and y stencils are
    separable: their correlations cx, cy [7] weight a 7 x 7 window of offsets."""
    n = pairs.shape[0]
    out_a = np.empty((n, 3, 3), np.complex128)
    out_q = np.empty((n, 3, 3), np.complex128)
    cx = np.empty(7)
    cy = np.empty(7)
    for p in range(n):
        o, s = pairs[p, 0], pairs[p, 1]
        lo, ls = level[o], level[s]
        for i in range(3):
            for j in range(3):
                cx[:] = 0.0
                cy[:] = 0.0
                for a in range(4):
                    for b in range(4):
                        cx[a - b + 3] += wx[o, i, a] * wx[s, j, b]
                        cy[a - b + 3] += wy[o, i, a] * wy[s, j, b]
                bx = ix[o, i] - ix[s, j] + nx - 1 - 3
                by = iy[o, i] - iy[s, j] + ny - 1 - 3
                va = 0j
                vq = 0j
                for a in range(7):
                    ra = 0j
                    rq = 0j
                    for b in range(7):
                        ra += cy[b] * table[lo, ls, 0, bx + a, by + b]
                        rq += cy[b] * table[lo, ls, 1, bx + a, by + b]
                    va += cx[a] * ra
                    vq += cx[a] * rq
                out_a[p, i, j] = va
                out_q[p, i, j] = vq
    return out_a, out_q


@numba.njit(cache=True, nogil=True)
def current_moments(p: np.ndarray, jw: np.ndarray, level: np.ndarray, n_levels: int, k: float, sx: np.ndarray,
                    sy: np.ndarray, mirrored: bool) -> np.ndarray:
    """Per direction (sx, sy) and metal level, the horizontal current moment
    sum_p jw_p exp(jk (x_p sx + y_p sy)) [D, n_levels, 2]. ``mirrored``: the points are the first
    quadrant's of currents in the x-driven mirror class, whose four images sum to
    4 J_x cos(k x sx) cos(k y sy) and -4 J_y sin(k x sx) sin(k y sy)."""
    n_dir = sx.shape[0]
    out = np.zeros((n_dir, n_levels, 2), np.complex128)
    for d in range(n_dir):
        kx, ky = k * sx[d], k * sy[d]
        for q in range(p.shape[0]):
            ax, ay = kx * p[q, 0], ky * p[q, 1]
            lev = level[q]
            if mirrored:
                out[d, lev, 0] += 4.0 * np.cos(ax) * np.cos(ay) * jw[q, 0]
                out[d, lev, 1] -= 4.0 * np.sin(ax) * np.sin(ay) * jw[q, 1]
            else:
                e = np.cos(ax + ay) + 1j * np.sin(ax + ay)
                out[d, lev, 0] += e * jw[q, 0]
                out[d, lev, 1] += e * jw[q, 1]
    return out
