"""Sweeps (resume after kill -9, invalid members, beam files, Dask), the optimiser's
constraint handling and NaN guard, and the report writer. Solves are a 3 m plate at a
1 m mesh and 8 frequencies: seconds each."""
import json
import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from groundplane.beam import Beam

from optimise.objective import EvalSettings
from optimise.report import write_report
from optimise.search import FAMILIES, optimise
from optimise.sweep import ConfigError, ResultStore, load_config, run_sweep

from .conftest import EXAMPLE_BEAM, ROOT

CHEAP = """
[solver]
mesh = 1.0
freqs = "55:97:6"
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
    assert settings.mesh.spacing == 1.0 and len(settings.freqs_mhz) == 8


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
    cmd = [sys.executable, "-m", "groundplane.cli", "sweep", str(cfg), "-o", str(out)]
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
    f = np.arange(55.0, 98.0, 6.0)
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


def _fake_eval(fom_of):
    calls = []

    def ev(candidate, settings):
        calls.append(candidate.plane)
        v = fom_of(candidate.plane)
        return {"status": "ok", "lst_averaged_fom_mk": v, "name": candidate.name}

    return ev, calls


def test_optimiser_respects_area_and_validity(tmp_path):
    # a made-up smooth FoM that always prefers more metal and longer teeth: the budget must bind
    ev, calls = _fake_eval(lambda p: 1000.0 / p.metal_area + 5.0 / p.tooth_height)
    res = optimise("sawtooth", 300.0, EvalSettings(), tmp_path, budget=60, integer_values=(3, 4),
                   evaluate_fn=ev, progress=False)
    assert calls, "the objective was never evaluated"
    for p in calls:  # only valid, in-budget designs ever reach the solver
        assert p.metal_area <= 300.0 * (1 + 1e-9)
        assert p.teeth_per_side * p.tooth_base <= p.side + 1e-9
    assert res.best["area_m2"] > 0.9 * 300.0  # the optimum sits on the budget
    lines = (tmp_path / "history.jsonl").read_text().splitlines()
    assert len(lines) == len(res.history) and json.loads((tmp_path / "best.json").read_text())


def test_optimiser_nan_guard_and_resume(tmp_path):
    seen = []

    def fom(p):  # the first design evaluated (the start point) breaks the solver: NaN
        seen.append(p.side)
        return float("nan") if p.side == seen[0] else 100.0 + (p.side - 12.0) ** 2
    ev, calls = _fake_eval(fom)
    res = optimise("square", 400.0, EvalSettings(), tmp_path, budget=25, evaluate_fn=ev, progress=False)
    statuses = {r["status"] for r in res.history}
    assert all(math.isfinite(r["objective"]) for r in res.history)
    assert res.history[0]["status"] == "failed" and res.history[0]["objective"] >= 1e4  # finite penalty
    assert "ok" in statuses
    assert res.best["fom_mk"] == pytest.approx(100.0, abs=0.5)
    n_first = len(calls)
    # an interrupted run resumes from its history: the same command evaluates nothing again
    ev2, calls2 = _fake_eval(fom)
    res2 = optimise("square", 400.0, EvalSettings(), tmp_path, budget=25, evaluate_fn=ev2, progress=False)
    assert calls2 == [] and res2.best == res.best and n_first > 0


def test_optimiser_rejects_bad_requests(tmp_path):
    with pytest.raises(ValueError, match="does not take the area constraint"):
        optimise("square", 100.0, EvalSettings(), tmp_path, algorithm="LN_NELDERMEAD")
    with pytest.raises(ValueError, match="unknown shape family"):
        optimise("hexagon", 100.0, EvalSettings(), tmp_path)
    with pytest.raises(ValueError, match="max-area"):
        optimise("square", float("nan"), EvalSettings(), tmp_path)


def test_every_family_start_is_valid_and_in_budget():
    for name, fam in FAMILIES.items():
        for n in fam.integer_values or (None,):
            x = np.clip(fam.start(600.0, n), fam.lower, fam.upper)
            assert fam.area(x, n) <= 600.0
            assert all(v(x, n) <= 0 for v in fam.validity)
            plane = fam.build(x, n)
            assert plane.metal_area == pytest.approx(fam.area(x, n))


def test_report_writer(tmp_path):
    rows = [
        {"name": "a", "status": "ok", "shape": "square", "params": {"side": 10.0}, "metal_area_m2": 100.0,
         "extent_m": 10.0, "lst_averaged_fom_mk": 300.0, "fom_mk": [200.0, 400.0], "lst_hours": [0.0, 12.0],
         "fit_freqs_mhz": [55.0, 60.0], "residuals_mk": {"2": [1.0, -1.0]}, "solve_s": 3.0},
        {"name": "b", "status": "ok", "shape": "plus", "params": {"arm": 5.0}, "metal_area_m2": 125.0,
         "extent_m": 15.0, "lst_averaged_fom_mk": 200.0, "fom_mk": [150.0, 250.0], "lst_hours": [0.0, 12.0],
         "fit_freqs_mhz": [55.0, 60.0], "residuals_mk": {"2": [2.0, -2.0]}, "solve_s": 4.0},
        {"name": "c", "status": "invalid", "shape": "sawtooth", "params": {}, "error": "teeth do not fit",
         "metal_area_m2": None, "extent_m": None, "lst_averaged_fom_mk": None},
    ]
    paths = write_report(rows, tmp_path, title="t")
    md = paths["md"].read_text()
    assert md.index("| 1 | b |") < md.index("| 2 | a |")  # ranked by FoM
    assert "teeth do not fit" in md
    for k in ("outlines", "fom_vs_lst", "residuals", "fom_vs_area"):
        assert paths[k].stat().st_size > 5000
    data = json.loads(paths["json"].read_text())
    assert [r["name"] for r in data] == ["b", "a", "c"]
    assert paths["csv"].read_text().splitlines()[1].startswith("1,b,ok")
    assert "<table" in paths["html"].read_text()


def test_design_study_table_conclusions_compare_mesh_and_retry(tmp_path, monkeypatch):
    """The reproduction on a stand-in solver: nine rows, a failed row retried on the rerun,
    NEC time read from the beam's own timings, and a second mesh's column and conclusions."""
    from dataclasses import replace

    import optimise.objective as objective
    from optimise.reproduce import DESIGN_STUDY, design_study
    from solvers.nec import MeshSettings

    f = np.arange(55.0, 98.0, 6.0)
    hb = Beam.load(EXAMPLE_BEAM)
    broken = {"sawtooth-15-12"}

    def fake_beam(candidate, settings, progress=False):
        if candidate.name in broken:
            raise RuntimeError("GEOMETRY DATA ERROR -- WIRE #5 INTERSECTS WIRE #6")
        # chromaticity falling with metal area and with mesh refinement, like the real thing
        amp = 0.02 * settings.mesh_settings().spacing * 100.0 / candidate.plane.metal_area
        g = np.repeat(hb.gain[:1], f.size, axis=0) * (1 + amp * np.sin(f / 3))[:, None, None]
        return Beam(f, hb.theta_deg, hb.phi_deg, g, meta={"seconds_per_frequency": [2.0] * f.size,
                                                           "n_segments": 100}), 0.0

    monkeypatch.setattr(objective, "candidate_beam", fake_beam)
    import optimise.reproduce as reproduce

    monkeypatch.setattr(reproduce, "pec_reference_fom", lambda settings, progress=False: 123.6)
    fine = EvalSettings(mesh=MeshSettings(spacing=0.7), freqs_mhz=tuple(f), fom=replace(EvalSettings().fom, n_lst=24))
    coarse = replace(fine, mesh=MeshSettings(spacing=1.0))
    table = design_study(fine, tmp_path, "groundplane reproduce design-study", progress=False)
    assert [t["preset"] for t in table] == [n for n, _ in DESIGN_STUDY]
    assert next(t for t in table if t["preset"] == "sawtooth-15-12")["status"] == "failed"
    assert "(i) cannot be tested yet" in (tmp_path / "design_study.md").read_text()
    broken.clear()  # the cause is fixed: rerunning retries only the failed row
    table = design_study(fine, tmp_path, "groundplane reproduce design-study", progress=False, compare=coarse)
    assert all(t["status"] == "ok" for t in table)
    assert all(t["solver_cpu_s"] == pytest.approx(2.0 * f.size) for t in table)
    md = (tmp_path / "design_study.md").read_text()
    assert "our FoM at 1 m (mK)" in md and "Same conclusions at 1 m" in md
    assert md.count("(i) larger area, lower FoM within a shape: **holds**") == 2
    assert "refining the mesh 1 -> 0.7 m moved it" in md
    assert "ours 123.6 mK vs the paper's 61.8 mK (x2.00)" in md
    rows = (tmp_path / "design_study_runs" / "results.jsonl").read_text().splitlines()
    assert len(rows) == 2 * 9 + 1  # 9 fine (one failed then retried) + 9 coarse, nothing redone


def test_config_and_cli_take_plate_height_and_a_finer_centre(tmp_path):
    from groundplane.cli import CLIError
    from solvers.cli import _refine

    cfg = tmp_path / "s.toml"
    cfg.write_text("[solver]\nmesh = 1.0\nplate_height = 0.03\nrefine_centre = [2.0, 4]\n"
                   "[[candidate]]\npreset = 'square-10'\n")
    _, _, settings = load_config(cfg)
    mesh = settings.mesh_settings()
    assert (mesh.plate_height, mesh.refine_half_width, mesh.refine_factor) == (0.03, 2.0, 4)
    assert _refine([2.0, 4.0]) == {"refine_half_width": 2.0, "refine_factor": 4}
    with pytest.raises(CLIError, match="whole number"):
        _refine([2.0, 2.5])
