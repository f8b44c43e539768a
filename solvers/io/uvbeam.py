"""pyuvdata's UVBeam (beamfits): the field's common beam format, read by pyuvsim, hera_sim,
croissant and others. pyuvdata does the FITS; this module only maps conventions.

Conventions (what a reader of our UVBeam files needs to know):

* A power beam, polarization ``xx``: the linear power gain of the blade's one feed, absolute
  (``data_normalization = "physical"``, as our ``Beam.gain``: gain = directivity for a
  lossless model), on an az/za grid (radians), frequencies in Hz.
* UVBeam's azimuth runs from East through North (counter-clockwise seen from above); ours
  runs counter-clockwise from the excitation axis. We write az = phi: the excitation axis is
  the UVBeam x axis (East, feed angle pi/2 as pyuvdata's x feed). The deployed antenna's
  orientation on the sky (EDGES: the axis 7 deg west of North, FomSettings.antenna_azimuth)
  is the simulator's to apply, as it is ours.
* The toolkit's provenance (the beam's ``meta``) is appended to the UVBeam ``history`` as
  base64 of its JSON between ``[groundplane-meta]`` tags (FITS cuts history into 72-character
  cards; base64 and the tags have no spaces to lose there), and read back, so npz -> UVBeam ->
  npz keeps it.
"""
from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np

from groundplane.beam import Beam
from groundplane.errors import BeamFormatError, UserInputError
from groundplane.files import atomic_path

from . import BeamFormat, register_format

META_TAG, META_END = "[groundplane-meta]", "[/groundplane-meta]"  # no spaces: FITS may cut a card anywhere


def _encode(meta: dict) -> str:
    return base64.b64encode(json.dumps(meta, sort_keys=True, default=str).encode()).decode()


def _decode(blob: str, path: Path) -> dict:
    """The meta written by :func:`_encode`."""
    try:
        meta = json.loads(base64.b64decode(blob, validate=True))
    except (ValueError, TypeError) as exc:
        raise BeamFormatError(f"{path}: damaged groundplane provenance in the UVBeam history ({exc})") from None
    return meta if isinstance(meta, dict) else {}


def _sniff(head: bytes) -> bool:
    """A FITS file whose primary header says it is a UVBeam beamfits (pyuvdata writes BTYPE)."""
    return head.startswith(b"SIMPLE  =") and b"BTYPE" in head


def write_uvbeam(beam: Beam, path: str | Path) -> Path:
    """The beam as a UVBeam beamfits file (atomically)."""
    from pyuvdata import UVBeam

    path = Path(path)
    for name, axis, unit in (("frequencies", beam.freqs_mhz, "MHz"), ("theta (zenith angle)", beam.theta_deg, "deg"),
                             ("phi (azimuth)", beam.phi_deg, "deg")):
        steps = np.diff(axis)
        if steps.size and not np.allclose(steps, steps[0], rtol=1e-6, atol=1e-9):
            shown = ", ".join(f"{v:g}" for v in axis[:6]) + (" ..." if axis.size > 6 else "")
            raise UserInputError(f"{path}: a UVBeam beamfits file holds evenly spaced {name}, and this beam's are "
                                 f"not ({shown} {unit}); write the native .npz instead, or solve it on an even grid "
                                 "(e.g. --freqs LO:HI:STEP)")
    meta = {k: v for k, v in beam.meta.items() if k != "source"}
    uvb = UVBeam.new(
        telescope_name=_ascii(beam.meta.get("telescope", "groundplane")),
        data_normalization="physical",
        freq_array=beam.freqs_mhz * 1e6,
        feed_name="EDGES-style blade dipole", feed_version=_ascii(beam.meta.get("engine", "groundplane")),
        model_name=_ascii(beam.meta.get("source", "groundplane beam")), model_version=_ascii(beam.meta.get("cache_key", "1")),
        polarization_array=["xx"], x_orientation="east",
        axis1_array=np.radians(beam.phi_deg), axis2_array=np.radians(beam.theta_deg),
        data_array=beam.gain[None, None],  # [vec 1, pol 1, f, za, az]: our [f, theta, phi]
        history="groundplane: gain[f, theta, phi] written as a UVBeam power beam (az = phi: the excitation axis "
                "is the x axis, East).\n" + META_TAG + _encode(meta) + META_END + "\n",
    )
    uvb.check()
    with atomic_path(path, suffix=".tmp.fits") as tmp:
        uvb.write_beamfits(str(tmp), clobber=True)
    return path


def _ascii(value) -> str:
    """A FITS header value: printable ASCII only (a file name in another script is written with
    escapes rather than refused by the FITS writer)."""
    text = str(value).encode("ascii", "backslashreplace").decode("ascii")
    return "".join(c if c.isprintable() else "?" for c in text)[:200]


def read_uvbeam(paths: list[Path]) -> Beam:
    """A UVBeam power beam on an az/za grid (beamfits) as a Beam: the first polarization's
    power (xx for our files; the pseudo-Stokes or feed power of others'), az -> phi."""
    from pyuvdata import UVBeam

    path = paths[0]
    uvb = UVBeam()
    try:
        uvb.read(str(path))
    except Exception as exc:  # pyuvdata raises many kinds on a damaged or foreign file
        raise BeamFormatError(f"{path}: not a readable UVBeam file ({type(exc).__name__}: {exc})") from exc
    if uvb.pixel_coordinate_system != "az_za":
        raise BeamFormatError(f"{path}: a UVBeam on a {uvb.pixel_coordinate_system} grid; only az_za beams are read")
    if uvb.beam_type == "efield":
        uvb.efield_to_power(calc_cross_pols=False)
    data = np.asarray(uvb.data_array)
    gain = np.real(data[0, 0]).astype(float)  # [f, za, az]
    meta: dict = {"source": str(path), "uvbeam_polarization": int(uvb.polarization_array[0])}
    compact = "".join((uvb.history or "").split())  # the whitespace FITS added at its card breaks removed
    if META_TAG in compact and META_END in compact:
        meta = {**_decode(compact.split(META_TAG, 1)[1].split(META_END, 1)[0], path), **meta}
    # radians -> deg leaves 1e-14 deg of rounding: back to the grid as written (1e-9 deg)
    theta, phi = (np.round(np.degrees(a), 9) for a in (uvb.axis2_array, uvb.axis1_array))
    return Beam(np.asarray(uvb.freq_array).ravel() / 1e6, theta, phi, gain, meta)


register_format(BeamFormat("uvbeam", sniff=_sniff, read=read_uvbeam,
                           description="pyuvdata UVBeam beamfits (power beam, az/za grid)"))
