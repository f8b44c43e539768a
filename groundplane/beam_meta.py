"""A beam's metadata, each key declared once (pyuvdata's ``UVParameter`` style): what it means,
its type, whether it has one value per frequency, and its acceptable values; one generic
:func:`check_meta` that every :class:`~groundplane.beam.Beam` runs. Keys not declared here may
ride along (an engine's own diagnostics, like UVBeam's ``extra_keywords``) but no other layer
reads them: ``tests/groundplane/test_beam_meta.py`` finds every key the code reads and
requires it declared here."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .errors import BeamFormatError

__all__ = ["BEAM_META", "MetaParameter", "check_meta", "per_frequency_keys"]

GAIN_NORMALISATIONS: dict[str, str] = {
    "input_power": "4 pi U / P_in, the power the antenna takes in (a solver's 'Gain'; our engines' gain)",
    "available_power": "4 pi U / P_available ('Realized Gain': the feed's mismatch counts as a loss too)",
    "radiated_power": "4 pi U / P_rad (directivity: lossless by definition)",
    "unknown": "the file does not say",
}
"""What ``Beam.gain`` is normalised to (``meta["gain_normalisation"]``). Only ``input_power``
makes 1 - the upper hemisphere's share of the power a ground loss."""

_NUMBER = (int, float)


@dataclass(frozen=True)
class MetaParameter:
    """One metadata key: its meaning, its type(s), one value per frequency or one in all, and
    the values it may take (None: any of its type)."""

    description: str
    kind: tuple[type, ...]
    per_frequency: bool = False
    acceptable: tuple[Any, ...] | None = None


def _p(description: str, *kind: type, per_frequency: bool = False, acceptable: tuple | None = None) -> MetaParameter:
    return MetaParameter(description, kind, per_frequency, acceptable)


BEAM_META: dict[str, MetaParameter] = {
    # where the beam came from
    "source": _p("where the beam came from: a file, or an engine's solve of a design", str),
    "format": _p("the file format it was read from (feko-ffe, edges-table, cst, hfss, uvbeam, npz, ...)", str),
    "solver": _p("the program that computed it (surface, nec, FEKO, CST, HFSS, ...)", str),
    "quantity": _p("the export's gain column as the file names it (Gain, Realized Gain, Directivity, ...)", str),
    "telescope": _p("the telescope a UVBeam file names", str),
    "note": _p("a free-text note (how it was converted)", str),
    "gain_normalisation": _p("what the gain is normalised to", str, acceptable=tuple(GAIN_NORMALISATIONS)),
    # what an engine solved, and how
    "engine": _p("the engine's identity (name, version, what it links): part of the cache key", dict),
    "design": _p("the design solved (plane, ground, antenna) as its canonical JSON object", dict),
    "mesh": _p("the engine's model settings (mesh, plate, feed, method)", dict),
    "cache_key": _p("the content key the beam is cached under", str),
    "gain_sha256": _p("checksum of the gain array, checked when the cache reads the beam back", str),
    "n_segments": _p("NEC-2 wire segments of the model", int),
    "n_unknowns": _p("surface-engine unknowns (RWG basis functions) of the model", int),
    "n_triangles": _p("surface-engine triangles of the model", int),
    "n_cells": _p("FDTD (Yee) cells of the model's grid", int),
    "time_steps": _p("FDTD time steps of the run", int),
    "fdtd_metal_area_m2": _p("the plane's metal as staircased on the FDTD grid (m^2; the outline's is the design's)",
                             *_NUMBER),
    "rotational_symmetry_sections": _p("NEC-2 GR sections (2: half the model and a half turn)", int),
    "mirror_symmetric_solve": _p("one azimuth quadrant solved and mirrored", bool),
    "seconds_per_frequency": _p("solver time at each frequency (s, in its worker)", *_NUMBER, per_frequency=True),
    "input_impedance_re": _p("the antenna's input resistance at each frequency (ohm)", *_NUMBER, per_frequency=True),
    "input_impedance_im": _p("the antenna's input reactance at each frequency (ohm)", *_NUMBER, per_frequency=True),
    "energy_balance": _p("radiated + ground-absorbed over input power (surface engine; 1 when exact)", *_NUMBER,
                         per_frequency=True),
    "gmres_iterations": _p("GMRES iterations of the fast solve", *_NUMBER, per_frequency=True),
    "gmres_residual": _p("GMRES relative residual of the fast solve", *_NUMBER, per_frequency=True),
    "gain_calibration_kappa": _p("NEC-2's gain calibration factor (blade over PEC radiates its input power)", *_NUMBER,
                                 per_frequency=True),
    "interpolated": _p("the frequency was not solved but filled from the solved ones (an engine's solve_every)", bool,
                       per_frequency=True),
    "mesh_note": _p("why the engine's mesh is coarser than it recommends for the beam's top frequency (reports "
                    "show it)", str),
    "frequency_fill": _p("how the unsolved frequencies were filled: solve_every, method, solved (count) and "
                         "leave_out_db (the fill's error estimated from the solved frequencies alone)", dict),
    # what was done to it
    "excitation_axis_deg": _p("azimuth of the excitation axis found in the file (deg)", *_NUMBER),
    "phi_rotation_deg": _p("azimuth the beam was turned by so phi = 0 is the excitation axis (deg)", *_NUMBER),
    "frequency_smoothed_degree": _p("degree of the Chebyshev fit of G(nu) that replaced the gain (a diagnostic)", int),
    "achromatic_at_mhz": _p("the frequency whose gain an achromatic stand-in copies to every frequency (MHz)",
                            *_NUMBER),
}


def per_frequency_keys(meta: dict[str, Any]) -> list[str]:
    """The keys of ``meta`` declared to hold one value per frequency."""
    return [k for k in meta if k in BEAM_META and BEAM_META[k].per_frequency]


def _is(value: Any, kind: tuple[type, ...]) -> bool:
    if bool in kind:
        return isinstance(value, bool)
    if isinstance(value, bool):  # True is an int to Python, not a number here
        return False
    return isinstance(value, kind)


def check_meta(meta: dict[str, Any], n_freqs: int, where: str) -> None:
    """Refuse a declared key whose value is not what the declaration says: the wrong type, a
    per-frequency list of another length or holding a non-number (NaN is a number: an engine
    that could not find a value says so), an unacceptable value."""
    for key, value in meta.items():
        p = BEAM_META.get(key)
        if p is None:
            continue
        if p.per_frequency:
            if not isinstance(value, list) or len(value) != n_freqs:
                got = f"{len(value)} values" if isinstance(value, list) else type(value).__name__
                raise BeamFormatError(f"{where}: meta '{key}' ({p.description}) must hold one value per frequency "
                                      f"({n_freqs}), got {got}")
            bad = next((v for v in value if not (v is None or _is(v, p.kind))), "ok")
            if bad != "ok":
                raise BeamFormatError(f"{where}: meta '{key}' holds {bad!r}, not a number")
            continue
        if not _is(value, p.kind):
            want = " or ".join(k.__name__ for k in p.kind)
            raise BeamFormatError(f"{where}: meta '{key}' ({p.description}) must be {want}, got {type(value).__name__}")
        if p.acceptable is not None and value not in p.acceptable:
            raise BeamFormatError(f"{where}: meta '{key}' is {value!r}; acceptable: {', '.join(map(str, p.acceptable))}")
