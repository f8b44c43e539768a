"""The far field of a solution: power gain 4 pi U / P_in on a (theta, phi) grid, the image
reflected by the ground (PEC, or the soil's Fresnel coefficients)."""
from __future__ import annotations

import numpy as np

from .excitation import Solution
from .grid import Q7, quadrature_points
from .halfspace import C0, MU0, fresnel, soil_permittivity
from .operators import Problem

ETA0 = MU0 * C0


def gain_pattern(prob: Problem, sol: Solution, theta_deg: np.ndarray, phi_deg: np.ndarray,
                 mirrored_currents: bool = False) -> np.ndarray:
    """Linear power gain G(theta, phi) = 4 pi U / P_in on the grid (theta rows, phi columns).

    ``mirrored_currents``: the currents are in the x-driven mirror class (solved with
    :class:`MirrorSymmetry`: J_x even and J_y odd in both x and y), so the four images of a
    first-quadrant point sum to 4 J_x cos(k x s_x) cos(k y s_y) and -4 J_y sin(k x s_x)
    sin(k y s_y): the same far field from a quarter of the solved currents (:func:`horizontal_moments`)."""
    mesh, k = prob.mesh, 2 * np.pi * sol.freq_hz / C0
    pts, w = quadrature_points(mesh, Q7)
    alpha = prob.c1.T @ sol.currents  # J = alpha rho + beta on each triangle
    beta = np.stack([-(prob.cv[0].T @ sol.currents), -(prob.cv[1].T @ sol.currents)], axis=-1)
    jw = (alpha[:, None, None] * pts[..., :2] + beta[:, None, :]) * w[..., None]  # [T, Q, 2]
    jw = jw.reshape(-1, 2)
    p = pts.reshape(-1, 3)
    if mirrored_currents:
        first = (p[:, 0] > 0) & (p[:, 1] > 0)  # every triangle lies in one quadrant (meshes are mirrored)
        p, jw = p[first], jw[first]
    levels, level = np.unique(np.round(p[:, 2], 9), return_inverse=True)  # flat metal: a few heights
    th, ph = np.meshgrid(np.radians(theta_deg), np.radians(phi_deg), indexing="ij")
    th, ph = th.ravel(), ph.ravel()
    # exp(jk s.r) = exp(jk (x sx + y sy)) exp(jk z cz): one horizontal moment per metal level
    moment = horizontal_moments(p, jw, level, len(levels), k * np.sin(th) * np.cos(ph), k * np.sin(th) * np.sin(ph),
                                mirrored_currents)
    up = np.exp(1j * k * np.outer(np.cos(th), levels))  # [D, n_levels]
    direct = np.einsum("dl,dlc->dc", up, moment)
    mirrored = np.einsum("dl,dlc->dc", up.conj(), moment) if prob.ground != "free" else np.zeros_like(direct)
    # theta and phi parts of the horizontal current moment; the image reflects them by R_v, R_h
    if prob.ground == "soil":
        r_v, r_h = fresnel(np.cos(th), soil_permittivity(*prob.soil, sol.freq_hz))
        r_v, r_h = r_v[:, None], r_h[:, None]
    else:
        r_v, r_h = (1.0, -1.0) if prob.ground == "pec" else (0.0, 0.0)
    along = direct - r_v * mirrored
    across = direct + r_h * mirrored
    nth = np.cos(th) * (along[:, 0] * np.cos(ph) + along[:, 1] * np.sin(ph))
    nph = -across[:, 0] * np.sin(ph) + across[:, 1] * np.cos(ph)
    u = k ** 2 * ETA0 * (np.abs(nth) ** 2 + np.abs(nph) ** 2) / (32 * np.pi ** 2)
    return (4 * np.pi * u / sol.input_power).reshape(len(theta_deg), len(phi_deg))


NUFFT_EPS = 1e-13  # relative to the sum of |strengths|: far below the model's own error (measured 1.4e-13 of the peak)


def horizontal_moments(p: np.ndarray, jw: np.ndarray, level: np.ndarray, n_levels: int, kx: np.ndarray,
                       ky: np.ndarray, mirrored: bool) -> np.ndarray:
    """Per direction (kx, ky) and metal level, the horizontal current moment
    sum_p jw_p exp(j (kx x_p + ky y_p)) [D, n_levels, 2], by a type-3 non-uniform FFT (finufft):
    the direct sum was D x P complex exponentials, 16 % of a search candidate's time.

    ``mirrored``: the points are the first quadrant's of currents in the x-driven mirror class
    (J_x even in x and y, J_y odd in both), so each point enters as its four images, J_y's with
    the sign of x y: their sums are 4 J_x cos(kx x) cos(ky y) and -4 J_y sin(kx x) sin(ky y)."""
    import finufft

    x, y, cx, cy = p[:, 0], p[:, 1], jw[:, 0], jw[:, 1]
    if mirrored:
        x, y = np.concatenate([x, -x, x, -x]), np.concatenate([y, y, -y, -y])
        cx, cy = np.tile(cx, 4), np.concatenate([cy, -cy, -cy, cy])
    lev = np.tile(level, 4) if mirrored else level
    out = np.zeros((len(kx), n_levels, 2), complex)
    for at in range(n_levels):
        on = lev == at
        strengths = np.ascontiguousarray(np.stack([cx[on], cy[on]]))
        # one thread: the solves run in one-thread worker processes
        out[:, at, :] = finufft.nufft2d3(x[on], y[on], strengths, np.ascontiguousarray(kx), np.ascontiguousarray(ky),
                                         eps=NUFFT_EPS, isign=1, nthreads=1).T
    return out
