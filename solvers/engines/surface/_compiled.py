"""Compiled (numba) inner loops of the fast solve. Hand-written because each is a small
stencil contraction per point pair that numpy can only express with gathers of tens of
millions of elements (the gathered temporaries, not the arithmetic, were the cost);
no library offers the pFFT's precorrection. Compiled once per machine (``cache=True``). Each
loop sums a pair's moments in a few locals and writes them once: adding every point pair into
the [6, P] output touched six cache lines apart each time (1.7x on the grid's moments;
``benchmarks/bench_compiled_moments.py``)."""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def _add_moments(out: np.ndarray, row: int, col: int, g: complex, xo: float, yo: float, xs: float,
                 ys: float) -> None:
    """Add one weighted kernel value to the six pair moments at ``out[row:row + 6, col]``:
    S0, Sx, Sy (observation point), Srr = rho . rho', Sx', Sy' (source point); the order of
    ``operators.pair_moments``."""
    out[row, col] += g
    out[row + 1, col] += g * xo
    out[row + 2, col] += g * yo
    out[row + 3, col] += g * (xo * xs + yo * ys)
    out[row + 4, col] += g * xs
    out[row + 5, col] += g * ys


@numba.njit(cache=True, nogil=True)
def rule_moments(po: np.ndarray, wo: np.ndarray, ps: np.ndarray, ws: np.ndarray, pairs: np.ndarray, k: float,
                 direct: bool, image: bool) -> np.ndarray:
    """The six moments of exp(-jkR)/R by the product of two point rules, for triangle pairs
    (obs, src): points ``po`` [T, Qo, 3] and ``ps`` [T, Qs, 3] (each at its triangle's level),
    weights ``wo``/``ws`` (area included). Rows 0-5 the direct kernel (if ``direct``), then
    rows of the image kernel (source mirrored below z = 0, if ``image``): [6 or 12, P]. The
    value at R ~ 0 is 0, as ``operators.kernel``'s (a self pair's coincident points)."""
    n = pairs.shape[0]
    out = np.zeros((6 * (int(direct) + int(image)), n), np.complex128)
    acc = np.zeros((out.shape[0], 1), np.complex128)  # one pair's sums, written once (see the module doc)
    img_row = 6 if direct else 0
    for p in range(n):
        o, s = pairs[p, 0], pairs[p, 1]
        acc[:, 0] = 0.0
        for i in range(po.shape[1]):
            xo, yo, zo = po[o, i, 0], po[o, i, 1], po[o, i, 2]
            for j in range(ps.shape[1]):
                xs, ys, zs = ps[s, j, 0], ps[s, j, 1], ps[s, j, 2]
                w = wo[o, i] * ws[s, j]
                rho2 = (xo - xs) ** 2 + (yo - ys) ** 2
                if direct:
                    r = np.sqrt(rho2 + (zo - zs) ** 2)
                    if r > 1e-9:
                        _add_moments(acc, 0, 0, np.exp(-1j * k * r) / r * w, xo, yo, xs, ys)
                if image:
                    r = np.sqrt(rho2 + (zo + zs) ** 2)
                    if r > 1e-9:
                        _add_moments(acc, img_row, 0, np.exp(-1j * k * r) / r * w, xo, yo, xs, ys)
        out[:, p] = acc[:, 0]
    return out


@numba.njit(cache=True, nogil=True)
def reflected_rule_moments(po: np.ndarray, wo: np.ndarray, ps: np.ndarray, ws: np.ndarray, pairs: np.ndarray,
                           zetas: np.ndarray, tables: np.ndarray, steps: np.ndarray, sizes: np.ndarray, sign: float,
                           out_a: np.ndarray, out_q: np.ndarray) -> None:
    """Add ``sign`` x each soil's reflected kernels by the product of two point rules (shapes
    as :func:`rule_moments`): the six moments of S(R_TE) into ``out_a`` [S, 6, P] and S0 of
    S(R_q - K_q) into ``out_q`` [S, P], for S soils at once. Their tables, as real numbers
    [n_zeta, n, S, 4] (Re, Im of S(R_TE), then of S(R_q - K_q); soil s's first ``sizes[s]``
    samples, on a grid of ``steps[s]``), share the height sums ``zetas``. The kernels are
    ``ReflectedKernels.lookup``'s: the table of the nearest height sum, linear in rho. The point
    pairs' geometry is paid once for every soil (the soils of a scenario set are solved together:
    ``pfft.reflected_near``), and the arithmetic is real (the weights are: numba multiplies a
    complex by a real as by a complex), the same numbers to the last bit."""
    n_soil = tables.shape[2]
    acc = np.zeros((n_soil, 14))  # one pair's sums (Re, Im of six moments, then of S0 of the charge kernel)
    fac = np.empty(6)
    for p in range(pairs.shape[0]):
        o, s = pairs[p, 0], pairs[p, 1]
        acc[:, :] = 0.0
        for i in range(po.shape[1]):
            xo, yo, zo = po[o, i, 0], po[o, i, 1], po[o, i, 2]
            for j in range(ps.shape[1]):
                xs, ys, zs = ps[s, j, 0], ps[s, j, 1], ps[s, j, 2]
                zeta = zo + zs
                which = 0
                for z in range(1, zetas.shape[0]):
                    if zeta > 0.5 * (zetas[z - 1] + zetas[z]):
                        which = z
                rho = np.sqrt((xo - xs) ** 2 + (yo - ys) ** 2)
                w = sign * wo[o, i] * ws[s, j]
                fac[0], fac[1], fac[2], fac[3], fac[4], fac[5] = 1.0, xo, yo, xo * xs + yo * ys, xs, ys
                for k in range(n_soil):
                    x = rho / steps[k]
                    at = min(int(x), sizes[k] - 2)
                    f = x - at
                    g = 1 - f
                    ar = (tables[which, at, k, 0] * g + tables[which, at + 1, k, 0] * f) * w
                    ai = (tables[which, at, k, 1] * g + tables[which, at + 1, k, 1] * f) * w
                    acc[k, 12] += (tables[which, at, k, 2] * g + tables[which, at + 1, k, 2] * f) * w
                    acc[k, 13] += (tables[which, at, k, 3] * g + tables[which, at + 1, k, 3] * f) * w
                    acc[k, 0] += ar
                    acc[k, 1] += ai
                    for m in range(1, 6):
                        acc[k, 2 * m] += ar * fac[m]
                        acc[k, 2 * m + 1] += ai * fac[m]
        for k in range(n_soil):
            for m in range(6):
                out_a[k, m, p] += complex(acc[k, 2 * m], acc[k, 2 * m + 1])
            out_q[k, p] += complex(acc[k, 12], acc[k, 13])


@numba.njit(cache=True, nogil=True)
def grid_pair_moments(table: np.ndarray, pairs: np.ndarray, ix: np.ndarray, iy: np.ndarray, wx: np.ndarray,
                      wy: np.ndarray, level: np.ndarray, nx: int, ny: int, pts: np.ndarray,
                      w: np.ndarray, n_full: int) -> np.ndarray:
    """What the grid puts in for each (obs, src) triangle pair: the six moments [C, 6, P] of
    each kernel channel of ``table`` [n_lev, n_lev, C, 2nx-1, 2ny-1] (on grid offsets) over
    the pair's 3 x 3 point pairs (points ``pts`` [T, 3, 3], weights ``w`` [T, 3]); channels from
    ``n_full`` on get S0 alone (a scalar potential's kernel: its other moments stay 0). A point
    pair's grid value is the sum over the two 4 x 4 stencils of w_o w_s K[node_o - node_s];
    the stencils are separable, so their correlations cx, cy [7] weight a 7 x 7 window."""
    n = pairs.shape[0]
    n_ch = table.shape[2]
    out = np.zeros((n_ch, 6, n), np.complex128)
    acc = np.zeros((n_ch, 6), np.complex128)  # one pair's sums, written once
    cx = np.empty(7)
    cy = np.empty(7)
    for p in range(n):
        o, s = pairs[p, 0], pairs[p, 1]
        lo, ls = level[o], level[s]
        acc[:, :] = 0.0
        for i in range(3):
            xo, yo = pts[o, i, 0], pts[o, i, 1]
            for j in range(3):
                xs, ys = pts[s, j, 0], pts[s, j, 1]
                cx[:] = 0.0
                cy[:] = 0.0
                for a in range(4):
                    for b in range(4):
                        cx[a - b + 3] += wx[o, i, a] * wx[s, j, b]
                        cy[a - b + 3] += wy[o, i, a] * wy[s, j, b]
                bx = ix[o, i] - ix[s, j] + nx - 1 - 3
                by = iy[o, i] - iy[s, j] + ny - 1 - 3
                ww = w[o, i] * w[s, j]
                rr = xo * xs + yo * ys
                for c in range(n_ch):
                    vr = 0.0  # real and imaginary parts apart: the weights are real
                    vi = 0.0
                    for a in range(7):
                        row_r = 0.0
                        row_i = 0.0
                        for b in range(7):
                            t = table[lo, ls, c, bx + a, by + b]
                            row_r += cy[b] * t.real
                            row_i += cy[b] * t.imag
                        vr += cx[a] * row_r
                        vi += cx[a] * row_i
                    g = complex(vr, vi) * ww
                    acc[c, 0] += g
                    if c < n_full:
                        acc[c, 1] += g * xo
                        acc[c, 2] += g * yo
                        acc[c, 3] += g * rr
                        acc[c, 4] += g * xs
                        acc[c, 5] += g * ys
        for c in range(n_ch):
            for m in range(6):
                out[c, m, p] = acc[c, m]
    return out


@numba.njit(cache=True, nogil=True)
def scatter_values(data: np.ndarray, slot: np.ndarray, cc: np.ndarray, free_o: np.ndarray, free_s: np.ndarray,
                   ma: np.ndarray, mq: np.ndarray, c_a: complex, c_q: complex) -> None:
    """Add basis-pair values of triangle-pair moments into CSR ``data``: for each pair's (up
    to) 3 x 3 basis pairs with ``slot`` >= 0, Z_mn += c_m c_n [c_a (Srr - v_n.So - v_m.Ss +
    v_m.v_n S0) + c_q S0q] (``ma`` [6, P] vector moments, or an empty array; ``mq`` [P] scalar,
    or empty): the dense fill's gather formula, for one list of pairs."""
    vector = ma.shape[0] == 6
    scalar = mq.shape[0] > 0
    for p in range(slot.shape[0]):
        for i in range(3):
            for j in range(3):
                at = slot[p, i, j]
                if at < 0:
                    continue
                v = 0j
                if vector:
                    vmx, vmy = free_o[p, i, 0], free_o[p, i, 1]
                    vnx, vny = free_s[p, j, 0], free_s[p, j, 1]
                    v += c_a * (ma[3, p] - vnx * ma[1, p] - vny * ma[2, p] - vmx * ma[4, p] - vmy * ma[5, p]
                                + (vmx * vnx + vmy * vny) * ma[0, p])
                if scalar:
                    v += c_q * mq[p]
                data[at] += cc[p, i, j] * v


@numba.njit(cache=True, nogil=True)
def kernel_products(kf: np.ndarray, f: np.ndarray, out: np.ndarray) -> None:
    """The matvec's spectral products, in one pass over memory: ``out[c, lo] = sum_s kf[lo, s, k_c]
    * f[c, s]`` for the sources' spectra ``f`` [3 (Jx, Jy, charge), n_lev, sx, sy] and the kernels'
    ``kf`` [n_lev, n_lev, 2 (vector, scalar), sx, sy] (k_c = 0 for the currents, 1 for the charge).
    The two current channels share each vector kernel value read (numpy's einsum, one channel and
    level a call, read every kernel plane twice)."""
    n_lev, sx, sy = kf.shape[0], f.shape[2], f.shape[3]
    for lo in range(n_lev):
        for i in range(sx):
            for j in range(sy):
                a0 = 0j
                a1 = 0j
                a2 = 0j
                for s in range(n_lev):
                    kv = kf[lo, s, 0, i, j]
                    a0 += kv * f[0, s, i, j]
                    a1 += kv * f[1, s, i, j]
                    a2 += kf[lo, s, 1, i, j] * f[2, s, i, j]
                out[0, lo, i, j] = a0
                out[1, lo, i, j] = a1
                out[2, lo, i, j] = a2
