"""astropy set-up shared by the sky code: never download at run time."""
from __future__ import annotations

from functools import lru_cache

from astropy.utils import iers

# The IERS tables bundled with astropy (astropy-iers-data) are enough at the 1-deg
# level of a drift scan; never reach for the network.
iers.conf.auto_download = False
iers.conf.auto_max_age = None


@lru_cache(maxsize=8)
def _location(lat: float, lon: float, height: float):
    import astropy.units as u
    from astropy.coordinates import EarthLocation

    return EarthLocation(lat=lat * u.deg, lon=lon * u.deg, height=height * u.m)


def location(site):
    """astropy EarthLocation of a :class:`groundplane.sky.Site`."""
    return _location(site.lat_deg, site.lon_deg, site.height_m)
