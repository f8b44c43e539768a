"""Fewer solved frequencies: a beam solved at every n-th frequency of a set, the rest filled by a
cubic spline of ln G per direction (scipy's ``CubicSpline``; the gain is positive and its structure
is multiplicative), with a leave-out estimate of the error from the solved frequencies alone.

Validated on the surface engine only (``docs/speed.md``, eleventh pass): five of its beams solved at
every 1 MHz, 55-97 MHz, filled from every 2 MHz, kept every FoM within 0.18 % (2 h bins and every
LST) and every gain within 0.0013 dB rms above 10 deg; from every 3 MHz the FoM moved up to 2.7 %,
and NEC-2 beams moved 2-15 % even from every 2 MHz (they carry 1 MHz structure a spline cannot
see), so only the surface engine offers it, at 2."""
from __future__ import annotations

import numpy as np

from groundplane.beam import Beam

METHOD = "cubic spline of ln G per direction"
MIN_SOLVED = 5
SMOOTH_KEYS = ("input_impedance_re", "input_impedance_im")
MAX_GAP_MHZ = 2.0  # the widest spacing of solved frequencies the fill was validated at  # a spline through fewer says little, and the leave-out needs its own points


def solved_indices(n_freqs: int, every: int) -> np.ndarray:
    """Indices of the frequencies to solve: every ``every``-th from the first, and the last (a
    fill never extrapolates); all of them when that would leave fewer than ``MIN_SOLVED``."""
    idx = np.arange(0, n_freqs, max(1, every))
    if idx[-1] != n_freqs - 1:
        idx = np.append(idx, n_freqs - 1)
    return np.arange(n_freqs) if len(idx) < MIN_SOLVED or every <= 1 else idx


def check_fill(freqs: np.ndarray, solved: np.ndarray) -> None:
    """Refuse a fill outside what was validated: frequencies in increasing order, the solved ones at
    most ``MAX_GAP_MHZ`` apart (every 2 of a 1 MHz set; 3 MHz apart moved a FoM by 2.7 %)."""
    from groundplane.errors import SettingsError

    if np.any(np.diff(freqs) <= 0):
        raise SettingsError("solve_every 2: the frequencies must increase (the fill is a spline across them)")
    gap = float(np.max(np.diff(solved)))
    if gap > MAX_GAP_MHZ + 1e-9:
        raise SettingsError(f"solve_every 2 would solve frequencies {gap:g} MHz apart and fill between them; "
                            f"the fill is validated to {MAX_GAP_MHZ:g} MHz (a 1 MHz set, every other one solved: "
                            f"3 MHz apart moved a FoM by 2.7 %): solve every frequency of this set (--solve-every 1)")


def _spline(freqs: np.ndarray, gain: np.ndarray, at: np.ndarray) -> np.ndarray:
    from scipy.interpolate import CubicSpline

    return np.exp(CubicSpline(freqs, np.log(np.maximum(gain, 1e-30)), axis=0)(at))


def leave_out_db(freqs: np.ndarray, gain: np.ndarray, theta_deg: np.ndarray) -> float:
    """The fill's error estimated from solved frequencies alone: every other one (not the ends)
    left out and filled from the rest, its worst frequency's rms dB difference above 10 deg
    elevation. The spacing is twice the fill's, so this over-states its error (on the surface
    engine's five validation beams by 4-16x)."""
    keep = np.unique(np.append(np.arange(0, len(freqs), 2), len(freqs) - 1))
    out = np.setdiff1d(np.arange(len(freqs)), keep)
    if len(keep) < 3 or not len(out):
        return float("nan")
    up = theta_deg <= 80.0
    est = _spline(freqs[keep], gain[keep], freqs[out])
    d_db = 10 * np.log10(est[:, up] / np.maximum(gain[out][:, up], 1e-30))
    return float(np.sqrt((d_db ** 2).reshape(len(out), -1).mean(axis=1)).max())


def filled(solved: Beam, freqs_mhz: np.ndarray, every: int) -> Beam:
    """``solved`` (at a subset of ``freqs_mhz``, as :func:`solved_indices`) with the other
    frequencies filled: the gain by the spline, each per-frequency meta value NaN there (nothing was
    solved), ``interpolated`` saying which, ``frequency_fill`` how and the leave-out estimate."""
    freqs_mhz = np.asarray(freqs_mhz, dtype=float)
    at = np.searchsorted(freqs_mhz, solved.freqs_mhz)
    if not np.allclose(freqs_mhz[at], solved.freqs_mhz):
        raise ValueError("frequency fill: the solved frequencies are not among the requested ones")
    gain = _spline(solved.freqs_mhz, solved.gain, freqs_mhz)
    gain[at] = solved.gain  # the solved frequencies exactly as solved
    from groundplane.beam_meta import per_frequency_keys

    meta = dict(solved.meta)
    n, m = len(freqs_mhz), len(solved.freqs_mhz)
    # the declared per-frequency keys, and an engine's own per-frequency diagnostics (lists of numbers)
    extras = [k for k, v in meta.items() if isinstance(v, list) and len(v) == m
              and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)]
    for key in dict.fromkeys([*per_frequency_keys(meta), *extras]):
        values = np.asarray(meta[key], dtype=float)
        if key in SMOOTH_KEYS and np.all(np.isfinite(values)):  # the feed impedance: smooth, filled alike
            from scipy.interpolate import CubicSpline

            full = CubicSpline(solved.freqs_mhz, values)(freqs_mhz)
        else:  # a solve's diagnostics (time, iterations, balance): nothing was solved there
            full = np.full(n, np.nan)
        full[at] = values
        meta[key] = full.tolist()
    mask = np.ones(n, bool)
    mask[at] = False
    meta["interpolated"] = mask.tolist()
    meta["frequency_fill"] = {"solve_every": int(every), "method": METHOD, "solved": int(len(at)),
                              "leave_out_db": leave_out_db(solved.freqs_mhz, solved.gain, solved.theta_deg)}
    return Beam(freqs_mhz, solved.theta_deg, solved.phi_deg, gain, meta)
