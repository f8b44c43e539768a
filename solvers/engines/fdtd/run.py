"""Running gprMax and reading what it wrote. gprMax is GPLv3: this BSD package never imports
it; it runs as its own process (``python -m gprMax model.in``, or the command in
``$GROUNDPLANE_GPRMAX``) and its HDF5 output is read with h5py.

A run lives in a folder named by its input's content; a finished run (its output and a
``done.json`` naming the input's hash) is read again rather than re-run, so a solve killed
after the stepping finished loses nothing, and one killed during it starts that run again
(a time-domain run cannot resume mid-way).
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import shlex
import subprocess
import sys
import time
from importlib import metadata
from importlib.util import find_spec
from pathlib import Path

import numpy as np

from groundplane.errors import EngineError, SolveError
from groundplane.files import atomic_path

GPRMAX_ENV = "GROUNDPLANE_GPRMAX"
GPRMAX_ARGS_ENV = "GROUNDPLANE_GPRMAX_ARGS"  # gprMax's own flags after the input file: "-gpu 0" runs on a GPU
VERIFIED_VERSION = "4.0.1"  # the far-field transform over a layered background this engine relies on
_STEP = re.compile(rb"(\d+)/(\d+) \[")


def gprmax_command() -> list[str]:
    """The command that runs gprMax: ``$GROUNDPLANE_GPRMAX`` (e.g. a separate environment's
    ``/opt/gprmax/bin/python -m gprMax``), else this Python's ``-m gprMax``."""
    said = os.environ.get(GPRMAX_ENV, "").strip()
    return shlex.split(said) if said else [sys.executable, "-m", "gprMax"]


def gprmax_args() -> list[str]:
    """gprMax's own flags, put after the input file (``$GROUNDPLANE_GPRMAX_ARGS``: ``-gpu 0`` for
    its CUDA solver, ``-cpu_precision double``, ...)."""
    return shlex.split(os.environ.get(GPRMAX_ARGS_ENV, ""))


def engine_info() -> dict[str, str]:
    """gprMax's identity for the cache key (read from its distribution, never imported), with the
    flags it runs with (a GPU or another precision is another model's numbers)."""
    flags = {"args": " ".join(gprmax_args())} if gprmax_args() else {}
    if os.environ.get(GPRMAX_ENV, "").strip():
        return {"engine": "gprmax", "version": "external", "command": os.environ[GPRMAX_ENV].strip(), **flags}
    try:
        return {"engine": "gprmax", "version": metadata.version("gprMax"), **flags}
    except metadata.PackageNotFoundError:
        return {"engine": "gprmax", "version": "not installed", **flags}


def check_engine() -> None:
    """Refuse, before any work, a machine without gprMax (or with a version whose layered far
    field this engine was not checked against)."""
    if os.environ.get(GPRMAX_ENV, "").strip():
        return
    if find_spec("gprMax") is None:
        raise EngineError("the fdtd engine needs gprMax (GPLv3, run as its own process): pip install gprMax==4.0.1 "
                          f"(the README's set-up installs it), or point {GPRMAX_ENV} at a command that runs it")
    have = engine_info()["version"]
    if have != VERIFIED_VERSION:
        raise EngineError(f"gprMax {have} is installed; the fdtd engine was checked against {VERIFIED_VERSION} "
                          "(its layered far field and port outputs): pip install gprMax==4.0.1")


def run_dir_for(root: Path, input_text: str) -> Path:
    """The folder of the run of ``input_text`` (by its content)."""
    return root / hashlib.sha256(input_text.encode()).hexdigest()[:24]


def _die_with_parent() -> None:  # pragma: no cover - runs in the child between fork and exec
    """A gprMax run must not outlive a killed solve (hours of two cores for nobody)."""
    try:
        import ctypes
        import signal

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except OSError:
        pass


def run_gprmax(input_text: str, run_dir: Path, label: str, steps: int, progress: bool = False) -> Path:
    """Run gprMax on ``input_text`` in ``run_dir`` (reused when it already finished); the
    output HDF5's path. Progress is gprMax's own step count, re-printed as this toolkit's."""
    out = run_dir / "model.h5"
    done = run_dir / "done.json"
    digest = hashlib.sha256(input_text.encode()).hexdigest()
    if out.exists() and done.exists():
        try:
            if json.loads(done.read_text()).get("input_sha256") == digest:
                return out
        except (OSError, ValueError):
            pass
    run_dir.mkdir(parents=True, exist_ok=True)
    for stale in (out, done):
        stale.unlink(missing_ok=True)
    (run_dir / "model.in").write_text(input_text)
    bar = None
    if progress:
        from groundplane.progress import Progress

        bar = Progress(steps, f"fdtd {label}", "steps", every_s=30.0)
    log = run_dir / "gprmax.log"
    t0 = time.perf_counter()
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    with open(log, "wb") as sink:
        try:
            proc = subprocess.Popen([*gprmax_command(), "model.in", *gprmax_args()], cwd=run_dir, stdout=subprocess.PIPE,
                                    stderr=subprocess.STDOUT, env=env, preexec_fn=_die_with_parent)
        except OSError as exc:
            raise EngineError(f"could not start gprMax ({' '.join(gprmax_command())}): {exc}") from exc
        try:
            _follow(proc, sink, bar)
            code = proc.wait()
        except BaseException:
            proc.kill()
            proc.wait()
            raise
        finally:
            if bar is not None:
                bar.close()
    if code != 0 or not out.exists():
        tail = _last_error(log)
        raise SolveError(f"{label}: gprMax failed (exit {code}): {tail} (log: {log})")
    with atomic_path(done, suffix=".tmp") as tmp:
        tmp.write_text(json.dumps({"input_sha256": digest, "seconds": time.perf_counter() - t0}))
    return out


def _follow(proc: subprocess.Popen, sink, bar) -> None:
    """Copy gprMax's output to the log, updating ``bar`` from its step counter."""
    assert proc.stdout is not None
    seen = 0
    while chunk := proc.stdout.read1(4096) if hasattr(proc.stdout, "read1") else proc.stdout.read(4096):
        sink.write(chunk)
        if bar is not None:
            found = _STEP.findall(chunk)
            if found:
                n = min(int(found[-1][0]), bar.total)
                if n > seen:
                    bar.update(n - seen)
                    seen = n


def _last_error(log: Path) -> str:
    """The line of gprMax's log that says what went wrong."""
    try:
        lines = [ln.strip() for ln in log.read_text(errors="replace").splitlines() if ln.strip()]
    except OSError:
        return "no log"
    for ln in reversed(lines):
        if re.match(r"^\w*(Error|Exception)\b", ln) or "Error:" in ln:
            return ln[:300]
    return lines[-1][:300] if lines else "no output"


def read_far_field(path: Path, freqs_mhz: list[float]) -> dict[float, tuple[np.ndarray, complex, float]]:
    """Per asked frequency: the gain grid [theta, phi] gprMax computed (4 pi U / accepted power),
    the input impedance (terminal V / I) and the accepted power's validity flag."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            tr = f["ntff/box1/frequency/ff"]
            fhz = np.asarray(tr["frequencies"][:], dtype=float)
            pat = tr["far_field/pattern"]
            theta, phi = np.asarray(pat["theta"][:], float), np.asarray(pat["phi"][:], float)
            gain = np.asarray(pat["fields/gain"][:], float)
            pp = pat["port_power"]
            v = np.asarray(pp["terminal_voltage_per_port"][0], complex)
            i = np.asarray(pp["terminal_current_per_port"][0], complex)
            valid = np.asarray(pp["gain_valid"][:], bool)
    except (OSError, KeyError) as exc:
        raise SolveError(f"gprMax's output {path} does not hold the far field asked for ({exc})") from exc
    th_rows, ph_cols = np.unique(theta), np.unique(phi)
    grid = gain.reshape(len(fhz), th_rows.size, ph_cols.size)
    out = {}
    for f in freqs_mhz:
        k = int(np.argmin(np.abs(fhz - f * 1e6)))
        if abs(fhz[k] - f * 1e6) > 1e3:
            raise SolveError(f"gprMax's output {path} has no {f:g} MHz")
        out[f] = (grid[k], complex(v[k] / i[k]), bool(valid[k]))
    return out


def remove_run(run_dir: Path) -> None:
    """Drop a finished run's bulky output once its beam is cached (its input and log stay)."""
    (run_dir / "model.h5").unlink(missing_ok=True)
    (run_dir / "done.json").unlink(missing_ok=True)


__all__ = ["check_engine", "engine_info", "gprmax_command", "read_far_field", "remove_run", "run_dir_for",
           "run_gprmax"]
