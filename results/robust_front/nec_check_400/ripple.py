"""Where in the sky each engine puts a plane's chromatic structure: per direction, the rms over the
band of the residual of a 5-term polynomial in ln f fitted to the gain in dB (the FoM's LinLog fit,
on the beam alone rather than on the sky), then its rms over azimuth at each zenith angle.

    groundplane solve --design results/robust_front/answer-400.json --engine {surface,nec} --mesh 0.5 \
        --freqs fit-band --workers 1 -o /tmp/diag/star400_{engine}.npz   (and --preset sawtooth-20-16 -> st2016)
    groundplane solve --design results/robust_front/field/teeth-xy-600/design.json ... -o /tmp/diag/star600_{engine}.npz
    .venv/bin/python results/robust_front/nec_check_400/ripple.py /tmp/diag/{star400,st2016,star600}_{surface,nec}.npz

(the beams of nec_check_400/compare_*.md and of the 600 m^2 field answer). Prints ripple.md's body.
"""
import sys
from pathlib import Path

import numpy as np

from groundplane.beam import Beam

ANGLES = (0, 10, 20, 30, 40, 50, 60, 70, 80)


def ripple(path: str) -> tuple[float, np.ndarray, np.ndarray]:
    """(rms over the sky above 10 deg elevation, rms over azimuth per zenith angle [ANGLES], the
    zenith's residual per frequency) of the 5-term fit's residual, dB."""
    beam = Beam.load(path)
    f, th, gain = beam.freqs_mhz, beam.theta_deg, beam.gain
    keep = th <= 80
    gdb = 10 * np.log10(np.maximum(gain[:, keep, :], 1e-12))
    flat = gdb.reshape(len(f), -1)
    basis = np.vander(np.log(f / np.sqrt(f[0] * f[-1])), 5)
    coef, *_ = np.linalg.lstsq(basis, flat, rcond=None)
    res = (flat - basis @ coef).reshape(gdb.shape)
    w = np.sin(np.radians(np.maximum(th[keep], 0.5)))[None, :, None]  # solid angle
    sky = float(np.sqrt((res ** 2 * w).sum() / (w.sum() * len(f) * gdb.shape[2])))
    by_angle = np.sqrt((res ** 2).mean(axis=(0, 2)))
    return sky, by_angle[[list(th[keep]).index(a) for a in ANGLES]], res[:, 0, 0]


def strongest_period(f: np.ndarray, res: np.ndarray) -> float:
    """The period (MHz, 3-30 searched in 0.1 MHz steps) of the sinusoid that fits ``res`` best (least squares)."""
    best, where = -1.0, 0.0
    for period in np.arange(3.0, 30.0 + 1e-9, 0.1):
        basis = np.stack([np.cos(2 * np.pi * f / period), np.sin(2 * np.pi * f / period)], axis=1)
        coef, *_ = np.linalg.lstsq(basis, res, rcond=None)
        if (amp := float(np.hypot(*coef))) > best:
            best, where = amp, float(period)
    return where


def main() -> None:
    """Print the table and the zenith residuals of the beams named on the command line."""
    paths = sys.argv[1:]
    rows = ["| beam | sky rms (dB) | " + " | ".join(f"{a} deg" for a in ANGLES) + " |",
            "|---|---|" + "---|" * len(ANGLES)]
    for p in paths:
        sky, by_angle, _ = ripple(p)
        rows.append(f"| {Path(p).stem} | {sky:.4f} | " + " | ".join(f"{v:.4f}" for v in by_angle) + " |")
    print("\n".join(rows))
    print("\nThe zenith's residual per frequency (mdB, 55-97 MHz), and the period (MHz) of its strongest sinusoid "
          "(3-30 MHz searched):\n")
    for p in paths:
        f = Beam.load(p).freqs_mhz
        zenith = ripple(p)[2] * 1e3
        print(f"- {Path(p).stem}: largest |residual| {np.abs(zenith).max():.0f} mdB, period "
              f"{strongest_period(f, zenith):.1f} MHz: " + " ".join(str(int(round(v))) for v in zenith))


if __name__ == "__main__":
    main()
