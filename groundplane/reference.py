"""A slow, independent antenna-temperature integration, to check the fast path.

Where the fast path resamples the sky onto the beam grid and sums cell areas, this sums
over HEALPix sky pixels (equal area 4 pi / N), transforming each pixel to AltAz with
astropy at the time of each LST and interpolating the beam (bilinear, periodic in phi)
at the pixel's direction. Shared with the fast path: only the map and the LST times.
"""
from __future__ import annotations

import numpy as np

from .beam import Beam
from .fom import FomSettings
from .sky import T_CMB_K, load_sky_map, location, lst_times, tabulated_sky


def reference_antenna_temperature(beam: Beam, settings: FomSettings, lsts_deg: np.ndarray) -> np.ndarray:
    """T_ant [f, lst] by brute-force pixel summation, one LST at a time."""
    import astropy.units as u
    import healpy as hp
    from astropy.coordinates import AltAz, SkyCoord
    from scipy.interpolate import RegularGridInterpolator

    hemi = beam.upper_hemisphere()
    model = tabulated_sky(settings.sky) if settings.sky != "haslam" else None
    maps = model.maps_at(hemi.freqs_mhz) if model else None  # [f, pix]: the sky at each frequency
    sky = load_sky_map() if model is None else maps[0]
    npix = sky.size
    nside = hp.npix2nside(npix)
    l, b = hp.pix2ang(nside, np.arange(npix), lonlat=True)
    gal = SkyCoord(l=l * u.deg, b=b * u.deg, frame="galactic")
    phi_ext = np.concatenate([hemi.phi_deg, [hemi.phi_deg[0] + 360.0]])
    values = np.concatenate([hemi.gain, hemi.gain[:, :, :1]], axis=2).transpose(1, 2, 0)  # theta, phi, f
    interp = RegularGridInterpolator((hemi.theta_deg, phi_ext), values, bounds_error=False, fill_value=None)
    loc = location(settings.site)
    scale = (hemi.freqs_mhz / 408.0) ** (-settings.beta)
    out = np.empty((hemi.freqs_mhz.size, len(lsts_deg)))
    for k, t in enumerate(lst_times(np.asarray(lsts_deg, dtype=float), settings.site)):
        aa = gal.transform_to(AltAz(obstime=t, location=loc))
        alt, az = aa.alt.deg, aa.az.deg
        up = alt > 0
        theta = np.clip(90.0 - alt[up], hemi.theta_deg[0], hemi.theta_deg[-1])
        phi = (settings.antenna_azimuth_deg - az[up]) % 360.0
        g = interp(np.column_stack([theta, phi])).T  # [f, pix]
        t408 = sky[up]
        if maps is not None:
            tsky = maps[:, up]
        elif settings.subtract_cmb:
            tsky = scale[:, None] * (t408 - T_CMB_K)[None, :] + T_CMB_K
        else:
            tsky = scale[:, None] * t408[None, :]
        if settings.absorption is not None:
            tsky = tsky + settings.absorption.temperature(hemi.freqs_mhz)[:, None]
        total = (g * tsky).sum(axis=1)
        if settings.normalise:
            out[:, k] = total / g.sum(axis=1)
        else:
            out[:, k] = total / npix  # (1/4pi) * sum G T (4pi/N)
    return out
