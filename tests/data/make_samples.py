"""Writes the small CST and HFSS sample exports in this folder, following the vendors'
documented column layouts, from an analytic short-dipole-over-ground pattern
G = 1.5 (1 - sin^2 theta cos^2 phi) * 4 sin^2(k h cos theta) / norm (upper hemisphere).
Run: python tests/data/make_samples.py"""
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent


def gain(theta_deg, phi_deg, f_mhz):
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    kh = 2 * np.pi * f_mhz / 299.792458 * 1.04
    g = 1.5 * (1 - np.sin(t) ** 2 * np.cos(p) ** 2) * 4 * np.sin(kh * np.cos(t)) ** 2
    return np.where(np.cos(t) > 0, g, 0.0) + 1e-6


def cst(f_mhz):
    lines = ["Theta [deg.]  Phi   [deg.]  Abs(Gain)[dBi   ]   Abs(Theta)[dBi   ]  Phase(Theta)[deg.]  "
             "Abs(Phi  )[dBi   ]  Phase(Phi  )[deg.]  Ax.Ratio[dB    ]",
             "-" * 150]
    for ph in np.arange(0, 361, 30.0):
        for th in np.arange(0, 181, 15.0):
            g = 10 * np.log10(gain(th, ph, f_mhz))
            lines.append(f"{th:12.3f}{ph:12.3f}{g:16.6e}{g - 3:16.6e}{0.0:16.3f}{g - 3:16.6e}{90.0:16.3f}{40.0:16.3f}")
    (HERE / f"cst_farfield (f={f_mhz:g}) [1].txt").write_text("\n".join(lines) + "\n")


def hfss():
    rows = ['"Freq [MHz]","Phi [deg]","Theta [deg]","dB(GainTotal) []"']
    for f in (50.0, 75.0):
        for ph in np.arange(0, 180, 30.0):
            for th in np.arange(-180, 181, 15.0):
                t, p = (th, ph) if th >= 0 else (-th, ph + 180)
                rows.append(f"{f:g},{ph:g},{th:g},{10 * np.log10(gain(t, p, f)):.6f}")
    (HERE / "hfss_gain.csv").write_text("\n".join(rows) + "\n")


if __name__ == "__main__":
    for f in (50.0, 75.0):
        cst(f)
    hfss()
