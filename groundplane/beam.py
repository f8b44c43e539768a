"""The one far-field beam object every solver and loader returns, and its native file.

Conventions (written down once, as pyuvdata's UVBeam does):

* ``gain`` is *linear* power gain ``[freq, theta, phi]`` (gain = directivity for a
  lossless PEC model), absolute (not peak-normalised).
* ``theta_deg`` is the zenith angle (0 = zenith, 90 = horizon); only the upper
  hemisphere is used for scoring.
* ``phi_deg`` is the azimuth in the antenna frame, counter-clockwise seen from above,
  with phi = 0 along the antenna's excitation axis (the E-plane) and phi = 90 the
  H-plane. The grid is periodic: it must not repeat 360 = 0.

Native file: ``.npz`` with arrays ``freqs_mhz``, ``theta_deg``, ``phi_deg``, ``gain``
and a JSON string ``meta``. It is read with ``allow_pickle=False``.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from .beam_meta import GAIN_NORMALISATIONS, check_meta, per_frequency_keys
from .errors import BeamFormatError, GroundLossUndefined, UserInputError
from .files import atomic_path

__all__ = ["Beam", "BeamFormatError", "GAIN_NORMALISATIONS", "GroundLossUndefined", "READER_GROUP"]

READER_GROUP = "groundplane.beam_readers"
FORMATS_GROUP = "groundplane.beam_formats"  # a function listing the formats the reader reads
WRITER_GROUP = "groundplane.beam_writers"  # one writer per output suffix (name = the suffix without its dot)
"""Entry-point group of beam-file readers: ``name = "module:function"`` where
``function(paths, format) -> Beam``. The distribution registers ``solvers.io:load_beam``
(every vendor format); the core itself reads only the native ``.npz``."""


@dataclass(frozen=True, eq=False)
class Beam:
    """Linear power gain ``gain[f, theta, phi]`` on a regular angular grid, plus metadata.

    >>> beam = Beam.from_file("examples/lowband_square10_nec.npz")
    >>> beam.gain.shape == (beam.freqs_mhz.size, beam.theta_deg.size, beam.phi_deg.size)
    True

    ``beam.fom(**settings)`` is :func:`groundplane.fom` of the beam: the Figure of Merit lives
    above the beam, so ``groundplane.api`` attaches it (as pandas attaches accessors) rather
    than this module importing upward.
    """

    freqs_mhz: np.ndarray
    theta_deg: np.ndarray
    phi_deg: np.ndarray
    gain: np.ndarray
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        src = self.meta.get("source", "beam") if isinstance(self.meta, dict) else "beam"
        for name, arr in (("freqs_mhz", self.freqs_mhz), ("theta_deg", self.theta_deg), ("phi_deg", self.phi_deg),
                          ("gain", self.gain)):
            if np.iscomplexobj(arr):  # a cast would drop the imaginary part in silence
                raise BeamFormatError(f"{src}: {name} is complex; a beam holds real power gain and angles")
        f = np.asarray(self.freqs_mhz, dtype=float).ravel()
        t = np.asarray(self.theta_deg, dtype=float).ravel()
        p = np.asarray(self.phi_deg, dtype=float).ravel()
        g = np.asarray(self.gain, dtype=float)
        object.__setattr__(self, "freqs_mhz", f)
        object.__setattr__(self, "theta_deg", t)
        object.__setattr__(self, "phi_deg", p)
        object.__setattr__(self, "gain", g)
        object.__setattr__(self, "meta", dict(self.meta))
        if g.shape != (f.size, t.size, p.size):
            raise BeamFormatError(
                f"{src}: gain has shape {g.shape}, expected (n_freq, n_theta, n_phi) = "
                f"({f.size}, {t.size}, {p.size})"
            )
        for name, arr in (("freqs_mhz", f), ("theta_deg", t), ("phi_deg", p)):
            if arr.size == 0:
                raise BeamFormatError(f"{src}: {name} is empty")
            if not np.all(np.isfinite(arr)):
                raise BeamFormatError(f"{src}: {name} has non-finite values")
            if arr.size > 1 and not np.all(np.diff(arr) > 0):
                raise BeamFormatError(f"{src}: {name} must be strictly increasing")
        if np.any(f <= 0):
            raise BeamFormatError(f"{src}: frequencies must be positive (MHz)")
        if t[0] < 0 or t[-1] > 180:
            raise BeamFormatError(f"{src}: theta_deg must lie within 0..180, got {t[0]}..{t[-1]}")
        if p[0] < 0 or p[-1] >= 360:
            raise BeamFormatError(
                f"{src}: phi_deg must lie within [0, 360) (do not repeat 360 = 0), got {p[0]}..{p[-1]}"
            )
        if not np.all(np.isfinite(g)):
            bad = np.argwhere(~np.isfinite(g))[0]
            raise BeamFormatError(
                f"{src}: gain is not finite at freq {f[bad[0]]} MHz, theta {t[bad[1]]}, phi {p[bad[2]]}"
            )
        if np.any(g < 0):
            raise BeamFormatError(f"{src}: linear power gain must be >= 0")
        check_meta(self.meta, f.size, src)  # each declared key as groundplane.beam_meta declares it

    # ------------------------------------------------------------------ views
    @property
    def shape(self) -> tuple[int, int, int]:
        return self.gain.shape  # type: ignore[return-value]

    def upper_hemisphere(self) -> "Beam":
        """The beam restricted to theta <= 90 deg (what the sky integral uses)."""
        keep = self.theta_deg <= 90.0 + 1e-9
        return Beam(self.freqs_mhz, self.theta_deg[keep], self.phi_deg, self.gain[:, keep, :], self.meta)

    def solid_angle_weights(self) -> np.ndarray:
        """dOmega (sr) of each (theta, phi) sample of the upper hemisphere: cell areas.

        Cells span half-way to the neighbouring samples (clipped to 0..90 deg in theta and
        periodic in phi), so the weights add to exactly 2 pi over a full upper-hemisphere grid.
        """
        t = np.radians(self.theta_deg)
        edges = np.concatenate([[t[0]], 0.5 * (t[1:] + t[:-1]), [t[-1]]])
        edges = np.clip(edges, 0.0, np.pi / 2)
        if self.theta_deg[0] <= 1e-9:
            edges[0] = 0.0
        band = np.cos(edges[:-1]) - np.cos(edges[1:])
        p = np.radians(self.phi_deg)
        if p.size == 1:
            dphi = np.array([2 * np.pi])
        else:
            nxt = np.concatenate([p[1:], [p[0] + 2 * np.pi]])
            prv = np.concatenate([[p[-1] - 2 * np.pi], p[:-1]])
            dphi = 0.5 * (nxt - prv)
        return np.clip(band, 0.0, None)[:, None] * dphi[None, :]

    @property
    def gain_normalisation(self) -> str:
        """What the gain is normalised to (a key of :data:`GAIN_NORMALISATIONS`): the meta's
        ``gain_normalisation``, else our engines' (input power), else read from the exported
        quantity's name ('Gain', 'Realized Gain', 'Directivity'), else ``unknown``."""
        said = self.meta.get("gain_normalisation")
        if said in GAIN_NORMALISATIONS:
            return said
        if self.meta.get("solver") in ("surface", "nec"):  # beams cached before the key was written
            return "input_power"
        quantity = str(self.meta.get("quantity", "")).lower()
        if "realized" in quantity or "realised" in quantity:
            return "available_power"
        if "dir" in quantity:
            return "radiated_power"
        return "input_power" if "gain" in quantity else "unknown"

    def ground_loss(self) -> np.ndarray:
        """Ground loss per frequency: L = 1 - (1/4 pi) int over the upper hemisphere of G dOmega
        (SPEC section 2), the power the soil absorbs as a fraction of what the antenna takes
        in. Quadrature: :meth:`solid_angle_weights`' cell areas (exact in theta, the midpoint
        rule in phi). Refused (:class:`GroundLossUndefined`) for a gain not normalised to input
        power, and for a beam that does not cover the upper hemisphere."""
        norm = self.gain_normalisation
        src = self.meta.get("source", "beam")
        if norm != "input_power":
            what = {"available_power": "the available power (Realized Gain)", "radiated_power": "the radiated power "
                    "(directivity)", "unknown": "a power the file does not state"}[norm]
            raise GroundLossUndefined(f"{src}: its gain is normalised to {what}, not to the antenna's input power, so "
                                      "1 - its upper-hemisphere integral is no ground loss (export the solver's "
                                      "'Gain', normalised to input power, for one)")
        hemi = self.upper_hemisphere()
        if hemi.theta_deg.size < 2 or hemi.theta_deg[0] > 1e-6 or hemi.theta_deg[-1] < 90 - 1e-6:
            raise GroundLossUndefined(f"{src}: the beam must cover theta 0..90 deg for its ground loss")
        gaps = np.diff(np.concatenate([hemi.phi_deg, [hemi.phi_deg[0] + 360.0]]))
        if hemi.phi_deg.size < 4 or gaps.max() > 1.5 * np.median(gaps):
            raise GroundLossUndefined(f"{src}: the beam must cover the full circle of azimuth for its ground loss "
                                      "(FEKO quadrant files: `groundplane convert` them into one beam first)")
        try:
            return 1.0 - self.checked_share()
        except BeamFormatError as exc:  # no loss to report, though the beam may still be scored normalised
            raise GroundLossUndefined(str(exc)) from None

    #: the widest upper-hemisphere share a gain normalised to any power can have: 1 for a lossless
    #: model over PEC; the margin is quadrature and an engine's own balance, not physics
    MAX_SHARE: ClassVar[float] = 1.25
    #: the narrowest: a ground that absorbs 99 % of what the antenna takes in is not a ground plane's
    MIN_SHARE: ClassVar[float] = 0.01

    def checked_share(self) -> np.ndarray:
        """:meth:`upper_hemisphere_share`, refused (:class:`BeamFormatError`) where it says the gain
        is on no power's scale (above :attr:`MAX_SHARE` or below :attr:`MIN_SHARE`): a beam x1e5
        scored 19 067 271 mK and a -8 184 008 % ground loss; x1e-300 scored 0.00 mK."""
        share = self.upper_hemisphere_share()
        bad = np.flatnonzero((share > self.MAX_SHARE) | (share < self.MIN_SHARE))
        if bad.size:
            i = int(bad[0])
            raise BeamFormatError(
                f"{self.meta.get('source', 'beam')}: the gain's integral over the upper hemisphere is {share[i]:.3g} x 4 pi "
                f"at {self.freqs_mhz[i]:g} MHz ({bad.size} of {share.size} frequencies outside {self.MIN_SHARE:g}-"
                f"{self.MAX_SHARE:g}): a linear power gain normalised to any power gives 1 over PEC and 1/2 in free "
                "space; is it in dB, or scaled?")
        return share

    def upper_hemisphere_share(self) -> np.ndarray:
        """(1/4 pi) int over theta <= 90 deg of G dOmega per frequency, by the cell areas of
        :meth:`solid_angle_weights`: 1 for a lossless model over PEC, 1/2 for an isotropic beam."""
        hemi = self.upper_hemisphere()
        return np.einsum("ftp,tp->f", hemi.gain, hemi.solid_angle_weights()) / (4 * np.pi)

    def cut(self, phi_deg: float) -> np.ndarray:
        """Gain [freq, theta] in the vertical plane at azimuth ``phi_deg`` (nearest sample)."""
        d = np.abs((self.phi_deg - phi_deg + 180) % 360 - 180)
        return self.gain[:, :, int(np.argmin(d))]

    def gain_at(self, theta_deg: float, phi_deg: float) -> np.ndarray:
        """Gain vs frequency at the nearest grid direction."""
        it = int(np.argmin(np.abs(self.theta_deg - theta_deg)))
        return self.cut(phi_deg)[:, it]

    def beam_width_3db(self, freq_mhz: float, phi_deg: float) -> float:
        """Full 3 dB beam width (deg) in the plane ``phi_deg`` at one frequency.

        Linear interpolation of the gain in dB along both halves of the plane (phi and
        phi + 180), measured from the peak at or near zenith.
        """
        f = int(np.argmin(np.abs(self.freqs_mhz - freq_mhz)))
        hemi = self.theta_deg <= 90 + 1e-9
        th = self.theta_deg[hemi]
        widths = []
        for ph in (phi_deg, phi_deg + 180.0):
            d = np.abs((self.phi_deg - ph + 180) % 360 - 180)
            g = self.gain[f, hemi, int(np.argmin(d))]
            widths.append(_half_power_angle(th, g))
        peak_ok = all(np.isfinite(widths))
        return float(sum(widths)) if peak_ok else float("nan")

    def rotated(self, phi_offset_deg: float) -> "Beam":
        """The same beam with its azimuth origin moved: new phi = old phi - ``phi_offset_deg``.

        Used to put phi = 0 on the excitation axis when a solver model was built with the
        dipole along another axis. The offset must be a whole number of grid steps.
        """
        step = np.diff(self.phi_deg)
        if self.phi_deg.size < 2 or not np.allclose(step, step[0]) or not np.isclose(
            self.phi_deg.size * step[0], 360.0
        ):
            raise UserInputError("rotation needs a uniform full-circle phi grid")
        shift = phi_offset_deg / step[0]
        if not np.isclose(shift, round(shift)):
            raise UserInputError(f"phi offset {phi_offset_deg} deg is not a multiple of the {step[0]} deg grid")
        gain = np.roll(self.gain, -int(round(shift)), axis=2)
        total = float(self.meta.get("phi_rotation_deg", 0.0)) + phi_offset_deg
        return Beam(self.freqs_mhz, self.theta_deg, self.phi_deg, gain, {**self.meta, "phi_rotation_deg": total})

    def frequency_smoothed(self, degree: int) -> "Beam":
        """The beam with each direction's G(nu) replaced by its least-squares Chebyshev fit
        of ``degree`` over the band: a diagnostic that separates narrow-band structure
        (solver artefacts such as wire-grid cavity resonances) from broadband chromaticity."""
        n = self.freqs_mhz.size
        if not (isinstance(degree, int) and 1 <= degree < n - 1):
            raise UserInputError(f"smoothing degree must be an integer in 1..{n - 2} for {n} frequencies, got {degree!r}")
        lo, hi = self.freqs_mhz.min(), self.freqs_mhz.max()
        x = (2 * self.freqs_mhz - lo - hi) / (hi - lo)
        flat = self.gain.reshape(n, -1)
        fit = np.polynomial.chebyshev.chebval(x, np.polynomial.chebyshev.chebfit(x, flat, degree)).T
        gain = np.clip(fit, 0.0, None).reshape(self.gain.shape)
        return Beam(self.freqs_mhz, self.theta_deg, self.phi_deg, gain, {**self.meta, "frequency_smoothed_degree": degree})

    def at_frequencies(self, index: np.ndarray) -> "Beam":
        """The beam at the frequencies ``index`` picks (increasing), with every per-frequency
        metadata value (impedance, timings, ...) picked alike."""
        index = np.asarray(index, dtype=int)
        meta = {k: ([self.meta[k][i] for i in index] if k in per_frequency_keys(self.meta) else v)
                for k, v in self.meta.items()}
        return Beam(self.freqs_mhz[index], self.theta_deg, self.phi_deg, self.gain[index], meta)

    def with_meta(self, **extra: Any) -> "Beam":
        return Beam(self.freqs_mhz, self.theta_deg, self.phi_deg, self.gain, {**self.meta, **extra})

    # ------------------------------------------------------------------- file
    def save(self, path: str | os.PathLike) -> Path:
        """Write the native ``.npz`` file atomically (temp file + rename)."""
        path = Path(path)
        with atomic_path(path, suffix=".tmp.npz") as tmp:
            np.savez_compressed(
                tmp,
                freqs_mhz=self.freqs_mhz,
                theta_deg=self.theta_deg,
                phi_deg=self.phi_deg,
                gain=self.gain,
                meta=np.array(json.dumps(self.meta, sort_keys=True, default=_json_default)),
            )
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Beam":
        """Read a native ``.npz`` beam (never unpickles).

        Raises
        ------
        BeamFormatError
            Not a readable native beam; the message names the file.
        """
        path = Path(path)
        if path.is_dir():
            raise BeamFormatError(f"{path}: is a directory, not a beam file")
        if path.exists() and not path.is_file():
            raise BeamFormatError(f"{path}: not a regular file (a device or a pipe); a beam is a file on disk")
        try:
            _check_npz_sizes(path)
            with np.load(path, allow_pickle=False) as z:
                missing = {"freqs_mhz", "theta_deg", "phi_deg", "gain"} - set(z.files)
                if missing:
                    raise BeamFormatError(f"{path}: missing arrays {sorted(missing)} in native beam file")
                meta = json.loads(str(z["meta"])) if "meta" in z.files else {}
                if not isinstance(meta, dict):
                    raise BeamFormatError(f"{path}: 'meta' must be a JSON object, got {type(meta).__name__}")
                arrays = {k: np.array(z[k]) for k in ("freqs_mhz", "theta_deg", "phi_deg", "gain")}
        except BeamFormatError:
            raise
        except FileNotFoundError:
            raise BeamFormatError(f"{path}: no such beam file") from None
        except Exception as exc:  # zipfile/zlib/numpy raise many kinds on a damaged file
            raise BeamFormatError(f"{path}: not a readable groundplane .npz beam ({type(exc).__name__}: {exc})") from exc
        meta.setdefault("source", str(path))
        try:
            return cls(meta=meta, **arrays)
        except BeamFormatError as exc:
            raise BeamFormatError(f"{path}: {exc}") from None

    def write(self, path: str | os.PathLike) -> Path:
        """Write the format the suffix names: a registered writer's (``.fits`` / ``.beamfits``:
        a pyuvdata UVBeam, from the solver layer's ``groundplane.beam_writers``) or else the
        native ``.npz`` (:meth:`save`)."""
        from importlib.metadata import entry_points

        suffix = Path(path).suffix.lower().lstrip(".")
        for ep in entry_points(group=WRITER_GROUP):
            if suffix and ep.name == suffix:
                return ep.load()(self, path)
        return self.save(path)

    @classmethod
    def from_file(cls, paths: str | os.PathLike | list, format: str = "auto") -> "Beam":
        """A beam from any supported file: a solver export (FEKO, CST, HFSS, ...) or the
        native ``.npz``; several files may make one beam (FEKO azimuth quadrants).

        Readers are found through the ``groundplane.beam_readers`` entry points, so the
        core needs no solver code; without any, only the native format is read.
        """
        reader = _reader()
        if reader is None:
            single = [paths] if isinstance(paths, (str, os.PathLike)) else list(paths)
            if format not in ("auto", "npz") or len(single) != 1:
                raise UserInputError(f"no reader for beam format '{format}' is installed")
            return cls.load(single[0])
        return reader(paths, format)


def reader_formats() -> list[str]:
    """'auto' and every format the installed readers read (the ``--format`` choices); with no
    reader installed, the native 'npz' alone."""
    from importlib.metadata import entry_points

    for ep in sorted(entry_points(group=FORMATS_GROUP), key=lambda e: e.name):
        return list(ep.load()())
    return ["auto", "npz"]


def _reader():
    from importlib.metadata import entry_points

    for ep in sorted(entry_points(group=READER_GROUP), key=lambda e: e.name):
        return ep.load()
    return None


def _half_power_angle(theta: np.ndarray, gain: np.ndarray) -> float:
    """Zenith angle at which ``gain`` first falls 3 dB below its value at zenith."""
    with np.errstate(divide="ignore"):
        db = 10 * np.log10(np.maximum(gain, 1e-30))
    ref = db[0]
    below = np.flatnonzero(db <= ref - 3.0103)
    if below.size == 0:
        return float("nan")
    i = below[0]
    if i == 0:
        return 0.0
    # linear interpolation between samples i-1 and i
    x0, x1, y0, y1 = theta[i - 1], theta[i], db[i - 1], db[i]
    return float(x0 + (ref - 3.0103 - y0) * (x1 - x0) / (y1 - y0))


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


MAX_AXIS_LENGTH = 1_000_000  # frequencies, angles: far beyond any real beam (1 deg grids are 360)
# a decompression bomb: a member this large that expands this many times (real gain arrays compress
# 1-3x; the native beams are stored uncompressed)
BOMB_MIN_BYTES, BOMB_RATIO = 64 * 2**20, 50
MAX_META_BYTES = 16 * 2**20


def _check_npz_sizes(path: Path) -> None:
    """Read each array's header and refuse one that declares more data than the file
    holds (a damaged or hostile file would otherwise make numpy allocate gigabytes first)."""
    import zipfile

    from numpy.lib import format as npy

    with zipfile.ZipFile(path) as zf:
        for info in zf.infolist():
            name = info.filename[:-4] if info.filename.endswith(".npy") else info.filename
            if name == "meta" and info.file_size > MAX_META_BYTES:  # before reading 256 MiB of JSON
                raise BeamFormatError(f"{path}: its 'meta' member is {info.file_size:,} bytes; a beam's metadata is "
                                      f"a few kB (at most {MAX_META_BYTES:,})")
            if info.file_size > BOMB_MIN_BYTES and info.file_size > BOMB_RATIO * max(1, info.compress_size):
                what = f"array '{name}'" if info.filename.endswith(".npy") else f"member '{info.filename}'"
                raise BeamFormatError(
                    f"{path}: {what} decompresses to {info.file_size:,} bytes from "
                    f"{info.compress_size:,} ({info.file_size / max(1, info.compress_size):,.0f}x); a beam's gains "
                    f"compress a few times at most, so this is refused unread")
            if not info.filename.endswith(".npy"):
                if name in ("freqs_mhz", "theta_deg", "phi_deg", "gain"):  # np.load would not find it under this name
                    raise BeamFormatError(f"{path}: member '{info.filename}' is not a .npy array; not a beam file")
                continue
            with zf.open(info) as fh:
                version = npy.read_magic(fh)
                read = npy.read_array_header_1_0 if version == (1, 0) else npy.read_array_header_2_0
                shape, _, dtype = read(fh)
            if dtype.hasobject:
                raise BeamFormatError(f"{path}: array '{info.filename[:-4]}' holds Python objects; refused (never unpickled)")
            nbytes = int(np.prod(shape, dtype=np.float64)) * dtype.itemsize
            if any(d > MAX_AXIS_LENGTH for d in shape):  # also when another axis is 0 (numpy refuses those itself)
                raise BeamFormatError(f"{path}: array '{info.filename[:-4]}' declares shape {tuple(shape)}: an axis "
                                      f"longer than {MAX_AXIS_LENGTH:,}, which no beam has")
            if info.file_size > BOMB_MIN_BYTES and info.file_size > BOMB_RATIO * max(1, info.compress_size):
                raise BeamFormatError(
                    f"{path}: array '{info.filename[:-4]}' decompresses to {info.file_size:,} bytes from "
                    f"{info.compress_size:,} ({info.file_size / max(1, info.compress_size):,.0f}x); a beam's gains "
                    f"compress a few times at most, so this is refused unread")
            if nbytes > info.file_size:
                raise BeamFormatError(
                    f"{path}: array '{info.filename[:-4]}' declares shape {tuple(shape)} ({nbytes:,} bytes) but the "
                    f"file holds {info.file_size:,} bytes for it; damaged or not a beam")
