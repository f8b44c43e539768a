"""Ground loss: 1 - the upper hemisphere's integral of G / 4 pi, for gains normalised to input power."""
import json

import numpy as np
import pytest

from groundplane.beam import Beam
from groundplane.cli import main
from groundplane.errors import GroundLossUndefined
from tests.conftest import ROOT

THETA, PHI = np.arange(91.0), np.arange(360.0)


def _beam(gain_fn, freqs=(60.0, 80.0), **meta) -> Beam:
    th, ph = np.radians(THETA)[:, None], np.radians(PHI)[None, :]
    gain = np.stack([gain_fn(th, ph, f) for f in freqs])
    return Beam(np.array(freqs), THETA, PHI, gain, {"gain_normalisation": "input_power", **meta})


def test_loss_of_an_analytic_gain_is_its_integral():
    """G = a cos^n(theta): int over the upper hemisphere = 2 pi a / (n + 1), so L = 1 - a / (2 (n + 1));
    the cell-area rule on a 1-degree grid is within 1e-4 of it."""
    for a, n in ((2.0, 0), (5.0, 1.5), (7.0, 3.0)):
        beam = _beam(lambda th, ph, f: a * np.cos(th) ** n * np.ones_like(ph))
        want = 1 - a / (2 * (n + 1))
        assert np.allclose(beam.ground_loss(), want, atol=1e-4)


def test_loss_of_a_lossy_beam_agrees_with_an_independent_integration():
    """A beam with azimuthal structure and a horizon null, against scipy's spline integral of
    G sin(theta) over the hemisphere (a different rule on the same samples)."""
    from scipy.interpolate import RectBivariateSpline

    def gain(th, ph, f):
        return 3.4 * np.cos(th) ** 1.2 * (1 + 0.3 * np.cos(2 * ph) * np.sin(th)) * (1 + 0.001 * f)

    beam = _beam(gain)
    th, ph = np.radians(THETA), np.radians(np.append(PHI, 360.0))
    for i, f in enumerate(beam.freqs_mhz):
        g = np.concatenate([beam.gain[i], beam.gain[i][:, :1]], axis=1) * np.sin(th)[:, None]
        spline = RectBivariateSpline(th, ph, g, kx=3, ky=3)
        independent = 1 - spline.integral(0, np.pi / 2, 0, 2 * np.pi) / (4 * np.pi)
        assert beam.ground_loss()[i] == pytest.approx(independent, abs=2e-4)
        assert 0.05 < beam.ground_loss()[i] < 0.5


def test_a_lossless_model_loses_nothing_within_quadrature():
    """The surface engine's blade over infinite PEC radiates what it takes in: L = 0 to 1e-3."""
    from groundplane.design import Design, InfinitePEC
    from solvers.engines import make_solver
    from solvers.engines.surface import SurfaceSettings

    beam = make_solver("surface", SurfaceSettings(blade_cells=(4, 4)), workers=0, use_cache=False).solve(
        Design(None, InfinitePEC()), [50.0, 80.0])
    assert beam.gain_normalisation == "input_power"
    assert np.abs(beam.ground_loss()).max() < 1e-3


@pytest.mark.parametrize("meta,norm", [({"quantity": "Directivity(Total)"}, "radiated_power"),
                                       ({"quantity": "Realized Gain(Total)"}, "available_power"),
                                       ({"quantity": "dB(DirTotal)"}, "radiated_power"),
                                       ({}, "unknown")])
def test_gain_not_normalised_to_input_power_has_no_loss(meta, norm):
    beam = Beam(np.array([70.0]), THETA, PHI, np.ones((1, 91, 360)), {"source": "export.ffe", **meta})
    assert beam.gain_normalisation == norm
    with pytest.raises(GroundLossUndefined, match="export.ffe: its gain is normalised to .*not to the antenna's input"):
        beam.ground_loss()


def test_loss_command_prints_and_writes_the_edges_table(tmp_path, capsys):
    path = tmp_path / "b.npz"
    _beam(lambda th, ph, f: 3.6 * np.cos(th) * np.ones_like(ph), freqs=(55.0, 76.0, 97.0),
          source="test beam").save(path)
    out = tmp_path / "ground.txt"
    assert main(["loss", str(path), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "| 76 | 10.0" in printed  # 1 - 3.6 / (2 x 2) = 0.1: within 1e-4 of the analytic value
    table = np.genfromtxt(out)  # what the EDGES pipeline does with it
    assert table.shape == (3, 2) and np.allclose(table[:, 0], [55, 76, 97])
    assert np.allclose(table[:, 1], 0.1, atol=1e-4)
    assert out.read_text().startswith("# ground loss L = 1 - (1/4 pi)")
    assert main(["loss", str(path), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert rows[0]["gain_normalisation"] == "input_power" and len(rows[0]["ground_loss"]) == 3


def test_loss_command_refuses_a_table_without_input_power_normalisation(tmp_path, capsys):
    out = tmp_path / "ground.txt"
    assert main(["loss", str(ROOT / "examples" / "edges_highband_feko.npz"), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "no ground loss" in err or "not to the antenna's input power" in err
    assert not out.exists()
    assert main(["loss", "a.npz", "b.npz", "-o", str(out)]) == 2
    assert "one beam's table" in capsys.readouterr().err


def test_fom_json_and_metrics_carry_the_loss(tmp_path, capsys):
    path = tmp_path / "b.npz"
    _beam(lambda th, ph, f: 3.6 * np.cos(th) * np.ones_like(ph), freqs=tuple(np.arange(50.0, 101.0))).save(path)
    assert main(["fom", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert np.allclose(out["ground_loss"], 0.1, atol=1e-4) and out["max_ground_loss_fit_band"] == pytest.approx(0.1, abs=1e-4)
    assert main(["fom", str(path), "--metrics"]) == 0
    assert "ground loss: 10.0" in capsys.readouterr().out
