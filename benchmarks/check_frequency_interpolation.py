"""Issue 35's "fewer solved frequencies": would a beam solved at every n-th frequency and
interpolated in frequency (a cubic spline of ln G per direction) keep the FoM? Leave-out check
on beams solved at every frequency: keep every ``step``-th, interpolate to the rest, and compare the
interpolated beam's gain (dB rms above 10 deg elevation, worst frequency) and LST-averaged FoM
(default settings) with the solved beam's on the same frequencies.

    .venv/bin/python benchmarks/check_frequency_interpolation.py [BEAM.npz ...] [--steps 2 3]
        [--reference SOLVED.npz] [-o results/bench/frequency_interpolation.txt]

With ``--reference`` (the same design on another soil, solved at every frequency) each beam is
filled as the reference times a spline of their ratio (ln G - ln G_ref): would a scenario set's
other soils need only every n-th frequency solved, the first soil carrying the rest?

Default beam: ``examples/lowband_square10_nec.npz`` (NEC-2, 40-100 MHz every 1 MHz). Prints
numbers only; the verdict line is a condition on them (the issue's bar: FoM within 0.5 %).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
FOM_TOLERANCE = 0.005  # the bar for any speed-up


def interpolated(beam, step: int, reference=None):
    """The beam with every frequency but each ``step``-th replaced by a cubic spline of ln G (with a
    ``reference`` beam on the same frequencies and grid: of ln G - ln G_ref, times G_ref)."""
    from scipy.interpolate import CubicSpline

    keep = np.arange(0, len(beam.freqs_mhz), step)
    if keep[-1] != len(beam.freqs_mhz) - 1:
        keep = np.append(keep, len(beam.freqs_mhz) - 1)  # never extrapolate
    ln_ref = 0.0 if reference is None else np.log(np.maximum(reference.gain, 1e-30))
    ln_g = np.log(np.maximum(beam.gain, 1e-30)) - ln_ref
    est = CubicSpline(beam.freqs_mhz[keep], ln_g[keep], axis=0)(beam.freqs_mhz) + ln_ref
    return dataclasses.replace(beam, gain=np.exp(est)), len(keep)


def main() -> None:
    from groundplane.beam import Beam
    from groundplane.fom import FomSettings, figure_of_merit

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("beams", nargs="*", default=[str(ROOT / "examples" / "lowband_square10_nec.npz")])
    ap.add_argument("--steps", type=int, nargs="+", default=[2, 3])
    ap.add_argument("--reference", help="fill the ratio to this beam (another soil, every frequency solved)")
    ap.add_argument("-o", "--out")
    args = ap.parse_args()
    reference = Beam.load(args.reference) if args.reference else None
    settings = {"2 h bins": FomSettings(), "every LST": FomSettings(lst_bin_hours=0.0)}
    lines, worst = [], 0.0
    for path in args.beams:
        beam = Beam.load(path)
        fom = {k: figure_of_merit(beam, s).lst_averaged_mk for k, s in settings.items()}
        lines.append(f"{Path(path).name}: {len(beam.freqs_mhz)} frequencies {beam.freqs_mhz[0]:g}-{beam.freqs_mhz[-1]:g} "
                     "MHz, FoM " + ", ".join(f"{v:.2f} mK ({k})" for k, v in fom.items()))
        if reference is not None and (not np.array_equal(reference.freqs_mhz, beam.freqs_mhz)
                                      or reference.gain.shape != beam.gain.shape):
            sys.exit(f"--reference {args.reference}: not on {Path(path).name}'s frequencies and directions "
                     f"({reference.gain.shape} against {beam.gain.shape})")
        for step in args.steps:
            est, n = interpolated(beam, step, reference)
            up = beam.theta_deg <= 80
            d_db = 10 * np.log10(est.gain[:, up] / beam.gain[:, up])
            rms = np.sqrt((d_db ** 2).reshape(len(beam.freqs_mhz), -1).mean(axis=1)).max()
            f_est = {k: figure_of_merit(est, s).lst_averaged_mk for k, s in settings.items()}
            worst = max(worst, *(abs(f_est[k] / fom[k] - 1) for k in fom))
            lines.append(f"  every {step}: {n} solved, gain {rms:.4f} dB rms (worst frequency), FoM "
                         + ", ".join(f"{f_est[k]:.2f} mK ({100 * (f_est[k] / fom[k] - 1):+.2f} %, {k})" for k in fom))
        print("\n".join(lines[-1 - len(args.steps):]), flush=True)
    verdict = ("every interpolated FoM is within" if worst <= FOM_TOLERANCE else "an interpolated FoM is outside")
    lines.append(f"largest FoM change {100 * worst:.2f} %: {verdict} the issue's {100 * FOM_TOLERANCE:g} %")
    print(lines[-1])
    if args.out:
        head = f"# .venv/bin/python benchmarks/check_frequency_interpolation.py {' '.join(sys.argv[1:])}  ({time.strftime('%Y-%m-%d')})\n"
        Path(args.out).write_text(head + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
