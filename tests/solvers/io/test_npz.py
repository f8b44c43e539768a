"""Every loader on real (or vendor-layout) samples, and malformed variants of each."""

import numpy as np
import pytest

from groundplane.beam import Beam, BeamFormatError
from solvers import detect_format, load_beam


def test_npz_roundtrip_and_no_pickle(tmp_path):
    b = Beam([50.0, 60.0], np.arange(91.0), np.arange(0, 360, 10.0), np.ones((2, 91, 36)), {"solver": "test"})
    p = b.save(tmp_path / "b.npz")
    assert detect_format(p) == "npz"
    c = load_beam(p)
    assert np.array_equal(c.gain, b.gain) and c.meta["solver"] == "test"
    np.savez(tmp_path / "evil.npz", freqs_mhz=np.array([1.0]), theta_deg=np.array([0.0]),
             phi_deg=np.array([0.0]), gain=np.array([[[1.0]]]), meta=np.array([{"a": 1}], dtype=object))
    with pytest.raises(BeamFormatError, match="not a readable|holds Python objects"):
        Beam.load(tmp_path / "evil.npz")
    np.savez(tmp_path / "partial.npz", freqs_mhz=np.array([1.0]))
    with pytest.raises(BeamFormatError, match="missing arrays"):
        Beam.load(tmp_path / "partial.npz")



def test_npz_declaring_a_huge_array_is_refused_without_allocating(tmp_path):
    """A header claiming 8 GB in a tiny file: refused from the header, named, no MemoryError."""
    import io
    import zipfile

    from numpy.lib import format as npy

    from groundplane.beam import Beam, BeamFormatError

    p = tmp_path / "huge.npz"
    with zipfile.ZipFile(p, "w") as zf:
        for name, arr in (("freqs_mhz", np.arange(3.0)), ("theta_deg", np.arange(91.0)), ("phi_deg", np.arange(360.0))):
            buf = io.BytesIO()
            np.save(buf, arr)
            zf.writestr(name + ".npy", buf.getvalue())
        buf = io.BytesIO()
        npy.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": (1_000_000_000,)})
        zf.writestr("gain.npy", buf.getvalue() + b"\0" * 64)
    with pytest.raises(BeamFormatError, match=r"huge\.npz: array 'gain' declares shape \(1000000000,\)"):
        Beam.load(p)


def test_npz_decompression_bomb_is_refused_from_the_zip_directory(tmp_path):
    """A consistent header over 256 MB of zeros compressed to ~250 kB: refused before numpy
    allocates or inflates anything."""
    import io
    import time
    import zipfile

    from groundplane.beam import Beam, BeamFormatError

    n = 3 * 91 * 120_000  # 256 MB of float64 gain
    p = tmp_path / "bomb.npz"
    with zipfile.ZipFile(p, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name, arr in (("freqs_mhz", np.arange(3.0)), ("theta_deg", np.arange(91.0)),
                          ("phi_deg", np.arange(120_000.0))):
            buf = io.BytesIO()
            np.save(buf, arr)
            zf.writestr(name + ".npy", buf.getvalue())
        from numpy.lib import format as npy

        with zf.open("gain.npy", "w", force_zip64=True) as fh:
            npy.write_array_header_1_0(fh, {"descr": "<f8", "fortran_order": False, "shape": (3, 91, 120_000)})
            zero = bytes(2**20)
            for _ in range(n * 8 // len(zero)):
                fh.write(zero)
    assert p.stat().st_size < 2 * 2**20
    t0 = time.perf_counter()
    with pytest.raises(BeamFormatError, match=r"bomb\.npz: array 'gain' decompresses to [\d,]+ bytes from [\d,]+ \([\d,]+x\)"):
        Beam.load(p)
    assert time.perf_counter() - t0 < 5
