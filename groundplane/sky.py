"""The sky seen by a drift-scanning antenna: the Haslam 408 MHz map in the horizon frame.

With one spectral index the sky at frequency nu is ``(nu/408)^-beta * T_408``, so the
408 MHz map only has to be resampled into the beam's (theta, phi) grid once per LST.
That ``[LST, theta, phi]`` array is computed with astropy (AltAz -> Galactic at the
time each LST occurs, so precession, nutation and aberration are astropy's) and healpy
(bilinear interpolation), and cached on disk: scoring a beam is then a matrix product.
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

from . import paper
from .errors import UserInputError
from .files import atomic_path

HASLAM_FILE = "haslam408_haslam1982_mpifr_nside0128_galactic_ring_K.fits"
SIDEREAL_DAY_S = 86164.0905  # mean sidereal day; only a first guess, refined with astropy
T_CMB_K = 2.725


@dataclass(frozen=True)
class Site:
    """An observing site (geodetic latitude and east longitude, deg)."""

    name: str = "MRO"
    lat_deg: float = paper.MRO_LATITUDE_DEG
    lon_deg: float = paper.MRO_LONGITUDE_DEG
    height_m: float = 0.0

    def __str__(self) -> str:
        return self.name


MRO = Site()
# Sites of global 21-cm experiments, each with where its coordinates come from. Heights are
# kept 0 as for the MRO (the FoM's sky does not depend on a site's height at this level).
SITES: dict[str, tuple[Site, str]] = {
    "MRO": (MRO, "EDGES, Murchison Radio-astronomy Observatory, Western Australia: the paper's site (SPEC)"),
    "KAROO": (Site("KAROO", -30.721526, 21.428304),
              "the Karoo radio reserve, South Africa (REACH, HERA): HERA's location in pyuvdata 3.2's known "
              "telescopes (from hera_mc); REACH's own coordinates are not in our sources"),
    "MARS": (Site("MARS", 79.37980, -90.99885),
             "MIST at the McGill Arctic Research Station, Axel Heiberg Island, Canada: the site given in the MIST "
             "soil paper (arXiv:2504.14444)"),
    "OVRO": (Site("OVRO", 37.239777, -118.281667),
             "LEDA / OVRO-LWA, Owens Valley Radio Observatory, California: OVRO-LWA's location in pyuvdata 3.2's "
             "known telescopes"),
}


def site_by_name(name: str) -> Site:
    """A site of :data:`SITES` by name (any case)."""
    key = name.strip().upper()
    if key not in SITES:
        raise UserInputError(f"--site {name}: unknown site; choose one of {', '.join(SITES)}, or give --lat and --lon")
    return SITES[key][0]


@lru_cache(maxsize=8)
def _location(lat: float, lon: float, height: float):
    import astropy.units as u
    from astropy.coordinates import EarthLocation
    from astropy.utils import iers

    # Every astropy time/frame computation here starts from a location, so this is where
    # astropy is set up (imported lazily: it costs ~0.5 s). The IERS tables bundled with
    # astropy (astropy-iers-data) are enough at the 1-deg level of a drift scan; never
    # reach for the network.
    iers.conf.auto_download = False
    iers.conf.auto_max_age = None

    return EarthLocation(lat=lat * u.deg, lon=lon * u.deg, height=height * u.m)


def location(site: Site):
    """astropy EarthLocation of a :class:`Site`."""
    return _location(site.lat_deg, site.lon_deg, site.height_m)


def cache_dir() -> Path:
    """Where derived, recomputable data lives (GROUNDPLANE_CACHE, else ~/.cache/groundplane)."""
    d = os.environ.get("GROUNDPLANE_CACHE")
    path = Path(d) if d else Path.home() / ".cache" / "groundplane"
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:  # unwritable: every write to it is skipped with a warning, nothing stops
        from .files import warn_once

        warn_once("cache-dir", f"the cache folder {path} cannot be made ({exc.strerror or exc}); going on without it")
    return path


def default_sky_path() -> Path:
    """The Haslam 408 MHz map shipped inside the package (no network needed)."""
    return Path(str(resources.files("groundplane") / "data" / HASLAM_FILE))


@lru_cache(maxsize=4)
def _read_map(path: str) -> np.ndarray:
    import healpy as hp

    m = hp.read_map(path, field=0, dtype=np.float64)
    if not np.all(np.isfinite(m)):
        raise UserInputError(f"{path}: sky map has non-finite pixels")
    return m


def load_sky_map(path: str | os.PathLike | None = None) -> np.ndarray:
    """A HEALPix map in Galactic coordinates, RING ordering, Kelvin (default: Haslam 408 MHz)."""
    return _read_map(str(path or default_sky_path()))


def _file_digest(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()[:16]


def lst_grid(n_lst: int = 360) -> np.ndarray:
    """LSTs (deg) of an n-bin drift scan over one sidereal day: 0, 360/n, ..."""
    return np.arange(n_lst) * (360.0 / n_lst)


def lst_times(lsts_deg: np.ndarray, site: Site = MRO, epoch: str = "2017-01-01T00:00:00"):
    """astropy Times, after ``epoch``, at which the local apparent sidereal time equals each LST."""
    import astropy.units as u
    from astropy.time import Time

    loc = location(site)
    t0 = Time(epoch, scale="utc")
    lst0 = t0.sidereal_time("apparent", longitude=loc.lon).deg
    t = t0 + ((np.asarray(lsts_deg) - lst0) % 360.0) / 360.0 * SIDEREAL_DAY_S * u.s
    for _ in range(2):  # refine with astropy's own sidereal time
        err = (t.sidereal_time("apparent", longitude=loc.lon).deg - np.asarray(lsts_deg) + 180) % 360 - 180
        t = t - err / 360.0 * SIDEREAL_DAY_S * u.s
    return t


def horizon_to_galactic(
    alt_deg: np.ndarray, az_deg: np.ndarray, times, site: Site = MRO
) -> tuple[np.ndarray, np.ndarray]:
    """Galactic (l, b) in deg of horizon directions (az from North through East) at each time.

    Returns arrays of shape ``(len(times),) + alt.shape``. No refraction (pressure 0).
    """
    import astropy.units as u
    from astropy.coordinates import AltAz, Galactic, SkyCoord

    loc = location(site)
    ls, bs = [], []
    for t in np.atleast_1d(times):
        frame = AltAz(obstime=t, location=loc)
        c = SkyCoord(alt=np.ravel(alt_deg) * u.deg, az=np.ravel(az_deg) * u.deg, frame=frame)
        g = c.transform_to(Galactic())
        ls.append(g.l.deg.reshape(np.shape(alt_deg)))
        bs.append(g.b.deg.reshape(np.shape(alt_deg)))
    return np.array(ls), np.array(bs)


def antenna_to_horizon(theta_deg: np.ndarray, phi_deg: np.ndarray, antenna_azimuth_deg: float):
    """Horizon (alt, az) of the antenna-frame grid (theta zenith angle, phi CCW from the
    excitation axis seen from above) for an excitation axis at ``antenna_azimuth_deg``
    (from North through East). Azimuth runs clockwise seen from above, so az = az0 - phi."""
    th, ph = np.meshgrid(theta_deg, phi_deg, indexing="ij")
    return 90.0 - th, (antenna_azimuth_deg - ph) % 360.0


@dataclass(frozen=True)
class HorizonSky:
    """The 408 MHz sky sampled on a beam grid for each LST: ``t408[lst, theta, phi]`` (K)."""

    lsts_deg: np.ndarray
    theta_deg: np.ndarray
    phi_deg: np.ndarray
    t408: np.ndarray
    key: str
    _made: dict = field(default_factory=dict, compare=False, repr=False)  # the float64 matrix, once made

    @property
    def lst_hours(self) -> np.ndarray:
        return self.lsts_deg / 15.0

    def matrix(self) -> np.ndarray:
        """``T408`` as a float64 [LST, pixel] matrix, made once and kept: every beam on this
        grid is then scored by one matrix product with its solid-angle-weighted gain."""
        if "m" not in self._made:
            self._made["m"] = self.t408.reshape(self.t408.shape[0], -1).astype(np.float64)
        return self._made["m"]


_MEMORY: dict[str, HorizonSky] = {}


def horizon_sky(
    theta_deg: np.ndarray,
    phi_deg: np.ndarray,
    *,
    lsts_deg: np.ndarray | None = None,
    site: Site = MRO,
    antenna_azimuth_deg: float,
    sky_path: str | os.PathLike | None = None,
    use_disk_cache: bool = True,
    progress: bool = False,
) -> HorizonSky:
    """The sky in the antenna's horizon frame for every LST, from memory, disk or computed.

    The disk cache is keyed by site, grid, LST set, antenna azimuth and the map's content
    hash, written atomically with a CRC-32 beside it, and is safe to delete; an entry that
    fails its check is recomputed, never used.
    """
    lsts = lst_grid() if lsts_deg is None else np.asarray(lsts_deg, dtype=float)
    theta = np.asarray(theta_deg, dtype=float)
    phi = np.asarray(phi_deg, dtype=float)
    path = Path(sky_path or default_sky_path())
    ident = {
        "v": 1,
        "site": [site.lat_deg, site.lon_deg, site.height_m],
        "theta": hashlib.sha256(theta.tobytes()).hexdigest()[:16],
        "phi": hashlib.sha256(phi.tobytes()).hexdigest()[:16],
        "lst": hashlib.sha256(lsts.tobytes()).hexdigest()[:16],
        "az0": float(antenna_azimuth_deg),
        "map": _file_digest(path),
    }
    key = hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()[:24]
    if key in _MEMORY:
        return _MEMORY[key]
    file = cache_dir() / f"horizon_sky_{key}.npy"
    shape = (lsts.size, theta.size, phi.size)
    t408 = _read_sky_cache(file, shape) if use_disk_cache else None
    if t408 is None:
        t408 = _compute_horizon_sky(path, theta, phi, lsts, site, antenna_azimuth_deg, progress)
        if use_disk_cache:
            _keep(lambda: _write_sky_cache(file, t408))
    hs = HorizonSky(lsts, theta, phi, t408, key)
    if len(_MEMORY) > 8:
        _MEMORY.clear()
    _MEMORY[key] = hs
    return hs


def _galactic_grid(theta: np.ndarray, phi: np.ndarray, lsts: np.ndarray, site: Site, antenna_azimuth_deg: float,
                   progress: bool, what: str):
    """(index, l, b) in deg of every grid direction at each LST (astropy: AltAz -> Galactic at
    the time each LST occurs), with a progress bar: the slow part of a horizon-frame sky."""
    alt, az = antenna_to_horizon(theta, phi, antenna_azimuth_deg)
    times = lst_times(lsts, site)
    bar = None
    if progress:
        from .progress import Progress

        bar = Progress(lsts.size, what, "LST")
    for i in range(lsts.size):
        l, b = horizon_to_galactic(alt, az, [times[i]], site)
        yield i, l[0], b[0]
        if bar:
            bar.update()
    if bar:
        bar.close()


def _compute_horizon_sky(path: Path, theta: np.ndarray, phi: np.ndarray, lsts: np.ndarray, site: Site,
                         antenna_azimuth_deg: float, progress: bool) -> np.ndarray:
    """T408 [LST, theta, phi] by transforming every grid direction to Galactic (astropy)
    and interpolating the map (healpy); minutes for 360 LSTs, hence the disk cache."""
    import healpy as hp

    sky = load_sky_map(path)
    t408 = np.empty((lsts.size, theta.size, phi.size), dtype=np.float32)
    for i, l, b in _galactic_grid(theta, phi, lsts, site, antenna_azimuth_deg, progress,
                                  "sky -> horizon frame (once per grid)"):
        t408[i] = hp.get_interp_val(sky, l, b, lonlat=True)
    return t408


def _keep(write) -> None:
    """Write a cache entry; a cache that cannot be written (full disk, read-only) costs the
    reuse, never the result."""
    from .errors import OutputError
    from .files import warn_once

    try:
        write()
    except (OutputError, UserInputError) as exc:
        warn_once("sky-cache", f"the sky cache cannot be written ({exc}); going on without it")


def _crc(a: np.ndarray) -> int:
    import zlib

    return zlib.crc32(memoryview(np.ascontiguousarray(a)).cast("B"))


def _read_checked(file: Path, load, valid) -> tuple[np.ndarray, ...] | None:
    """The arrays of a cache entry if it is whole: ``load(file)`` reads them, ``valid(*arrays)``
    says they are plausible, and their CRC-32 is the one written beside them. Anything else
    (truncated, overwritten, no checksum) is deleted: an entry whose checksum is missing is
    never adopted, however plausible its values (a sky scaled x2 is plausible and scored
    478.9 mK for 239.5)."""
    check = file.with_suffix(".crc.json")
    if not file.exists():
        return None
    try:
        arrays = load(file)
        ok = bool(valid(*arrays)) and check.exists() and json.loads(check.read_text()).get("crc32") == _crc_of(arrays)
    except (OSError, ValueError, TypeError, KeyError, AttributeError, EOFError):
        ok = False
    if not ok:
        _remove(file)
        _remove(check)
        return None
    return arrays


def _remove(path: Path) -> None:
    """Delete a damaged cache entry, whatever it has become (a file, or a folder in its place)."""
    import shutil

    try:
        path.unlink(missing_ok=True)
    except IsADirectoryError:
        shutil.rmtree(path, ignore_errors=True)
    except OSError:
        pass  # a read-only cache: the entry stays, and is not read


def _write_checked(file: Path, save, arrays: tuple[np.ndarray, ...]) -> None:
    """Write a cache entry (``save(fh)``) and its CRC-32 beside it, each atomically."""
    with atomic_path(file, suffix=file.suffix + ".tmp") as tmp:
        with open(tmp, "wb") as fh:
            save(fh)
    with atomic_path(file.with_suffix(".crc.json"), suffix=".json.tmp") as tmp:
        tmp.write_text(json.dumps({"crc32": _crc_of(arrays), "shape": list(arrays[0].shape)}))


def _crc_of(arrays: tuple[np.ndarray, ...]) -> int:
    out = 0
    for a in arrays:
        out ^= _crc(a)
    return out


def _read_sky_cache(file: Path, shape: tuple[int, ...]) -> np.ndarray | None:
    """A cached horizon sky if whole: right shape, float32, finite, plausible temperatures."""
    got = _read_checked(file, lambda f: (np.load(f, allow_pickle=False),),
                        lambda t: (t.shape == shape and t.dtype == np.float32 and np.all(np.isfinite(t))
                                   and float(t.min()) > 0.0 and float(t.max()) < 1e6))
    return None if got is None else got[0]


def _write_sky_cache(file: Path, t408: np.ndarray) -> None:
    _write_checked(file, lambda fh: np.save(fh, t408), (t408,))


# ------------------------------------------------------------------ other sky models
SKY_MODELS: dict[str, str | None] = {
    "haslam": None,  # the 408 MHz map scaled by (nu / 408)^-beta: the paper's sky
    "gsm2008": "gsm2008_nside0064_galactic_ring_K_40-100MHz.fits",
    "lfsm": "lfsm_nside0064_galactic_ring_K_40-100MHz.fits",
}
MODEL_NODES_MHZ = (40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0, 408.0)  # the tabulated maps (fields 0-7)


@dataclass(frozen=True)
class TabulatedSky:
    """A sky model given as maps at a few frequencies (GSM2008, LFSM; package data). Between
    them each pixel's ln T is a cubic spline in ln nu (not-a-knot) through its tabulated
    values: exact at the tabulated frequencies and smooth (C2) between them, so it adds no
    spectral structure of its own (linear interpolation in ln T - ln nu would: its kinks at
    every 10 MHz leave LinLog residuals of a few 1e-4 of T on GSM2008)."""

    name: str
    nodes_mhz: np.ndarray
    log_maps: np.ndarray  # [node, pix], ln K
    _spline: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def nside(self) -> int:
        import healpy as hp

        return int(hp.npix2nside(self.log_maps.shape[1]))

    def maps_at(self, freqs_mhz) -> np.ndarray:
        """T [f, pix] (K) at each frequency, which must lie within the tabulated range."""
        from scipy.interpolate import CubicSpline

        f = np.atleast_1d(np.asarray(freqs_mhz, dtype=float))
        lo, hi = float(self.nodes_mhz[0]), float(self.nodes_mhz[-1])
        if f.min() < lo - 1e-9 or f.max() > hi + 1e-9:
            raise UserInputError(f"--sky {self.name} is tabulated at {lo:g}-{hi:g} MHz only; the beam has "
                                 f"{f.min():g}-{f.max():g} MHz (use --sky haslam, or --freqs within the range)")
        if "s" not in self._spline:
            self._spline["s"] = CubicSpline(np.log(self.nodes_mhz), self.log_maps, axis=0)
        return np.exp(self._spline["s"](np.log(f)))


@lru_cache(maxsize=4)
def tabulated_sky(name: str) -> TabulatedSky:
    """One of the package's tabulated sky models by name (``SKY_MODELS``)."""
    import healpy as hp

    if SKY_MODELS.get(name) is None:
        raise UserInputError(f"--sky {name}: not a tabulated sky model (choose one of "
                             f"{', '.join(k for k, v in SKY_MODELS.items() if v)})")
    path = Path(str(resources.files("groundplane") / "data" / SKY_MODELS[name]))
    maps = np.array([hp.read_map(str(path), field=i, dtype=np.float64) for i in range(len(MODEL_NODES_MHZ))])
    if not (np.all(np.isfinite(maps)) and maps.min() > 0):
        raise UserInputError(f"{path}: sky model has non-finite or non-positive pixels")
    return TabulatedSky(name, np.array(MODEL_NODES_MHZ), np.log(maps))


@dataclass(frozen=True)
class HorizonWeights:
    """Where each beam-grid direction falls on a HEALPix map at each LST: the 4 pixels
    ``pix[lst, dir, 4]`` and bilinear weights ``weight[lst, dir, 4]`` (healpy's), for any map
    of that nside. A sky that changes with frequency is then sampled per frequency without
    redoing the astropy transform."""

    lsts_deg: np.ndarray
    pix: np.ndarray
    weight: np.ndarray
    key: str

    @property
    def lst_hours(self) -> np.ndarray:
        return self.lsts_deg / 15.0

    def products(self, gw: np.ndarray, maps: np.ndarray) -> np.ndarray:
        """sum over directions of gw[f, dir] T_f(lst, dir) -> [f, lst], with T_f = maps[f]
        resampled at each LST (a sparse [dir, pix] matrix per LST: one product per LST)."""
        import scipy.sparse as sp

        n_dir, n_pix = self.pix.shape[1], maps.shape[1]
        rows = np.repeat(np.arange(n_dir), 4)
        out = np.empty((gw.shape[0], self.pix.shape[0]))
        for i in range(self.pix.shape[0]):
            m = sp.csr_matrix((self.weight[i].ravel().astype(np.float64), (rows, self.pix[i].ravel())),
                              shape=(n_dir, n_pix))
            out[:, i] = np.einsum("fp,fp->f", (m.T @ gw.T).T, maps)
        return out


def horizon_weights(theta_deg: np.ndarray, phi_deg: np.ndarray, *, lsts_deg: np.ndarray, site: Site,
                    antenna_azimuth_deg: float, nside: int, progress: bool = False) -> HorizonWeights:
    """:class:`HorizonWeights` for a beam grid, from memory, disk (checked like the horizon sky)
    or computed (minutes: the astropy transform of every direction at every LST)."""
    import healpy as hp

    theta, phi, lsts = (np.asarray(a, dtype=float) for a in (theta_deg, phi_deg, lsts_deg))
    ident = {"v": 1, "kind": "weights", "site": [site.lat_deg, site.lon_deg, site.height_m], "nside": int(nside),
             "theta": hashlib.sha256(theta.tobytes()).hexdigest()[:16],
             "phi": hashlib.sha256(phi.tobytes()).hexdigest()[:16],
             "lst": hashlib.sha256(lsts.tobytes()).hexdigest()[:16], "az0": float(antenna_azimuth_deg)}
    key = hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()[:24]
    if key in _MEMORY:
        return _MEMORY[key]  # type: ignore[return-value]
    file = cache_dir() / f"horizon_weights_{key}.npz"
    shape = (lsts.size, theta.size * phi.size, 4)
    got = _read_weights_cache(file, shape, 12 * nside ** 2)
    if got is None:
        pix = np.empty(shape, dtype=np.int32)
        weight = np.empty(shape, dtype=np.float32)
        for i, l, b in _galactic_grid(theta, phi, lsts, site, antenna_azimuth_deg, progress,
                                      f"HEALPix nside {nside} -> horizon frame (once per grid)"):
            p, w = hp.get_interp_weights(nside, l.ravel(), b.ravel(), lonlat=True)
            pix[i], weight[i] = p.T, w.T
        _keep(lambda: _write_weights_cache(file, pix, weight))
        got = (pix, weight)
    hw = HorizonWeights(lsts, got[0], got[1], key)
    if len(_MEMORY) > 8:
        _MEMORY.clear()
    _MEMORY[key] = hw  # type: ignore[assignment]
    return hw


def _load_weights(file: Path) -> tuple[np.ndarray, np.ndarray]:
    with np.load(file, allow_pickle=False) as z:
        return z["pix"], z["weight"]


def _read_weights_cache(file: Path, shape: tuple[int, ...], npix: int) -> tuple[np.ndarray, ...] | None:
    """Cached weights if whole: shapes, pixels in range, weights summing to 1 (and the CRC)."""
    return _read_checked(file, _load_weights,
                         lambda pix, w: (pix.shape == shape and w.shape == shape and pix.min() >= 0 and pix.max() < npix
                                         and np.allclose(w.sum(axis=-1), 1.0, atol=1e-5)))


def _write_weights_cache(file: Path, pix: np.ndarray, weight: np.ndarray) -> None:
    _write_checked(file, lambda fh: np.savez(fh, pix=pix, weight=weight), (pix, weight))
