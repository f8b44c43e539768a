"""Property-based fuzzing of every loader with mutated real files: the answer is a valid
Beam or the project's BeamFormatError naming the file -- never another exception, never
a hang (each example is bounded by hypothesis's deadline)."""
import io

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from groundplane.beam import Beam, BeamFormatError
from solvers import load_beam
from tests.conftest import DATA, SHARED_BEAMS

FEKO = SHARED_BEAMS / "feko_lowband_soil_40MHz_0-90.ffe"


def _small_ffe() -> bytes:
    """The real FEKO quadrant cut to theta 0-10 (11 x 91 rows), header counts adjusted."""
    lines = FEKO.read_text().splitlines()
    out = []
    for l in lines:
        parts = l.split()
        if l.startswith("#") or not parts:
            out.append(l.replace("Theta Samples: 181", "Theta Samples: 11"))
        elif float(parts[0]) <= 10.0:
            out.append(l)
    return ("\n".join(out) + "\n").encode()


def _small_npz() -> bytes:
    buf = io.BytesIO()
    b = Beam([50.0, 60.0, 70.0], np.arange(0.0, 91.0, 10.0), np.arange(0.0, 360.0, 30.0),
             np.random.default_rng(0).uniform(0.1, 8, (3, 10, 12)), {"solver": "fuzz"})
    np.savez(buf, freqs_mhz=b.freqs_mhz, theta_deg=b.theta_deg, phi_deg=b.phi_deg, gain=b.gain, meta='{"a": 1}')
    return buf.getvalue()


def _samples() -> dict[str, tuple[str, bytes]]:
    out = {"hfss": ("h.csv", (DATA / "hfss_gain.csv").read_bytes()),
           "cst": ("cst_farfield (f=50) [1].txt", (DATA / "cst_farfield (f=50) [1].txt").read_bytes()),
           "npz": ("b.npz", _small_npz())}
    if FEKO.exists():
        out["feko-ffe"] = ("q.ffe", _small_ffe())
    return out


SAMPLES = _samples()

mutation = st.one_of(
    st.tuples(st.just("flip"), st.integers(0, 10**9), st.integers(0, 255)),
    st.tuples(st.just("truncate"), st.integers(0, 10**9), st.just(0)),
    st.tuples(st.just("delete_line"), st.integers(0, 10**9), st.just(0)),
    st.tuples(st.just("duplicate_line"), st.integers(0, 10**9), st.just(0)),
    st.tuples(st.just("insert"), st.integers(0, 10**9), st.integers(0, 255)),
)


def mutate(data: bytes, ops) -> bytes:
    b = bytearray(data)
    for kind, pos, val in ops:
        if not b:
            break
        i = pos % len(b)
        if kind == "flip":
            b[i] = val
        elif kind == "truncate":
            del b[i:]
        elif kind == "insert":
            b[i:i] = bytes([val])
        else:
            lines = bytes(b).split(b"\n")
            j = pos % len(lines)
            lines[j:j + 1] = [] if kind == "delete_line" else [lines[j], lines[j]]
            b = bytearray(b"\n".join(lines))
    return bytes(b)


@pytest.mark.parametrize("fmt", sorted(SAMPLES))
@settings(max_examples=int(__import__("os").environ.get("FUZZ_EXAMPLES", 60)), deadline=5000, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(ops=st.lists(mutation, min_size=1, max_size=4))
def test_mutated_files_load_or_fail_cleanly(fmt, ops, tmp_path):
    name, data = SAMPLES[fmt]
    p = tmp_path / name
    p.write_bytes(mutate(data, ops))
    try:
        beam = load_beam([p], fmt)
    except BeamFormatError as exc:
        assert str(p) in str(exc) or p.name in str(exc), f"error does not name the file: {exc}"
        return
    assert isinstance(beam, Beam) and np.all(np.isfinite(beam.gain)) and np.all(beam.freqs_mhz > 0)
