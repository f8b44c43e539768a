"""NEC-2 adapter: golden values, engine guard, gain normalisation, mesh, cache, CLI.
CI solves stay small (blade alone, or a 3 m plate at a coarse mesh, few frequencies)."""
import numpy as np
import pytest

from groundplane.design import Design, Soil
from groundplane.errors import EngineError
from groundplane.shapes import Square
from solvers.engines.nec import (
    NecSettings,
    build_model,
    engine,
)
from solvers.engines.nec.engine import check_engine
from solvers.engines.patterns import mirror_quadrant


def test_engine_is_the_verified_one():
    info = check_engine("soil")
    assert info == {"engine": "pynec-accel", "version": "1.7.6"}

@pytest.mark.parametrize("height,fortran", [(0.05, -3.22), (0.30, 2.70)])
def test_golden_dipole_over_soil(height, fortran):
    assert engine.engine_call(engine.golden_dipole_zenith_gain, height) == pytest.approx(fortran, abs=0.05)

def test_wrong_engine_refused(monkeypatch):
    monkeypatch.setattr(engine, "engine_info", lambda: {"engine": "pynec", "version": "2.3.4"})
    with pytest.raises(EngineError, match="not verified"):
        check_engine("soil")
    monkeypatch.setattr(engine, "engine_info", lambda: {"engine": "pynec-accel", "version": "1.7.6"})
    monkeypatch.setattr(engine, "_GOLDEN_OK", {})
    monkeypatch.setattr(engine, "engine_call", lambda fn, h=0.05: -4.49)  # PyNEC 2.3.4's answer
    with pytest.raises(EngineError, match="failed the golden test"):
        check_engine("soil")

def test_mirror_quadrant_matches_full_solve_of_symmetric_plate():
    d = Design(Square(3.0), Soil())
    mesh = NecSettings(spacing=1.0)
    m = build_model(d, mesh)
    q = engine.engine_call(engine.radiation_pattern, m, 70.0, 91)
    full = engine.engine_call(engine.radiation_pattern, m, 70.0, 360)
    assert np.allclose(mirror_quadrant(q[None])[0], full, rtol=1e-3, atol=1e-9)

