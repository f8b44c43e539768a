"""The antenna's input impedance and S11: from our engines' beams and the EDGES table's headers,
written as Touchstone that scikit-rf reads back, compared between engines."""
import json

import numpy as np
import pytest

from groundplane.beam import Beam
from groundplane.cli import main
from groundplane.s11 import input_impedance, reflection
from tests.conftest import shared_file

F = np.array([50.0, 60.0, 70.0])


def _beam(path, z, freqs=F):
    g = np.ones((freqs.size, 91, 360))
    Beam(freqs, np.arange(91.0), np.arange(360.0), g, {"source": "test", "input_impedance_re": list(z.real),
                                                       "input_impedance_im": list(z.imag)}).save(path)
    return str(path)


def _read_with_scikit_rf(path) -> dict:
    """scikit-rf's reading of a Touchstone file, in its own process (its libraries' OpenMP runtime
    and healpy's cannot share one: 'cannot allocate memory in static TLS block')."""
    import subprocess
    import sys

    pytest.importorskip("skrf")
    code = ("import json, sys, skrf; n = skrf.Network(sys.argv[1]); print(json.dumps({'f': n.f.tolist(), "
            "'z0': n.z0[:, 0].real.tolist(), 's': [[v.real, v.imag] for v in n.s[:, 0, 0]], "
            "'z': [[v.real, v.imag] for v in n.z[:, 0, 0]]}))")
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, check=True).stdout
    return json.loads(out)


def test_touchstone_is_read_back_by_scikit_rf_to_1e9(tmp_path, capsys):
    z = np.array([21.6 + 8.5j, 55.7 + 28.4j, 79.3 + 7.9j])
    path = _beam(tmp_path / "b.npz", z)
    out = tmp_path / "antenna.s1p"
    assert main(["s11", path, "-o", str(out), "--z0", "75"]) == 0
    net = _read_with_scikit_rf(out)
    s = np.array([complex(*v) for v in net["s"]])
    assert np.allclose(net["f"], F * 1e6) and np.allclose(net["z0"], 75.0)
    assert np.abs(s - (z - 75) / (z + 75)).max() < 1e-9
    assert np.abs(np.array([complex(*v) for v in net["z"]]) - z).max() < 1e-6
    assert "| 60 | 55.700 | 28.400 |" in capsys.readouterr().out
    assert main(["s11", path, "--json"]) == 0
    row = json.loads(capsys.readouterr().out)[0]
    assert row["s11_db"][0] == pytest.approx(20 * np.log10(abs((z[0] - 50) / (z[0] + 50))))


def test_a_beam_without_impedance_and_a_bad_reference_are_one_line(tmp_path, capsys):
    plain = tmp_path / "p.npz"
    Beam(F, np.arange(91.0), np.arange(360.0), np.ones((3, 91, 360))).save(plain)
    assert main(["s11", str(plain)]) == 2
    assert "no input impedance" in capsys.readouterr().err
    path = _beam(tmp_path / "b.npz", np.array([50.0 + 0j] * 3))
    assert main(["s11", path, "--z0", "-1"]) == 2
    assert main(["s11", path, "-o", str(tmp_path / "x.txt")]) == 2
    assert ".s1p" in capsys.readouterr().err


def test_the_edges_tables_headers_give_its_impedance():
    """'#FREQUENCY 80 MHz amp in dB s11 -1.463 dB 6.136 -33.741': R and X at 50 ohm, and the
    |S11| they give is the header's."""
    from solvers.io import load_beam

    beam = load_beam(shared_file("edges_highband_feko_gain_db.txt"))
    z = input_impedance(beam)
    assert z is not None and z[0] == pytest.approx(6.136 - 33.741j)
    assert 20 * np.log10(abs(reflection(z[0]))) == pytest.approx(-1.463, abs=0.005)


def test_both_engines_give_the_blade_over_pec_an_impedance_within_the_documented_bounds(tmp_path, monkeypatch):
    """docs/beams.md: the feed models differ (a 4 cm strip across the gap against one wire
    segment), so R differs by 1.3-1.6x and the impedances by 45-75 %; both put the blade's
    series resonance (R largest) at 70 MHz."""
    from groundplane.design import Design, InfinitePEC
    from solvers.engines import make_solver

    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path))
    freqs = [60.0, 70.0, 80.0]
    # in worker processes: NEC's OpenMP runtime must not share this process with healpy's
    zs = input_impedance(make_solver("surface", workers=1).solve(Design(None, InfinitePEC()), freqs))
    zn = input_impedance(make_solver("nec", workers=1).solve(Design(None, InfinitePEC()), freqs))
    assert np.argmax(zs.real) == np.argmax(zn.real) == 1
    assert np.all((zn.real / zs.real > 1.3) & (zn.real / zs.real < 1.6))
    assert np.all(np.abs(zn - zs) / np.abs(zs) < 0.75)


def test_compare_and_metrics_show_the_s11(tmp_path, capsys):
    f = np.arange(50.0, 101.0)
    a = _beam(tmp_path / "a.npz", np.linspace(40.0, 80.0, f.size) + 0j, freqs=f)
    b = _beam(tmp_path / "b.npz", np.linspace(45.0, 85.0, f.size) + 0j, freqs=f)
    assert main(["fom", a, "--metrics", "--n-lst", "24"]) == 0
    assert "S11 (50 ohm):" in capsys.readouterr().out
    assert main(["compare", a, b, "--n-lst", "24"]) == 0
    assert "|S11| (50 ohm) of b.npz against a.npz: differs by" in capsys.readouterr().out
