"""The layered design's promise: a shape family, a beam format and a solver engine are
each added from outside the package (here, this test file alone) and every command picks
them up: shapes, export, sweep, optimise, fom and the design-study reproduction."""
import json
from dataclasses import asdict, dataclass, replace

import numpy as np
import pytest

from groundplane.beam import Beam
from groundplane.cli import main
from groundplane.options import option
from groundplane.shapes import SHAPES, GroundPlane, param
from solvers.engines import ENGINES, Plan, Solver, register_engine
from solvers.engines.base import SolveSettings
from solvers.io import FORMATS, BeamFormat, register_format

LIGHT = ["--freqs", "55:97:3", "--n-lst", "24"]


@pytest.fixture
def toy_family():
    """A rectangle family declared here and nowhere else."""

    class Rectangle(GroundPlane, kind="toy-rectangle"):
        length: float = param("length along the excitation axis (m)", bounds=(2.0, 20.0))
        width: float = param("width across the excitation axis (m)", bounds=(2.0, 20.0))

        def _vertices(self):
            a, b = self.length / 2, self.width / 2
            return np.array([[-a, -b], [a, -b], [a, b], [-a, b]])

        @classmethod
        def area_of(cls, p):
            return p["length"] * p["width"]

    yield Rectangle
    SHAPES.pop("toy-rectangle")


@dataclass(frozen=True)
class StandInSettings:
    ripple: float = option(0.02, "relative spectral ripple of a 100 m^2 plate (stand-in engine)")

    def as_dict(self):
        return asdict(self)


def stand_in_gain(model: tuple[float, float], freq: float) -> tuple[np.ndarray, dict[str, float]]:
    """The stand-in's physics (in a worker process): a 2 cos^2 beam whose ripple in frequency
    falls with metal area; ``model`` is (metal area, ripple of a 100 m^2 plate)."""
    area_m2, ripple = model
    amp = ripple * 100.0 / area_m2
    th = np.arange(91.0)
    g = 2 * np.cos(np.radians(th)) ** 2 * (1 + amp * np.sin(freq / 3))
    return np.repeat(g[:, None], 91, axis=1), {}


@pytest.fixture
def stand_in_engine():
    """A second engine writes only its physics: a Solver subclass with its identity and its
    plan (the base caches, resumes and runs the workers). Chromaticity falls with metal area."""

    @register_engine
    class StandIn(Solver):
        name = "stand-in"
        settings_class = StandInSettings
        grounds = ("soil", "pec")
        solved: list = []

        def engine_identity(self):
            return {"engine": "stand-in", "version": "1"}

        def plan(self, design):
            StandIn.solved.append(design.label())
            area = design.plane.metal_area if design.plane is not None else 1e4
            return Plan(stand_in_gain, (area, self.settings.ripple), 91, {"n_segments": 0}, f"stand-in {design.label()}")

    yield StandIn
    ENGINES.pop("stand-in")


def test_toy_family_in_shapes_export_sweep_and_optimiser(toy_family, stand_in_engine, tmp_path, capsys):
    assert main(["shapes"]) == 0
    assert "toy-rectangle (length, width)" in capsys.readouterr().out
    stl = tmp_path / "r.stl"
    assert main(["export", "toy-rectangle", "--length", "4", "--width", "3", "-o", str(stl)]) == 0
    assert "metal area 12.00 m^2" in capsys.readouterr().out and stl.stat().st_size > 0
    assert main(["export", "toy-rectangle", "--length", "4", "-o", str(stl)]) == 2
    assert "toy-rectangle needs --width" in capsys.readouterr().err
    cfg = tmp_path / "s.toml"
    cfg.write_text('[solver]\nengine = "stand-in"\nripple = 0.05\nfreqs = "55:97:3"\n[fom]\nn_lst = 24\n'
                   '[[family]]\nshape = "toy-rectangle"\nlength = [4, 8]\nwidth = 5\n')
    assert main(["sweep", str(cfg), "-o", str(tmp_path / "sweep")]) == 0
    rows = {r["name"]: r for r in json.loads((tmp_path / "sweep" / "results.json").read_text())}
    assert set(rows) == {"toy-rectangle-4-5", "toy-rectangle-8-5"}
    assert rows["toy-rectangle-8-5"]["lst_averaged_fom_mk"] < rows["toy-rectangle-4-5"]["lst_averaged_fom_mk"]
    capsys.readouterr()
    # the stand-in's 2 cos^2 beam loses 2/3 of its power by the loss's definition: scored as the paper scores
    rc = main(["optimise", "--shape", "toy-rectangle", "--max-area", "60", "--budget", "8", "--engine", "stand-in",
               "--scenarios", "nominal", "--max-loss", "none", *LIGHT, "-o", str(tmp_path / "opt")])
    assert rc == 0, capsys.readouterr().err
    best = json.loads((tmp_path / "opt" / "best.json").read_text())
    assert best["area_m2"] <= 60 * (1 + 1e-9) and set(best["params"]) == {"length", "width"}
    assert any("toy-rectangle" not in s and "Rectangle(" in s for s in stand_in_engine.solved)


def test_toy_beam_format_read_by_fom(tmp_path, capsys):
    def read(paths):
        lo, hi, step = (float(v) for v in paths[0].read_text().split()[1:4])
        f = np.arange(lo, hi + step / 2, step)
        th, ph = np.arange(91.0), np.arange(0.0, 360.0, 2.0)
        g = 2 * np.cos(np.radians(th))[None, :, None] ** 2 * (1 + 0.01 * np.sin(f / 4))[:, None, None]
        return Beam(f, th, ph, np.repeat(g, ph.size, axis=2), {"source": str(paths[0]), "format": "toy"})

    register_format(BeamFormat("toy", sniff=lambda head: head.startswith(b"TOYBEAM"), read=read))
    try:
        path = tmp_path / "beam.toy"
        path.write_text("TOYBEAM 50 100 1\n")
        assert main(["fom", str(path), "--format", "toy", "--n-lst", "24"]) == 0
        assert "mK  LST-averaged FoM of" in capsys.readouterr().out
        assert main(["fom", str(path), "--n-lst", "24", "--json"]) == 0  # found by content too
        assert json.loads(capsys.readouterr().out)["beam"]["format"] == "toy"
        assert Beam.from_file(path).meta["format"] == "toy"
    finally:
        FORMATS.pop("toy")


def test_stand_in_solver_runs_the_design_study(stand_in_engine, tmp_path):
    from optimise.evaluate import EvalSettings
    from optimise.studies import run_study

    settings = EvalSettings(solve=SolveSettings(engine="stand-in", freqs_mhz=tuple(np.arange(55.0, 98.0, 3.0))),
                            model=StandInSettings())
    settings = replace(settings, fom=settings.fom.__class__(n_lst=24))
    run_study("design-study", tmp_path, settings)
    md = (tmp_path / "design_study.md").read_text()
    import csv

    from optimise.studies.design_study import conclusions

    table = [{**r, "our_fom_mk": float(r["our_fom_mk"])} for r in csv.DictReader(open(tmp_path / "design_study.csv"))]
    assert len(table) == 9 and all(line in md for line in conclusions(table))  # the verdicts of these rows
    assert "blade dipole over infinite PEC ground" in stand_in_engine.solved  # the PEC reference row
    assert len([s for s in stand_in_engine.solved if "soil" in s]) == 9
