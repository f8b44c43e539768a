"""A beam's metadata keys are declared once (groundplane/beam_meta.py) and checked on every
beam; the keys any layer reads are declared; per-frequency values follow a frequency subset."""
import re

import numpy as np
import pytest

from groundplane.beam import Beam, BeamFormatError
from groundplane.beam_meta import BEAM_META
from tests.conftest import ROOT


def _beam(**meta):
    f = np.array([50.0, 60.0, 70.0])
    return Beam(f, np.arange(91.0), np.arange(0.0, 360.0, 90.0), np.ones((3, 91, 4)), meta)


def test_every_key_the_code_reads_is_declared():
    read = set()
    for pkg in ("groundplane", "solvers", "optimise"):
        for path in (ROOT / pkg).rglob("*.py"):
            read |= set(re.findall(r"meta(?:\.get\(|\[)\"([a-z_0-9]+)\"", path.read_text()))
    assert read, "the pattern found no reads: it no longer matches the code"
    assert read <= set(BEAM_META), f"read but not declared in groundplane/beam_meta.py: {sorted(read - set(BEAM_META))}"


def test_every_declaration_is_described_and_typed():
    for key, p in BEAM_META.items():
        assert p.description and p.kind, key


@pytest.mark.parametrize("meta, message", [
    ({"n_unknowns": "many"}, r"meta 'n_unknowns' .* must be int, got str"),
    ({"n_unknowns": True}, r"must be int, got bool"),
    ({"seconds_per_frequency": [1.0, 2.0]}, r"one value per frequency \(3\), got 2 values"),
    ({"input_impedance_re": [1.0, "x", 2.0]}, r"meta 'input_impedance_re' holds 'x', not a number"),
    ({"gain_normalisation": "volts"}, r"acceptable: input_power, available_power"),
    ({"design": [1, 2]}, r"meta 'design' .* must be dict, got list"),
])
def test_a_key_against_its_declaration_is_refused_by_name(meta, message):
    with pytest.raises(BeamFormatError, match=message):
        _beam(source="test beam", **meta)


def test_undeclared_keys_ride_along_and_nan_is_a_number():
    b = _beam(my_diagnostic={"x": 1}, input_impedance_re=[1.0, float("nan"), 3.0], input_impedance_im=[0, 0, 0])
    assert b.meta["my_diagnostic"] == {"x": 1}


def test_a_frequency_subset_takes_its_per_frequency_values_along():
    b = _beam(seconds_per_frequency=[1.0, 2.0, 3.0], n_unknowns=10, source="s")
    sub = b.at_frequencies(np.array([0, 2]))
    assert sub.freqs_mhz.tolist() == [50.0, 70.0] and sub.meta["seconds_per_frequency"] == [1.0, 3.0]
    assert sub.meta["n_unknowns"] == 10 and np.array_equal(sub.gain, b.gain[[0, 2]])


def test_a_stored_beam_with_bad_meta_is_one_clear_error(tmp_path):
    good = _beam(seconds_per_frequency=[1.0, 2.0, 3.0])
    path = good.save(tmp_path / "b.npz")
    import json

    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta"]))
    meta["seconds_per_frequency"] = [1.0]
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(BeamFormatError, match="seconds_per_frequency"):
        Beam.load(tmp_path / "bad.npz")
