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
EDGES_TABLE = SHARED_BEAMS / "edges_highband_feko_gain_db.txt"


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
    if EDGES_TABLE.exists():  # its first frequency block: header and 360 azimuth rows
        out["edges-table"] = ("t.txt", ("\n".join(EDGES_TABLE.read_text().splitlines()[:362]) + "\n").encode())
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


def _check(p, fmt):
    try:
        beam = load_beam([p], fmt)
    except BeamFormatError as exc:
        assert str(p) in str(exc) or p.name in str(exc), f"error does not name the file: {exc}"
        return None
    assert isinstance(beam, Beam) and np.all(np.isfinite(beam.gain)) and np.all(beam.freqs_mhz > 0)
    return beam


azimuth_token = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr),
                          st.integers(-10**12, 10**12).map(str), st.text(min_size=1, max_size=8).filter(
                              lambda t: t.strip() and not any(c.isspace() for c in t)))


@pytest.mark.skipif(not EDGES_TABLE.exists(), reason="needs ../shared/data/beams (the EDGES-format FEKO table)")
@settings(max_examples=int(__import__("os").environ.get("FUZZ_EXAMPLES", 60)), deadline=5000,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(row=st.integers(0, 359), token=azimuth_token)
def test_any_azimuth_row_number_loads_or_is_refused_naming_its_line(row, token, tmp_path):
    """The azimuth column of an EDGES table (each row's 'az N'): any token in any row is either
    the number that row must hold or a refusal naming the file and that line."""
    lines = EDGES_TABLE.read_text().splitlines()[:362]
    first = next(i for i, ln in enumerate(lines) if ln.startswith("az"))
    i = first + row
    parts = lines[i].split()
    lines[i] = " ".join([parts[0], token, *parts[2:]])
    p = tmp_path / "t.txt"
    p.write_text("\n".join(lines) + "\n")
    try:
        load_beam([p], "edges-table")
    except BeamFormatError as exc:
        assert f"t.txt:{i + 1}" in str(exc), f"error does not name the line: {exc}"
        return
    assert float(token) == float(parts[1])  # only the right number loads


@settings(max_examples=int(__import__("os").environ.get("FUZZ_EXAMPLES", 60)), deadline=5000,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(shape=st.lists(st.integers(0, 10**7), min_size=0, max_size=4).map(tuple),
       descr=st.sampled_from(["<f8", "<c16", "<f4", "|u1", "<i8", "|O"]), pad=st.integers(0, 4096))
def test_any_declared_gain_array_is_read_or_refused_without_allocating_it(shape, descr, pad, tmp_path):
    """An .npz whose gain header declares any shape and type over a few bytes of data (a
    decompression or allocation bomb): a clean refusal naming the file, never a MemoryError."""
    import zipfile

    from numpy.lib import format as npy

    p = tmp_path / "bomb.npz"
    with zipfile.ZipFile(p, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name, arr in (("freqs_mhz", np.arange(50.0, 53.0)), ("theta_deg", np.arange(0.0, 91.0, 10.0)),
                          ("phi_deg", np.arange(0.0, 360.0, 30.0))):
            buf = io.BytesIO()
            np.save(buf, arr)
            zf.writestr(name + ".npy", buf.getvalue())
        buf = io.BytesIO()
        npy.write_array_header_1_0(buf, {"descr": descr, "fortran_order": False, "shape": shape})
        zf.writestr("gain.npy", buf.getvalue() + b"\0" * pad)
    _check(p, "npz")
