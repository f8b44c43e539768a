"""Gain patterns on the 1-degree grid every engine returns: a mirror-symmetric quadrant to the
full circle, a coarser far-field grid to 1 degree, and the upper-hemisphere mean gain."""
from __future__ import annotations

import numpy as np

from groundplane.beam import Beam


def mirror_quadrant(q: np.ndarray) -> np.ndarray:
    """phi 0..90 of a pattern symmetric about both vertical planes -> phi 0..359."""
    full = np.empty(q.shape[:-1] + (360,))
    full[..., 0:91] = q
    full[..., 91:181] = q[..., 89::-1][..., :90]  # phi 91..180 = 180 - phi in 89..0
    full[..., 181:271] = q[..., 1:91]  # phi 181..270 = phi - 180 in 1..90
    full[..., 271:360] = q[..., 89:0:-1]  # phi 271..359 = 360 - phi in 89..1
    return full


def upper_mean_gain(g: np.ndarray) -> float:
    """Mean of G over the upper hemisphere of a [91, 360] or quadrant [91, 91] 1-degree pattern."""
    full = mirror_quadrant(g) if g.shape[-1] == 91 else g
    w = Beam([1.0], np.arange(91.0), np.arange(360.0), full[None]).solid_angle_weights()
    return float((full * w).sum() / w.sum())


def to_one_degree(g: np.ndarray, step: int, quadrant: bool) -> np.ndarray:
    """A [theta, phi] gain grid every ``step`` deg -> every 1 deg, by a bicubic
    interpolating spline (scipy) on the grid padded with its own symmetries, so the
    ends (zenith, phi = 0/90 or the phi wrap) are interior points of the spline.

    ``quadrant``: phi 0..90 of a pattern symmetric about both vertical planes; else phi
    0..360-step. Either way G(-theta, phi) = G(theta, phi + 180)."""
    from scipy.interpolate import RectBivariateSpline

    pad = 3
    th = np.arange(g.shape[0]) * step
    ph = np.arange(g.shape[1]) * step
    if quadrant:  # G(theta, -phi) = G(theta, phi), G(theta, 90 + phi) = G(theta, 90 - phi), G(-theta) = G(theta)
        gp = np.concatenate([g[:, pad:0:-1], g, g[:, -2:-2 - pad:-1]], axis=1)
        gp = np.concatenate([gp[pad:0:-1], gp], axis=0)
        out_phi = np.arange(91.0)
    else:  # periodic in phi; G(-theta, phi) = G(theta, phi + 180)
        def wrap(a: np.ndarray) -> np.ndarray:
            return np.concatenate([a[:, -pad:], a, a[:, :pad]], axis=1)

        gp = wrap(g)
        gp = np.concatenate([wrap(np.roll(g, -(g.shape[1] // 2), axis=1))[pad:0:-1], gp], axis=0)
        out_phi = np.arange(360.0)
    th_p = np.concatenate([-th[pad:0:-1], th])
    ph_p = np.concatenate([-ph[pad:0:-1] if quadrant else ph[-pad:] - 360.0, ph,
                           (2 * ph[-1] - ph[-2:-2 - pad:-1]) if quadrant else ph[:pad] + 360.0])
    spline = RectBivariateSpline(th_p, ph_p, gp, kx=3, ky=3, s=0)
    return np.clip(spline(np.arange(91.0), out_phi), 0.0, None)
