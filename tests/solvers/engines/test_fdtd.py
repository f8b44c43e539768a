"""The FDTD referee: its grid model (pure geometry), real gprMax runs on tiny cases (a lossless
model must radiate what it takes in), and its refusals."""
import json
import math

import numpy as np
import pytest

from groundplane.antenna import EDGES_LOW_BAND
from groundplane.design import Design, FreeSpace, InfinitePEC, Soil
from groundplane.errors import EngineError, SettingsError, SolveError
from groundplane.shapes import PRESETS, Square
from solvers.engines import make_solver
from solvers.engines.fdtd import FdtdSettings, build_model, panel_cells
from solvers.engines.fdtd import run as fdtd_run
from solvers.engines.fdtd.model import soil_attenuation, soil_layer_depth


def test_blade_on_the_grid_follows_the_half_cell_rule():
    """At 5 cm: 0.95 x 1.20 m panels, 1.05 m up (shared/referee's blade for the 0.964 x 1.252 m one);
    the width stays an even count of cells so the one-cell feed sits on the axis of symmetry."""
    assert panel_cells(EDGES_LOW_BAND, 0.05) == (19, 24, 21)
    for dx in (0.03, 0.05, 0.075, 0.1):
        along, across, up = panel_cells(EDGES_LOW_BAND, dx)
        assert across % 2 == 0
        assert abs((along + 0.5) * dx - EDGES_LOW_BAND.panel_length) <= dx / 2 + 1e-9
        assert abs((across + 1) * dx - EDGES_LOW_BAND.panel_width) <= dx + 1e-9


def test_staircased_plane_keeps_its_symmetry_and_reports_its_metal():
    model = build_model(Design(PRESETS["sawtooth-20-16"], Soil()), FdtdSettings(cell=0.1))
    plane = [p for p in model.plates if abs(p[4] - model.soil_top) < 1e-9]  # the plate 'on' the soil
    assert plane, "the plane lies on the soil surface"
    i0, j0, _ = model.feed
    xc, yc = (i0 + 0.5) * model.dx, j0 * model.dx  # the feed edge's middle
    cells = set()
    for x1, y1, x2, y2, _ in plane:
        for i in range(round(x1 / model.dx), round(x2 / model.dx)):
            for j in range(round(y1 / model.dx), round(y2 / model.dx)):
                cells.add((round((i + 0.5) * model.dx - xc, 6), round((j + 0.5) * model.dx - yc, 6)))
    assert len(cells) == model.metal_cells  # the rectangles tile the staircase once
    assert all((-x, y) in cells and (x, -y) in cells for x, y in cells)  # both mirror symmetries
    assert model.metal_area == pytest.approx(PRESETS["sawtooth-20-16"].metal_area, rel=0.01)


def test_input_file_names_the_soil_the_feed_and_the_far_field():
    model = build_model(Design(Square(3.0), Soil(2.5, 0.005)), FdtdSettings(cell=0.1, plate_position="above"))
    text = model.input_file([55.0, 75.0, 97.0])
    assert "#material: 2.5 0.005 1 0 soil" in text
    assert "#voltage_source: x" in text and " feed 10" in text
    bg = next(ln for ln in text.splitlines() if ln.startswith("#ntff_layered_background"))
    top, bottom = float(bg.split()[4]), float(bg.split()[6])
    # the soil layer is deep enough that its PEC floor's echo is down 1e-3 at 55 MHz
    assert math.exp(-2 * soil_attenuation(Soil(2.5, 0.005), 55e6) * (top - bottom)) <= 1.001e-3
    plate_z = {p[4] for p in model.plates}
    assert min(plate_z) == pytest.approx(model.soil_top + 0.1)  # 'above': one cell up
    assert "55000000 75000000 97000000" in text


def test_refusals_name_what_is_wrong():
    with pytest.raises(SettingsError, match="cell"):
        FdtdSettings(cell=0.5)
    with pytest.raises(SettingsError, match="wavelength in the soil"):
        build_model(Design(Square(3.0), Soil(80.0, 0.02)), FdtdSettings(cell=0.2), 100e6)
    with pytest.raises(SettingsError, match="too nearly lossless"):
        soil_layer_depth(Soil(3.5, 0.0), 55e6)


def test_a_missing_gprmax_is_refused_before_any_work(monkeypatch):
    monkeypatch.delenv(fdtd_run.GPRMAX_ENV, raising=False)
    monkeypatch.setattr(fdtd_run, "find_spec", lambda name: None)
    solver = make_solver("fdtd", FdtdSettings(cell=0.1), use_cache=False)
    with pytest.raises(EngineError, match="pip install gprMax"):
        solver.solve(Design(None, FreeSpace()), [80.0])


def test_a_failing_gprmax_names_its_log(monkeypatch, tmp_path):
    monkeypatch.setenv(fdtd_run.GPRMAX_ENV, "python3 -c 'import sys; print(\"ValueError: broken model\"); sys.exit(3)'")
    with pytest.raises(SolveError, match=r"gprMax failed \(exit 3\): ValueError: broken model \(log: .*gprmax.log\)"):
        fdtd_run.run_gprmax("#title: x\n", tmp_path / "run", "test", 10)


def test_a_finished_run_is_read_again_not_rerun(monkeypatch, tmp_path):
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    text = "#title: done\n"
    (run_dir / "model.h5").write_bytes(b"")
    (run_dir / "done.json").write_text(json.dumps({"input_sha256": __import__("hashlib").sha256(text.encode()).hexdigest()}))

    def no_run(*a, **k):
        raise AssertionError("gprMax was started again")

    monkeypatch.setattr(fdtd_run.subprocess, "Popen", no_run)
    assert fdtd_run.run_gprmax(text, run_dir, "test", 10) == run_dir / "model.h5"
    (run_dir / "done.json").write_text(json.dumps({"input_sha256": "another input"}))
    with pytest.raises(AssertionError, match="started again"):
        fdtd_run.run_gprmax(text, run_dir, "test", 10)


needs_gprmax = pytest.mark.skipif(fdtd_run.find_spec("gprMax") is None and not fdtd_run.os.environ.get(fdtd_run.GPRMAX_ENV),
                                  reason="gprMax is not installed (pip install -e '.[test]' installs it)")


@needs_gprmax
def test_lossless_blade_radiates_what_it_accepts():
    """The blade alone in free space (10 cm cells): gprMax's gain (4 pi U / accepted power)
    integrated over both hemispheres here is 1 when nothing is lost, and the beam is the
    toolkit's (1-degree grid, input-power normalisation, impedance)."""
    solver = make_solver("fdtd", FdtdSettings(cell=0.1), use_cache=False)
    beam = solver.solve(Design(None, FreeSpace()), [60.0, 80.0, 100.0])
    assert beam.gain.shape == (3, 91, 360)
    assert np.allclose(beam.meta["energy_balance"], 1.0, atol=0.005)
    assert beam.gain_normalisation == "input_power"
    z = np.array(beam.meta["input_impedance_re"]) + 1j * np.array(beam.meta["input_impedance_im"])
    assert np.all(z.real > 10) and np.all(np.abs(z) < 200)
    # the E-plane (phi 0) pattern is the H-plane's narrower one: the blade's axis is x
    e, h = beam.gain[1, 60, 0], beam.gain[1, 60, 90]
    assert e < h


@needs_gprmax
def test_blade_over_pec_and_a_plate_on_soil(tmp_path, monkeypatch):
    """Over PEC nothing is lost; over MRO soil a 3 m plate loses what the shared referee
    measured at 5 cm (radiation efficiency 0.885 / 0.925 / 0.928 at 60 / 80 / 100 MHz) to a
    few points at 10 cm; the run is cached like any engine's."""
    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path))
    solver = make_solver("fdtd", FdtdSettings(cell=0.1))
    pec = solver.solve(Design(None, InfinitePEC()), [60.0, 100.0])
    assert np.allclose(pec.meta["energy_balance"], 1.0, atol=0.005)
    soil = solver.solve(Design(Square(3.0), Soil()), [60.0, 80.0, 100.0])
    assert np.allclose(soil.meta["energy_balance"], [0.885, 0.925, 0.928], atol=0.02)
    assert np.allclose(1.0 - np.array(soil.meta["energy_balance"]), soil.ground_loss(), atol=1e-9)
    assert solver.cached(Design(Square(3.0), Soil()), [60.0, 80.0, 100.0]) is not None
    assert not any(tmp_path.glob("fdtd/*/model.h5"))  # the bulky output goes once the beam is cached


def test_gprmax_flags_reach_the_run_and_the_cache_key(monkeypatch, tmp_path):
    """$GROUNDPLANE_GPRMAX_ARGS (e.g. -gpu 0) goes after the input file, and a run with other flags
    is another model: another cache key."""
    solver = make_solver("fdtd", FdtdSettings(cell=0.1))
    design = Design(None, FreeSpace())
    plain = solver.cache_key(design, [80.0])
    monkeypatch.setenv(fdtd_run.GPRMAX_ARGS_ENV, "-cpu_precision double")
    assert solver.cache_key(design, [80.0]) != plain
    seen = {}

    class Stop(Exception):
        pass

    def popen(args, **kw):
        seen["args"] = args
        raise Stop

    monkeypatch.setattr(fdtd_run.subprocess, "Popen", popen)
    with pytest.raises(Stop):
        fdtd_run.run_gprmax("#title: x\n", tmp_path / "run", "test", 10)
    assert seen["args"][-3:] == ["model.in", "-cpu_precision", "double"]


def test_a_grid_past_the_machine_is_refused_before_it_is_drawn(monkeypatch):
    """square-30 at 5 mm is 15 billion cells: refused from the outline's bounds, before any cell is
    rasterised (that alone would take minutes and gigabytes)."""
    import solvers.engines.fdtd.solver as fdtd_solver

    monkeypatch.setattr(fdtd_solver, "build_model", lambda *a, **k: pytest.fail("rasterised before the check"))
    solver = make_solver("fdtd", FdtdSettings(cell=0.005), use_cache=False)
    with pytest.raises(SettingsError, match=r"M cells of 0.005 m need over .* GiB; .* available. Use a coarser --cell"):
        solver.plan(Design(PRESETS["square-30"], Soil()))


def test_a_user_error_found_in_the_run_stays_a_user_error(monkeypatch):
    """A lossless soil is refused as the user's mistake (exit 2 from the CLI), not as a failed solve."""
    monkeypatch.setenv(fdtd_run.GPRMAX_ENV, "false")  # never reached
    solver = make_solver("fdtd", FdtdSettings(cell=0.1), use_cache=False)
    with pytest.raises(SettingsError, match="too nearly lossless .* an endless layer"):
        solver.solve(Design(Square(3.0), Soil(3.5, 0.0)), [60.0])
