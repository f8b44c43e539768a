"""Shared by every loader: turn scattered (freq, theta, phi, gain) samples into a Beam on a
regular grid, or say exactly what is wrong. Written here because the vendors' exports
differ only in how they list samples, and every loader needs the same completeness checks."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from groundplane.beam import Beam, BeamFormatError

_ANGLE_DECIMALS = 6
UNIT_SCALE_TO_MHZ = {"ghz": 1e3, "mhz": 1.0, "khz": 1e-3, "hz": 1e-6}
PLAUSIBLE_MHZ = (1.0, 2000.0)  # the toolkit's band (21-cm experiments observe 40-200 MHz): outside it a unit is
# wrong (an HFSS 'Freq [GHz]' column holding MHz values reads as 40000-100000 MHz, which 100 GHz let through)


def check_frequency(f_mhz: float, where_: str) -> float:
    """Refuse a frequency no antenna export has: a file whose unit is wrong would otherwise
    be scored as a beam at 4e-5 MHz or 4e7 MHz."""
    lo, hi = PLAUSIBLE_MHZ
    if not (lo <= f_mhz <= hi):
        raise BeamFormatError(
            f"{where_}: implausible frequency {f_mhz:g} MHz (expected {lo:g} MHz to {hi:g} MHz); is its unit "
            "wrong in the file (MHz written where Hz is declared, or the reverse)?")
    return f_mhz


def where(path: str | Path, line: int | None = None) -> str:
    return f"{path}:{line}" if line is not None else str(path)


def db_to_linear(db: np.ndarray) -> np.ndarray:
    return 10.0 ** (np.asarray(db, dtype=float) / 10.0)


def fold_angles(theta: np.ndarray, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Map negative theta (HFSS-style -180..180 cuts) to theta >= 0 and phi into [0, 360)."""
    theta = np.asarray(theta, dtype=float)
    phi = np.asarray(phi, dtype=float)
    neg = theta < 0
    theta = np.where(neg, -theta, theta)
    phi = np.where(neg, phi + 180.0, phi)
    phi = np.round(phi % 360.0, _ANGLE_DECIMALS) % 360.0
    return np.round(theta, _ANGLE_DECIMALS), phi


def samples_to_grid(
    theta: np.ndarray,
    phi: np.ndarray,
    gain: np.ndarray,
    source: str,
    *,
    tolerance_db: float = 0.05,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One frequency's samples -> (theta grid, phi grid, gain[theta, phi]).

    Repeated directions (phi 0 and 360, the two halves of a -180..180 cut, overlapping
    quadrants) must agree within ``tolerance_db``; every grid point must be present.
    """
    theta, phi = fold_angles(theta, phi)
    gain = np.asarray(gain, dtype=float)
    if not np.all(np.isfinite(gain)):
        i = int(np.flatnonzero(~np.isfinite(gain))[0])
        raise BeamFormatError(f"{source}: non-finite gain at theta {theta[i]}, phi {phi[i]}")
    tg, ti = np.unique(theta, return_inverse=True)
    pg, pi = np.unique(phi, return_inverse=True)
    for name, g in (("theta", tg), ("phi", pg)):
        _check_even(g, name, source)
    # At theta = 0 or 180 every phi is the same direction: fill missing phi there.
    grid = np.full((tg.size, pg.size), np.nan)
    count = np.zeros((tg.size, pg.size), dtype=int)
    total = np.zeros((tg.size, pg.size))
    first = np.full((tg.size, pg.size), np.nan)
    np.add.at(count, (ti, pi), 1)
    np.add.at(total, (ti, pi), gain)
    order = np.argsort(ti * pg.size + pi, kind="stable")
    flat = ti[order] * pg.size + pi[order]
    _, first_idx = np.unique(flat, return_index=True)
    first.ravel()[flat[first_idx]] = gain[order][first_idx]
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = total / np.maximum(count, 1)
        spread_db = np.abs(10 * np.log10(np.maximum(mean, 1e-300)) - 10 * np.log10(np.maximum(first, 1e-300)))
    dup = count > 1
    if np.any(dup & (spread_db > tolerance_db) & (mean > 1e-20)):
        i, j = np.argwhere(dup & (spread_db > tolerance_db) & (mean > 1e-20))[0]
        raise BeamFormatError(
            f"{source}: the direction theta {tg[i]}, phi {pg[j]} is listed {count[i, j]} times "
            f"with gains that differ by {spread_db[i, j]:.3f} dB (allowed {tolerance_db} dB)"
        )
    grid[count > 0] = mean[count > 0]
    for pole in np.flatnonzero((np.abs(tg) < 1e-9) | (np.abs(tg - 180) < 1e-9)):
        row = grid[pole]
        if np.any(np.isfinite(row)) and np.any(~np.isfinite(row)):
            row[~np.isfinite(row)] = np.nanmean(row)
    if np.any(~np.isfinite(grid)):
        missing = np.argwhere(~np.isfinite(grid))
        i, j = missing[0]
        raise BeamFormatError(
            f"{source}: incomplete angular grid: {len(missing)} of {grid.size} (theta, phi) points "
            f"missing, first at theta {tg[i]}, phi {pg[j]} (expected every theta x phi combination "
            f"of {tg.size} thetas and {pg.size} phis)"
        )
    return tg, pg, grid


def _check_even(g: np.ndarray, name: str, source: str) -> None:
    """Angles must be evenly spaced, so a missing cut is not taken for a coarser step. phi
    is circular and may leave out one wide range (a quadrant export, stitched later): one
    gap of at least 45 deg and 4 steps; any other irregularity is refused."""
    if g.size < 3:
        return
    d = np.diff(g)
    if name == "phi":
        d = np.append(d, g[0] + 360.0 - g[-1])
    step = float(np.min(d))
    off = np.flatnonzero(np.abs(d - step) > 1e-3)
    if name == "phi" and off.size == 1 and d[off[0]] >= max(45.0, 4 * step):
        return
    if off.size:
        k = int(off[0])
        nxt = g[(k + 1) % g.size] + (360.0 if k + 1 == g.size else 0.0)
        raise BeamFormatError(
            f"{source}: uneven {name} grid: steps of {step:g} deg but {g[k]:g} -> {nxt:g} deg "
            f"({name} value(s) missing there?)")


def assemble(
    freqs_mhz: list[float],
    grids: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
    source: str,
    meta: dict,
) -> Beam:
    """Stack per-frequency grids (which must share their angles) into one Beam."""
    if not grids:
        raise BeamFormatError(f"{source}: no far-field data found")
    t0, p0, _ = grids[0]
    for f, (t, p, _) in zip(freqs_mhz, grids):
        if t.shape != t0.shape or p.shape != p0.shape or not (np.allclose(t, t0) and np.allclose(p, p0)):
            raise BeamFormatError(
                f"{source}: the angular grid at {f:g} MHz ({t.size} x {p.size}) differs from the one at "
                f"{freqs_mhz[0]:g} MHz ({t0.size} x {p0.size})"
            )
    f = np.asarray(freqs_mhz, dtype=float)
    for x in f:
        check_frequency(float(x), source)
    if np.unique(f).size != f.size:
        raise BeamFormatError(f"{source}: a frequency is listed twice: {sorted(f.tolist())}")
    order = np.argsort(f)
    gain = np.stack([grids[i][2] for i in order])
    return Beam(f[order], t0, p0, gain, {"source": source, **meta})


def merge_phi(beams: list[Beam], source: str, tolerance_db: float = 0.05) -> Beam:
    """Stitch beams that cover different azimuth ranges (FEKO quadrant exports) into one."""
    ref = beams[0]
    for b in beams[1:]:
        if b.freqs_mhz.shape != ref.freqs_mhz.shape or not np.allclose(b.freqs_mhz, ref.freqs_mhz):
            raise BeamFormatError(
                f"{source}: {b.meta.get('source')} has frequencies {b.freqs_mhz.tolist()} but "
                f"{ref.meta.get('source')} has {ref.freqs_mhz.tolist()}"
            )
        if b.theta_deg.shape != ref.theta_deg.shape or not np.allclose(b.theta_deg, ref.theta_deg):
            raise BeamFormatError(
                f"{source}: {b.meta.get('source')} and {ref.meta.get('source')} have different theta grids"
            )
    grids = []
    for fi, f in enumerate(ref.freqs_mhz):
        th, ph, g = [], [], []
        for b in beams:
            tt, pp = np.meshgrid(b.theta_deg, b.phi_deg, indexing="ij")
            th.append(tt.ravel())
            ph.append(pp.ravel())
            g.append(b.gain[fi].ravel())
        grids.append(samples_to_grid(np.concatenate(th), np.concatenate(ph), np.concatenate(g),
                                     f"{source} at {f:g} MHz", tolerance_db=tolerance_db))
    meta = {**ref.meta, "parts": [b.meta.get("source") for b in beams]}
    meta.pop("source", None)
    return assemble(list(ref.freqs_mhz), grids, source, meta)
