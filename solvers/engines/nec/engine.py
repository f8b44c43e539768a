"""The NEC-2 engine itself: which one is installed, whether it computes the right
currents (the golden test), and running a model at one frequency.

``pynec-accel`` 1.7.6 (module ``PyNEC``) is the engine. ``PyNEC``/``necpp`` 2.3.4 give
wrong currents for wires a few cm above Sommerfeld soil (shared/nec/NOTES.md);
pynec-accel matches Fortran NEC-2 there but is wrong *with GX symmetry*, so GX is never
used and a request for it is refused. A golden test (half-wave dipole 5 cm over MRO soil,
Fortran NEC-2: -3.22 dBi at zenith) runs before the first soil solve in a process and a
wrong engine is refused. NEC always runs in spawned worker processes: PyNEC and healpy
each bundle a libgomp, and loading both in one process fails ("cannot allocate memory in
static TLS block").
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from groundplane.errors import EngineError, SolveError, UserInputError
from groundplane.files import atomic_path, warn_once

from ..patterns import to_one_degree, upper_mean_gain
from ..workers import process_pool
from .mesh import NecModel

C_MHZ_M = 299.792458
VERIFIED = ("pynec-accel", "1.7.6")
GOLDEN_DBI = -3.22  # Fortran NEC-2, dipole 5 cm over eps_r 3.5, sigma 0.02 S/m (NOTES.md)
_GOLDEN_OK: dict[str, float] = {}


def engine_info() -> dict[str, str]:
    """Which distribution provides the PyNEC module, and its version."""
    from importlib import metadata

    for dist in ("pynec-accel", "PyNEC", "pynec"):
        try:
            return {"engine": dist.lower(), "version": metadata.version(dist)}
        except metadata.PackageNotFoundError:
            continue
    raise EngineError("no NEC-2 engine: install pynec-accel==1.7.6 (pip install -e . does)")


def golden_dipole_zenith_gain(height: float = 0.05) -> float:
    """Zenith gain (dBi) of the NOTES.md golden case: half-wave dipole at 75 MHz, radius
    1 cm, 11 segments, ``height`` m over eps_r 3.5, sigma 0.02 S/m (Fortran: -3.22 dBi at 5 cm)."""
    from PyNEC import nec_context

    c = nec_context()
    g = c.get_geometry()
    half = 0.25 * C_MHZ_M / 75.0
    g.wire(1, 11, -half, 0.0, height, half, 0.0, height, 0.01, 1.0, 1.0)
    c.geometry_complete(1)
    c.gn_card(2, 0, 3.5, 0.02, 0, 0, 0, 0)
    c.fr_card(0, 1, 75.0, 0)
    c.ex_card(0, 1, 6, 0, 1.0, 0, 0, 0, 0, 0)
    c.rp_card(0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0)
    return float(np.asarray(c.get_radiation_pattern(0).get_gain())[0, 0])


def engine_call(fn, *args):
    """Run ``fn(*args)`` in a fresh spawned engine process (never beside healpy)."""
    with process_pool(1) as pool:
        return pool.submit(fn, *args).result()


def check_engine(ground: str, in_process: bool = False) -> dict[str, str]:
    """Refuse an engine known to be wrong over soil; run the golden test once (in an engine
    process, or here with ``in_process`` where NEC runs in this process). The models never use
    NEC's GX (mirror) symmetry: pynec-accel 1.7.6 is wrong with it (5.62 vs 3.85 dBi, NOTES.md)."""
    info = engine_info()
    if ground == "soil":
        if (info["engine"], info["version"]) != VERIFIED:
            raise EngineError(
                f"{info['engine']} {info['version']} is not verified for wires near Sommerfeld soil "
                "(PyNEC/necpp 2.3.4 are known wrong there); install pynec-accel==1.7.6"
            )
        key = f"{info['engine']}-{info['version']}"
        if key not in _GOLDEN_OK:
            got = golden_dipole_zenith_gain(0.05) if in_process else engine_call(golden_dipole_zenith_gain, 0.05)
            if abs(got - GOLDEN_DBI) > 0.05:
                raise EngineError(
                    f"{key} failed the golden test: dipole 5 cm over soil gives {got:.2f} dBi at zenith, "
                    f"Fortran NEC-2 gives {GOLDEN_DBI} dBi"
                )
            _GOLDEN_OK[key] = got
    return info


def context(model: NecModel, freq_mhz: float):
    """A PyNEC context with the model's geometry, ground, frequency and excitation set."""
    from PyNEC import nec_context

    c = nec_context()
    g = c.get_geometry()
    for w in model.wires:
        g.wire(w.tag, w.n_seg, *w.p1, *w.p2, w.radius, 1.0, 1.0)
    if model.sections > 1:
        g.generate_cylindrical_structure(len(model.wires), model.sections)  # GR card
    c.geometry_complete(1)
    if model.ground == "soil":
        c.gn_card(2, 0, model.eps_r, model.sigma, 0, 0, 0, 0)
    elif model.ground == "pec":
        c.gn_card(1, 0, 0, 0, 0, 0, 0, 0)
    # "free": no ground card (free space)
    c.fr_card(0, 1, float(freq_mhz), 0)
    for tag, volts in model.sources():
        c.ex_card(0, tag, 1, 0, float(volts), 0, 0, 0, 0, 0)
    return c


def radiation_pattern(model: NecModel, freq_mhz: float, n_phi: int, step: int = 1) -> np.ndarray:
    """Linear power gain [theta 0..90, phi 0..n_phi-1] (1-degree steps) at one frequency.

    NEC computes the far field every ``step`` degrees (the far-field sum costs as much as
    the LU at 1 degree); the grid is then interpolated to 1 degree by :func:`to_one_degree`."""
    return pattern_and_impedance(model, freq_mhz, n_phi, step)[0]


def pattern_and_impedance(model: NecModel, freq_mhz: float, n_phi: int, step: int = 1) -> tuple[np.ndarray, complex]:
    """:func:`radiation_pattern` and the antenna's input impedance (ohm) from the same solve: the
    sum over the feed's sources (the gap split in series at x = 0, halves under GR) of V / I."""
    n_th = 90 // step + 1
    n_ph = 90 // step + 1 if n_phi == 91 else 360 // step
    c = context(model, freq_mhz)
    c.rp_card(0, n_th, n_ph, 0, 0, 0, 0, 0.0, 0.0, float(step), float(step), 0, 0)
    ip = c.get_input_parameters(0)
    volts, amps = np.asarray(ip.get_voltage(), complex), np.asarray(ip.get_current(), complex)
    z_in = complex(np.sum(volts / amps)) if amps.size and np.all(np.abs(amps) > 0) else complex("nan")
    db = np.asarray(c.get_radiation_pattern(0).get_gain(), dtype=float)
    if db.shape != (n_th, n_ph) or not np.all(np.isfinite(db)):
        raise SolveError(f"NEC returned a pattern of shape {db.shape} with non-finite values at {freq_mhz} MHz")
    g = 10.0 ** (db / 10.0)
    g[db <= -990] = 0.0  # NEC's "no field" marker (theta = 90 over ground)
    return (g if step == 1 else to_one_degree(g, step, quadrant=n_phi == 91)), z_in


def calibration_factor(ref_model: NecModel, freq: float, step: int, store: str | None = None) -> float:
    """kappa = (mean gain of the blade over PEC over the upper hemisphere) / 2 at ``freq``.

    It depends only on the blade model, frequency and far-field grid, so it is kept in
    ``store`` (a directory named by those; one small JSON per frequency) and every candidate
    with the same blade reuses it instead of solving the blade over PEC again."""
    path = Path(store) / f"{freq:.6f}.json" if store else None
    if path is not None and path.exists():
        try:
            return float(json.loads(path.read_text())["kappa"])
        except (ValueError, KeyError, TypeError):
            path.unlink(missing_ok=True)  # damaged: recompute
    kappa = upper_mean_gain(radiation_pattern(ref_model, freq, 91, step)) / 2.0  # the blade alone: D2-symmetric
    if path is not None and 0.3 < kappa < 3.0:
        try:
            with atomic_path(path, suffix=".tmp.json") as tmp:
                tmp.write_text(json.dumps({"freq_mhz": freq, "kappa": kappa}))
        except UserInputError as exc:  # an unwritable cache: solved again next time, as the beam cache does
            warn_once("calibration-unwritable", f"the NEC-2 gain calibration is not kept ({exc}); it is solved "
                                                "again for every design")
    return kappa


@dataclass(frozen=True)
class NecJob:
    """What a worker needs to solve one design at any frequency. ``calibration``: ``"self"``
    when the design *is* the blade over PEC (its own mean gain calibrates it), ``"reference"``
    to divide by the blade-over-PEC ``reference`` model's (kept in ``store``), ``"none"``."""

    model: NecModel
    n_phi: int
    step: int
    calibration: str = "none"
    reference: NecModel | None = None
    store: str | None = None


def solve_frequency(job: NecJob, freq: float) -> tuple[np.ndarray, dict[str, float]]:
    """Worker job: the calibrated pattern at one frequency, its calibration factor and the
    input impedance."""
    g, z_in = pattern_and_impedance(job.model, freq, job.n_phi, job.step)
    kappa = 1.0
    if job.calibration != "none":
        if job.calibration == "self":
            kappa = upper_mean_gain(g) / 2.0
        else:
            kappa = calibration_factor(job.reference, freq, job.step, job.store)
        if not (0.3 < kappa < 3.0):
            raise SolveError(f"gain calibration factor {kappa:.3f} at {freq} MHz is implausible")
        g = g / kappa
    return g, {"gain_calibration_kappa": kappa, "input_impedance_re": z_in.real, "input_impedance_im": z_in.imag}


def solve_band(job: NecJob, freqs) -> np.ndarray:
    """Engine process: the job's gain [f, 91, n_phi] at each frequency, one after another."""
    return np.stack([solve_frequency(job, float(f))[0] for f in freqs])
