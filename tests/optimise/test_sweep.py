"""Sweeps (resume after kill -9, invalid members, beam files, Dask), the optimiser's
constraint handling and NaN guard, and the report writer. Solves are a 3 m plate at a
1 m mesh and 8 frequencies: seconds each."""
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from groundplane.beam import Beam
from optimise.sweep import ConfigError, ResultStore, load_config, run_sweep
from solvers.engines.base import SolveSettings
from tests.conftest import EXAMPLE_BEAM, ROOT

CHEAP = """
[solver]
mesh = 1.0
freqs = "55:97:4"
[fom]
n_lst = 24
"""



def write_cfg(tmp_path, body):
    p = tmp_path / "sweep.toml"
    p.write_text(CHEAP + body)
    return p

def test_config_expands_families_and_reports_invalid_members(tmp_path):
    cfg = write_cfg(tmp_path, """
[[candidate]]
preset = "square-10"
[[family]]
shape = "sawtooth"
side = [3, 4]
teeth_per_side = [1, 3]
tooth_base = 1.5
tooth_height = 1
""")
    cands, invalid, settings = load_config(cfg)
    assert [c.name for c in cands] == ["square-10", "sawtooth-3-1-1.5-1", "sawtooth-4-1-1.5-1"]
    assert len(invalid) == 2 and "use teeth_per_side" in invalid[0]["error"]
    assert settings.model.spacing == 1.0 and len(settings.freqs_mhz) == 11

@pytest.mark.parametrize("body,msg", [
    ("[[candidate]]\nshape = 'hexagon'\n", "unknown shape"),
    ("[[candidate]]\npreset = 'square-10'\n[[candidate]]\npreset = 'square-10'\n", "unique"),
    ("[bogus]\n", "unknown table"),
    ("", "no candidates"),
    ("[[candidate]]\nshape = 'square'\nside = -1\n", r"#1: Square: side must be a positive"),
    ("fit_bnad = [55, 97]\n", r"\[fom\]: unknown key\(s\) \['fit_bnad'\]"),  # lands in CHEAP's [fom]
])
def test_bad_config_names_the_entry(tmp_path, body, msg):
    with pytest.raises(ConfigError, match=msg):
        load_config(write_cfg(tmp_path, body))

def test_sweep_resumes_after_kill_9(tmp_path):
    cfg = write_cfg(tmp_path, "".join(f"[[candidate]]\nname = 'sq{s}'\nshape = 'square'\nside = {s}\n" for s in (2, 3, 4)))
    out = tmp_path / "out"
    env = {**os.environ, "GROUNDPLANE_CACHE": str(tmp_path / "cache")}
    cmd = [sys.executable, "-m", "groundplane", "sweep", str(cfg), "-o", str(out)]
    proc = subprocess.Popen(cmd, env=env, cwd=ROOT, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    jsonl = out / "results.jsonl"
    t0 = time.time()
    while time.time() - t0 < 300 and not (jsonl.exists() and jsonl.read_text().count("\n") >= 1):
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGKILL)  # the whole group: sweep and its NEC workers
    proc.wait()
    first = [json.loads(l) for l in jsonl.read_text().splitlines()]
    assert 1 <= len(first) < 3, "the kill should land mid-sweep"
    rerun = subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert rerun.returncode == 0, rerun.stderr
    rows = [json.loads(l) for l in jsonl.read_text().splitlines()]
    names = [r["name"] for r in rows]
    assert sorted(names) == ["sq2", "sq3", "sq4"]  # every candidate once: none lost, none redone
    assert rows[: len(first)] == first
    assert (out / "report.md").exists() and (out / "results.csv").exists()

def test_sweep_ranks_a_beam_file_with_solved_candidates(tmp_path, monkeypatch):
    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "cache"))
    f = np.arange(55.0, 98.0, 4.0)
    hb = Beam.load(EXAMPLE_BEAM)
    fake = Beam(f, hb.theta_deg, hb.phi_deg, np.repeat(hb.gain[:1], f.size, axis=0) * (1 + 0.01 * np.sin(f / 3))[:, None, None])
    fake.save(tmp_path / "export.npz")
    cfg = write_cfg(tmp_path, "[[candidate]]\nshape = 'square'\nside = 2\n"
                              "[[candidate]]\nname = 'from-feko'\nbeam = 'export.npz'\nmetal_area_m2 = 4\n")
    cands, invalid, settings = load_config(cfg)
    rows = run_sweep(cands, settings, tmp_path / "out", progress=False)
    assert {r["name"]: r["status"] for r in rows} == {"square-2": "ok", "from-feko": "ok"}
    assert next(r for r in rows if r["name"] == "from-feko")["metal_area_m2"] == 4
    again = run_sweep(cands, settings, tmp_path / "out", progress=False)
    assert len(ResultStore(tmp_path / "out").path.read_text().splitlines()) == 2  # nothing redone
    assert [r["lst_averaged_fom_mk"] for r in again] == [r["lst_averaged_fom_mk"] for r in rows]

def test_sweep_on_dask_local_cluster(tmp_path, monkeypatch):
    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "cache"))
    cfg = write_cfg(tmp_path, "[[candidate]]\nshape = 'square'\nside = 2\n[[candidate]]\nshape = 'plus'\narm = 1\n")
    cands, _, settings = load_config(cfg)
    rows = run_sweep(cands, settings, tmp_path / "out", executor="dask", progress=False)
    assert all(r["status"] == "ok" for r in rows) and len(rows) == 2
    local = run_sweep(cands, settings, tmp_path / "local", progress=False)  # solves are cached by now
    assert [r["lst_averaged_fom_mk"] for r in rows] == pytest.approx([r["lst_averaged_fom_mk"] for r in local])

def test_config_and_cli_take_plate_height_and_a_finer_centre(tmp_path):
    from groundplane.cli import build_parser
    from optimise.cli import eval_settings

    cfg = tmp_path / "s.toml"
    cfg.write_text("[solver]\nengine = 'nec'\nmesh = 1.0\nplate_height = 0.03\nrefine_centre = [2.0, 4]\n"
                   "[[candidate]]\npreset = 'square-10'\n")
    _, _, settings = load_config(cfg)
    mesh = settings.model
    assert (mesh.plate_height, mesh.refine_half_width, mesh.refine_factor) == (0.03, 2.0, 4)
    args = build_parser().parse_args(["optimise", "--engine", "nec", "--shape", "square", "--max-area", "100", "-o",
                                      "x", "--refine-centre", "2", "4", "--plate-height", "0.03"])
    mesh = eval_settings(args).model
    assert (mesh.plate_height, mesh.refine_half_width, mesh.refine_factor) == (0.03, 2.0, 4)
    args = build_parser().parse_args(["optimise", "--engine", "nec", "--shape", "square", "--max-area", "100", "-o",
                                      "x", "--refine-centre", "2", "2.5"])
    with pytest.raises(ConfigError, match="whole number"):
        eval_settings(args)


def test_sweep_exits_non_zero_when_a_candidate_failed(tmp_path, monkeypatch, capsys):
    from groundplane.cli import main

    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "cache"))
    hb = Beam.load(EXAMPLE_BEAM)
    f = np.arange(55.0, 80.0, 6.0)  # stops short of the 55-97 MHz fit band: cannot be scored
    Beam(f, hb.theta_deg, hb.phi_deg, np.repeat(hb.gain[:1], f.size, axis=0)).save(tmp_path / "short.npz")
    cfg = write_cfg(tmp_path, "[[candidate]]\nname = 'short'\nbeam = 'short.npz'\nmetal_area_m2 = 4\n")
    assert main(["sweep", str(cfg), "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert "1 candidate(s) failed (short)" in err and "--retry-failed" in err


def test_frequencies_that_cannot_be_scored_are_refused_before_any_solve(tmp_path, monkeypatch):
    from groundplane.cli import main
    from solvers.engines.nec import NecSolver

    monkeypatch.setattr(NecSolver, "solve", lambda *a, **k: (_ for _ in ()).throw(AssertionError("solved")))
    cfg = tmp_path / "s.toml"
    cfg.write_text('[solver]\nmesh = 1.0\nfreqs = "150:200:5"\n[[candidate]]\npreset = "square-10"\n')
    with pytest.raises(Exception, match=r"cannot be scored: the beam covers 150-200 MHz but the fit band is 55-97"):
        run_sweep(*load_config(cfg)[::2], tmp_path / "out", progress=False)
    assert main(["optimise", "--shape", "square", "--max-area", "100", "--freqs", "150:200:5",
                 "-o", str(tmp_path / "opt")]) == 2


@pytest.mark.parametrize("body,msg", [
    ('[fom]\nnormalise = "false"\n', r"normalise: expected true or false, got 'false'"),
    ("[solver]\nmesh = true\n", r"mesh: expected a number, got True"),
    ("[fom]\nn_lst = 3.7\n", r"n_lst: expected a whole number, got 3.7"),
    ('[fom]\nfit_band = "55"\n', r"fit_band: expected a number, got the string '55'"),
    ("[[candidate]]\npreset = 'square-10'\nside = 3\n", r"preset"),
])
def test_toml_values_are_type_checked_not_coerced(tmp_path, body, msg):
    p = tmp_path / "s.toml"
    p.write_text(body + ("" if "candidate" in body else "[[candidate]]\npreset = 'square-10'\n"))
    with pytest.raises(ConfigError, match=msg):
        load_config(p)


def test_an_engine_that_cannot_solve_on_soil_is_refused_before_any_solve(monkeypatch):
    """Candidates lie on soil: an engine that does not declare soil among its grounds is
    refused with one line naming the way out (every shipped engine solves on soil today)."""
    from groundplane.errors import UserInputError
    from optimise.evaluate import EvalSettings
    from solvers.engines.surface import SurfaceSolver

    EvalSettings(solve=SolveSettings(engine="surface")).check_scorable()
    monkeypatch.setattr(SurfaceSolver, "grounds", ("pec", "free"))
    with pytest.raises(UserInputError, match=r"solves over pec, free ground only.*use --engine fdtd or --engine nec \(or"):
        EvalSettings(solve=SolveSettings(engine="surface")).check_scorable()  # the way out from the declarations


@pytest.mark.parametrize("toml, message", [
    ('[solver]\nmesh = "1.0"\n[[candidate]]\npreset = "square-10"\n', "mesh: expected a number, got the string '1.0'"),
    ('[solver]\nworkers = "2"\n[[candidate]]\npreset = "square-10"\n', "workers: expected a number, got the string"),
    ('[[family]]\nshape = "square"\nsid = [10]\n', "square has no parameter(s) ['sid']; it takes ['side']"),
    ('[[candidate]]\nname = 123\npreset = "square-10"\n', "name must be a string, got 123"),
])
def test_sweep_files_are_checked_before_any_solve(tmp_path, capsys, toml, message):
    """Issue 25 item 7: each of these solved (or said 'no candidates') before failing."""
    from groundplane.cli import main

    cfg = tmp_path / "s.toml"
    cfg.write_text(toml)
    assert main(["sweep", str(cfg), "-o", str(tmp_path / "out")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out" / "results.jsonl").exists()


def test_optimise_compare_names_are_checked_before_the_search(tmp_path, capsys):
    from groundplane.cli import main

    assert main(["optimise", "--shape", "square", "--max-area", "100", "--compare", "sqaure-10",
                 "-o", str(tmp_path / "o")]) == 2
    assert "unknown preset 'sqaure-10'" in capsys.readouterr().err and not (tmp_path / "o").exists()


def test_eval_settings_refuse_an_unknown_engine_and_a_model_of_another_engine():
    from groundplane.errors import UserInputError
    from optimise.evaluate import EvalSettings
    from solvers.engines.nec import NecSettings

    with pytest.raises(UserInputError, match="engine 'foo': choose one of"):
        EvalSettings(solve=SolveSettings(engine="foo"))
    with pytest.raises(UserInputError, match="engine surface takes SurfaceSettings model settings, got NecSettings"):
        EvalSettings(model=NecSettings())
    assert EvalSettings(solve=SolveSettings(engine="nec"), model=NecSettings(spacing=0.7)).spacing == 0.7
