"""Sweeps (resume after kill -9, invalid members, beam files, Dask), the optimiser's
constraint handling and NaN guard, and the report writer. Solves are a 3 m plate at a
1 m mesh and 8 frequencies: seconds each."""
import json
import math

import numpy as np
import pytest

from optimise.evaluate import EvalSettings
from optimise.search import family, optimisable, optimise
from solvers.engines.base import SolveSettings

CHEAP = """
[solver]
mesh = 1.0
freqs = "55:97:4"
[fom]
n_lst = 24
"""



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
    res = optimise("square", 400.0, EvalSettings(), tmp_path, budget=25, evaluate_fn=ev, progress=False,
                   strategy="local")
    statuses = {r["status"] for r in res.history}
    assert all(math.isfinite(r["objective"]) for r in res.history)
    assert res.history[0]["status"] == "failed" and res.history[0]["objective"] >= 1e4  # finite penalty
    assert "ok" in statuses
    assert res.best["fom_mk"] == pytest.approx(100.0, abs=0.5)
    n_first = len(calls)
    # an interrupted run resumes from its history: the same command evaluates nothing again
    ev2, calls2 = _fake_eval(fom)
    res2 = optimise("square", 400.0, EvalSettings(), tmp_path, budget=25, evaluate_fn=ev2, progress=False,
                    strategy="local")
    assert calls2 == [] and res2.best == res.best and n_first > 0

def test_optimiser_rejects_bad_requests(tmp_path):
    with pytest.raises(ValueError, match="does not take the area constraint"):
        optimise("square", 100.0, EvalSettings(), tmp_path, algorithm="LN_NELDERMEAD")
    with pytest.raises(ValueError, match="unknown shape family"):
        optimise("hexagon", 100.0, EvalSettings(), tmp_path)
    with pytest.raises(ValueError, match="max-area"):
        optimise("square", float("nan"), EvalSettings(), tmp_path)

def test_every_family_start_is_valid_and_in_budget():
    assert set(optimisable()) == {"square", "plus", "sawtooth", "polygon-n", "star", "teeth", "teeth-xy"}
    for name in optimisable():
        fam = family(name)
        for n in fam.integer_values or (None,):
            x = np.clip(fam.start(600.0, n), fam.lower, fam.upper)
            assert fam.area(x, n) <= 600.0
            assert all(v <= 0 for v in fam.validity(x, n))
            plane = fam.build(x, n)
            assert plane.metal_area == pytest.approx(fam.area(x, n))



def test_small_features_are_refused_and_the_answer_is_confirmed_at_a_finer_mesh(tmp_path):
    """The search may not exploit the wire grid (teeth or gaps under two cells are invalid),
    and its answer is the best of its top few re-solved at the finer mesh, saying so."""
    from optimise.search import too_fine_for

    coarse = EvalSettings(solve=SolveSettings(engine="nec"))  # the wire grid, whose node merging moves short edges
    spacing = coarse.model.spacing

    def fom(p, s):  # a model artefact: the coarse mesh flatters narrow teeth, the fine one does not
        return 100.0 + p.tooth_base * (1.0 if s.model.spacing < spacing else -1.0)

    calls = []

    def ev(candidate, settings):
        calls.append((candidate.plane, settings.model.spacing))
        return {"status": "ok", "lst_averaged_fom_mk": fom(candidate.plane, settings), "name": candidate.name}

    res = optimise("sawtooth", 300.0, coarse, tmp_path, budget=40, integer_values=(3,), evaluate_fn=ev,
                   progress=False, confirm_mesh=0.7 * spacing, confirm_top=3)
    for plane, sp in calls:
        assert too_fine_for(plane, sp) is None or sp < spacing
    fine = [c for c in calls if c[1] < spacing]
    assert 1 <= len(fine) <= 3 and res.best["confirmed_at"] == pytest.approx(0.7 * spacing)
    assert res.best["fom_mk"] == min(r["fom_mk"] for r in res.confirmed)
    assert res.best["search_fom_mk"] != res.best["fom_mk"]
    # resumable: the confirmation is not solved again
    n = len(calls)
    optimise("sawtooth", 300.0, coarse, tmp_path, budget=40, integer_values=(3,), evaluate_fn=ev, progress=False,
             confirm_mesh=0.7 * spacing, confirm_top=3)
    assert len(calls) == n


def test_a_short_outline_edge_is_refused_on_the_wire_grid_only():
    """The 600 m^2 search's first sawtooth has a 0.43 m corner edge: the NEC grid (nodes merge
    within 0.3 cells) cannot place it at a 1 m mesh, the surface engine's conforming
    triangulation keeps it; a tooth under two cells wide is refused by both."""
    from groundplane.shapes import Sawtooth
    from optimise.search import smallest_feature, too_fine_for

    plane = Sawtooth(side=17.320508075688775, teeth_per_side=4, tooth_base=3.4641016151377553,
                     tooth_height=6.495190528383288)
    edge, span = smallest_feature(plane)
    assert edge == pytest.approx(0.433, abs=1e-3) and span == pytest.approx(3.464, abs=1e-3)
    from solvers.engines import make_solver
    from solvers.engines.nec import NecSettings
    from solvers.engines.surface import SurfaceSettings

    nec, surface = make_solver("nec", NecSettings(spacing=1.0)), make_solver("surface", SurfaceSettings(spacing=1.0))
    assert too_fine_for(plane, 1.0) is None
    assert "outline edge" in nec.why_unresolved(plane)
    assert surface.why_unresolved(plane) is None
    assert "under two mesh cells" in too_fine_for(plane, 1.8)


def test_a_search_resumed_with_other_settings_is_refused_and_a_new_confirm_mesh_resolves(tmp_path):
    """history.jsonl is keyed by design only: resuming it with another mesh or FoM would
    replay its FoMs as if solved with the new settings, so the directory refuses, naming the
    difference; confirm rows at one mesh are not reused for another."""
    from dataclasses import replace

    from groundplane.errors import UserInputError

    base = EvalSettings()
    sp = base.model.spacing
    calls = []

    def ev(candidate, settings):
        calls.append(settings.model.spacing)
        return {"status": "ok", "lst_averaged_fom_mk": 100.0 + candidate.plane.tooth_base, "name": candidate.name}

    kw = dict(budget=6, integer_values=(3,), evaluate_fn=ev, progress=False, confirm_top=1)
    optimise("sawtooth", 300.0, base, tmp_path, confirm_mesh=0.7 * sp, **kw)
    n = len(calls)
    with pytest.raises(UserInputError, match=r"other settings \(settings\.mesh\.spacing: 0\.5 -> 1\.0"):
        optimise("sawtooth", 300.0, base.with_spacing(1.0), tmp_path, confirm_mesh=0.7, **kw)
    with pytest.raises(UserInputError, match="lst_bin"):
        optimise("sawtooth", 300.0, replace(base, fom=replace(base.fom, lst_bin_hours=0.0)), tmp_path, **kw)
    assert len(calls) == n  # nothing solved by a refused run
    res = optimise("sawtooth", 300.0, base, tmp_path, confirm_mesh=0.7 * sp, **kw)  # same settings: all replayed
    assert len(calls) == n and res.best["confirmed_at"] == pytest.approx(0.7 * sp)
    res = optimise("sawtooth", 300.0, base, tmp_path, confirm_mesh=0.5 * sp, **kw)  # a new confirm mesh re-solves
    assert calls[n:] == [pytest.approx(0.5 * sp)] and res.best["confirmed_at"] == pytest.approx(0.5 * sp)


def test_a_search_solved_by_another_model_version_is_refused_and_an_unrecorded_one_is_upgraded(tmp_path, monkeypatch,
                                                                                               capsys):
    """search.json records the engine's model version: its FoMs are that model's, so a resume
    under another one is refused by name; one written before the version was recorded takes
    today's, and says so."""
    from groundplane.errors import UserInputError
    from solvers.engines import ENGINES

    calls = []

    def ev(candidate, settings):
        calls.append(candidate.name)
        return {"status": "ok", "lst_averaged_fom_mk": 100.0 + candidate.plane.tooth_base, "name": candidate.name}

    kw = dict(budget=4, integer_values=(3,), evaluate_fn=ev, progress=False, confirm_top=0)
    optimise("sawtooth", 300.0, EvalSettings(), tmp_path, **kw)
    meta = json.loads((tmp_path / "search.json").read_text())
    version = ENGINES["surface"].model_version
    assert meta["model"] == {"engine": "surface", "version": version}
    n = len(calls)
    monkeypatch.setattr(ENGINES["surface"], "model_version", version + 1)
    with pytest.raises(UserInputError, match=rf"model\.version: {version} -> {version + 1}"):
        optimise("sawtooth", 300.0, EvalSettings(), tmp_path, **kw)
    monkeypatch.undo()
    del meta["model"]  # as written before the version was recorded
    (tmp_path / "search.json").write_text(json.dumps(meta))
    optimise("sawtooth", 300.0, EvalSettings(), tmp_path, **kw)
    assert "no model version recorded; recorded now as surface model" in capsys.readouterr().err
    assert json.loads((tmp_path / "search.json").read_text())["model"]["version"] == version and len(calls) == n


def test_thin_strips_are_too_fine_for_the_mesh():
    """Long teeth a cell wide have no sharp vertex for the spike rule; the opening catches them,
    and leaves the paper's presets alone."""
    from groundplane.shapes import PRESETS, Teeth
    from optimise.search import thin_fraction, too_fine_for

    arms = Teeth(5.479, 1, 1.103, 8.664, 0.403)  # found by a search at 1 m: 70 mK there
    assert thin_fraction(arms, 1.0) > 0.4 and "narrower than two mesh cells" in too_fine_for(arms, 1.0)
    assert too_fine_for(arms, 0.25) is None
    for name, plane in PRESETS.items():
        assert thin_fraction(plane, 1.0) < 0.01, name


def test_a_neck_narrower_than_the_mesh_is_refused_and_a_history_holding_one_is_held_to_it(tmp_path, capsys):
    """A tooth on a neck narrower than two cells (the robust front's 400 m^2 answer of 2026-12-02: 10.7 m spikes on
    4.7 cm necks) holds little area, so the thin share missed it; how far the thin metal reaches does not. A
    history solved before the rule is replayed with such rows refused: never the best, the file untouched."""
    from groundplane.shapes import PRESETS, from_dict
    from optimise.search import MAX_STRANDED_CELLS, stranded_metal, thin_fraction, too_fine_for

    spikes = dict(shape="teeth-xy", side=19.65, teeth_per_side=4, chamfer=1.09, base_x=2.73, height_x=0.73,
                  tip_x=0.65, base_y=1.95, height_y=0.0, tip_y=0.31, base_d=0.047, height_d=10.65, tip_d=0.30)
    plane = from_dict(spikes)
    reach, (x, y) = stranded_metal(plane, 0.7)
    assert thin_fraction(plane, 0.7) < 0.10 and reach > 10 and abs(x) > 14 and abs(y) > 14
    assert "reaches 10." in too_fine_for(plane, 0.7)
    for name, preset in PRESETS.items():
        assert stranded_metal(preset, 0.7)[0] <= MAX_STRANDED_CELLS * 0.7 and too_fine_for(preset, 0.7) is None, name
    square = from_dict(dict(shape="teeth-xy", side=19.0, teeth_per_side=4, chamfer=0.0, base_x=2.0, height_x=0.0,
                            tip_x=0.0, base_y=2.0, height_y=0.0, tip_y=0.0, base_d=0.0, height_d=0.0, tip_d=0.0))
    fam = family("teeth-xy")

    def row(p, fom):
        x = [p.params()[k] for k in fam.names]
        return {"integer": 4, "x": x, "area_m2": p.metal_area, "status": "ok", "fom_mk": fom, "objective": fom,
                "phase": "explore", "mesh_m": 0.7, "feasible": True}
    ev, calls = _fake_eval(lambda p: 500.0)
    optimise("teeth-xy", 400.0, EvalSettings().with_spacing(0.7), tmp_path, budget=1, evaluate_fn=ev,
             progress=False, integer_values=(4,))
    lines = [json.dumps(row(plane, 50.0)), json.dumps(row(square, 400.0))]
    with open(tmp_path / "history.jsonl", "a") as f:
        f.write("\n".join(lines) + "\n")
    before = (tmp_path / "history.jsonl").read_text()
    res = optimise("teeth-xy", 400.0, EvalSettings().with_spacing(0.7), tmp_path, budget=1,
                   evaluate_fn=ev, progress=True, integer_values=(4,))
    assert res.best is None or res.best["fom_mk"] != 50.0
    assert "refused by today's checks" in capsys.readouterr().err
    assert (tmp_path / "history.jsonl").read_text().startswith(before)


def test_history_lines_of_the_wrong_shape_are_evaluated_again(tmp_path, capsys):
    """Issue 25 item 8: valid JSON of the wrong shape in history.jsonl was a traceback."""
    ev, calls = _fake_eval(lambda p: 100.0 + (p.side - 12.0) ** 2)
    optimise("square", 400.0, EvalSettings(), tmp_path, budget=6, evaluate_fn=ev, progress=False, strategy="local")
    n = len(calls)
    with open(tmp_path / "history.jsonl", "a") as fh:
        fh.write('{"x": "abc", "integer": null, "status": "ok"}\n[1, 2, 3]\n{"x": [1.0], "objective": "NaN"}\n')
    ev2, calls2 = _fake_eval(lambda p: 100.0 + (p.side - 12.0) ** 2)
    res = optimise("square", 400.0, EvalSettings(), tmp_path, budget=6, evaluate_fn=ev2, progress=False,
                   strategy="local")
    assert calls2 == [] and res.best is not None and n > 0  # the good rows replayed, nothing solved again
    assert "line(s) are not history rows and are ignored" in capsys.readouterr().err


def test_the_search_itself_refuses_a_seed_it_could_not_use(tmp_path):
    """Seeds outside the family or the budget are refused by optimise(), not skipped silently."""
    from groundplane.errors import UserInputError
    from groundplane.shapes import Square

    def ev(c, s):
        raise AssertionError("nothing may be solved")
    with pytest.raises(UserInputError, match="--seed big: not a square design within the bounds and the 50 m"):
        optimise("square", 50.0, EvalSettings(), tmp_path, budget=4, evaluate_fn=ev, progress=False,
                 seeds={"big": Square(10.0)})
    with pytest.raises(UserInputError, match="--seed needs --strategy global"):
        optimise("square", 500.0, EvalSettings(), tmp_path, budget=4, evaluate_fn=ev, progress=False,
                 seeds={"big": Square(10.0)}, strategy="local")



def test_explore_spends_the_global_stage_on_the_seeds_alone_and_is_part_of_the_search(tmp_path):
    """--explore N: the global stage solves N designs, the seeds first (no space-filling sample when
    the seeds fill it), then refines from them; a resume asking another N is refused, and an N the
    search cannot spend is refused before any solve."""
    from groundplane.errors import UserInputError
    from groundplane.shapes import Square

    ev, calls = _fake_eval(lambda p: 100.0 + (p.side - 12.0) ** 2)
    seeds = {"eleven": Square(11.0), "thirteen": Square(13.0)}
    res = optimise("square", 400.0, EvalSettings(), tmp_path, budget=20, evaluate_fn=ev, progress=False,
                   seeds=seeds, explore=2)
    phases = [r["phase"] for r in res.history if r["status"] == "ok"]
    assert phases[:2] == ["seed", "seed"] and "explore" not in phases  # the two seeds, no Sobol sample
    assert phases[2].startswith("refine") and len(calls) > 2
    assert res.best["fom_mk"] < 101.0  # the refinement from the seeds found the optimum (side 12)
    with pytest.raises(UserInputError, match="another search|differs|explore"):  # another share: another path
        optimise("square", 400.0, EvalSettings(), tmp_path, budget=20, evaluate_fn=ev, progress=False,
                 seeds=seeds, explore=3)
    for bad in (0, 11):
        with pytest.raises(UserInputError, match=f"--explore {bad}: the global stage's solves must lie between 1"):
            optimise("square", 400.0, EvalSettings(), tmp_path / "bad", budget=10, evaluate_fn=ev, progress=False,
                     explore=bad)
    default = optimise("square", 400.0, EvalSettings(), tmp_path / "default", budget=10, evaluate_fn=ev,
                       progress=False, seeds=seeds)
    assert "explore" in [r["phase"] for r in default.history]  # 60 % of 10: the seeds and a Sobol sample

def _teeth_xy_x(fam, **p):
    base = dict(side=16.0, chamfer=0.0, base_x=3.0, height_x=4.0, tip_x=0.0, base_y=3.0, height_y=0.0, tip_y=0.0,
                base_d=0.0, height_d=0.0, tip_d=0.0)
    return np.array([{**base, **p}[k] for k in fam.names])


def test_a_plane_met_again_under_other_parameters_is_not_solved_again(tmp_path):
    """The robust front's until-flat phase re-solved one plane at 80-140 s a time: teeth of height
    0 whose base the optimiser moved. The same outline is now the same row, and costs no solve."""
    from optimise.search import History, _Evaluator, flat_over_last_half

    fam = family("teeth-xy")
    ev_fn, calls = _fake_eval(lambda p: 100.0 + p.metal_area / 100)
    ev = _Evaluator(fam, "teeth-xy", 900.0, EvalSettings().with_spacing(1.0), History(tmp_path / "h.jsonl"), ev_fn,
                    progress=False)
    a = ev(_teeth_xy_x(fam), np.zeros(0), 2)
    b = ev(_teeth_xy_x(fam, base_y=5.0, tip_y=0.7), np.zeros(0), 2)  # no y teeth: base_y and tip_y change nothing
    c = ev(_teeth_xy_x(fam, height_y=1.0), np.zeros(0), 2)  # another plane
    assert a == b != c and len(calls) == 2 and ev.solves == 2
    assert ev.hist.rows[1]["same_metal_as"] == 1 and ev.hist.rows[1]["seconds"] == 0.0
    assert flat_over_last_half(ev.counted)["solves"] == 2
    # a resumed search replays the twin without counting it, and an old history (rows without their
    # outline) is indexed from its planes
    rows = [json.loads(line) for line in (tmp_path / "h.jsonl").read_text().splitlines()]
    (tmp_path / "old.jsonl").write_text("".join(json.dumps({k: v for k, v in r.items() if k != "outline"}) + "\n"
                                                for r in rows[:1]))
    ev2 = _Evaluator(fam, "teeth-xy", 900.0, EvalSettings().with_spacing(1.0), History(tmp_path / "old.jsonl"), ev_fn,
                     progress=False)
    ev2.backfill_outlines()
    assert ev2(_teeth_xy_x(fam, base_y=7.0), np.zeros(0), 2) == a and len(calls) == 2 and ev2.solves == 0


def test_the_convergence_curve_is_the_best_feasible_so_far():
    from optimise.search import best_so_far, solved_rows

    rows = [{"status": "ok", "fom_mk": 50.0, "feasible": False}, {"status": "invalid", "fom_mk": None},
            {"status": "ok", "fom_mk": 90.0, "feasible": True}, {"status": "ok", "fom_mk": 90.0, "same_metal_as": 3},
            {"status": "failed", "fom_mk": None}, {"status": "ok", "fom_mk": 80.0}]
    solved = solved_rows(rows)
    assert len(solved) == 4 and best_so_far(solved) == [math.inf, 90.0, 90.0, 80.0]


def test_the_confirmation_re_solves_distinct_planes(tmp_path):
    """The robust front confirmed one plane twice at the finest level (two rows of one outline)."""
    from optimise.search import History, _confirm, _Evaluator

    fam = family("teeth-xy")
    ev_fn, calls = _fake_eval(lambda p: 100.0 + p.metal_area / 100)
    ev = _Evaluator(fam, "teeth-xy", 900.0, EvalSettings().with_spacing(1.0), History(tmp_path / "h.jsonl"), ev_fn,
                    progress=False)
    twins = [_teeth_xy_x(fam), _teeth_xy_x(fam, base_y=5.0)]
    for i, x in enumerate(twins):  # as an old history holds them: each solved and counted
        row = {"integer": 2, "x": list(x), "params": fam.params(x, 2), "area_m2": fam.area(x, 2), "status": "ok",
               "fom_mk": 120.0, "objective": 120.0, "name": f"twin {i}"}
        ev.hist.add(row)
        ev.counted.append(row)
    ev(_teeth_xy_x(fam, height_y=1.0), np.zeros(0), 2)
    rows = _confirm(ev, EvalSettings(), tmp_path, 2, progress=False)
    assert len(rows) == 2 and len({row_plane_key(fam, r) for r in rows}) == 2


def row_plane_key(fam, r):
    from optimise.search import row_plane

    return row_plane(fam, r).outline_key()


def test_a_search_says_how_long_its_budget_will_take(tmp_path, capsys, monkeypatch):
    """After three solves the progress line gives the time to the budget's last solve at the
    median solve so far (a long search on a 2-core machine runs for hours)."""
    import optimise.search as osearch

    clock = iter(range(0, 10_000, 50))  # every perf_counter call 50 s later: each solve "takes" 50 s
    monkeypatch.setattr(osearch.time, "perf_counter", lambda: float(next(clock)))
    ev, _ = _fake_eval(lambda p: 100.0 + (p.side - 12.0) ** 2)
    optimise("square", 400.0, EvalSettings(), tmp_path, budget=8, evaluate_fn=ev, progress=True, strategy="local")
    lines = [ln for ln in capsys.readouterr().err.splitlines() if "[local, solve" in ln and "mK" in ln]
    assert "to solve" not in lines[1] and "; ~4 min to solve 8)" in lines[2]  # 5 solves left x 50 s


def test_a_build_tolerance_scores_a_design_a_crew_builds_alike_from_the_solved_one(tmp_path):
    """--build-tolerance F: a proposal within F of each parameter's range of a solved design gets that
    design's row without a solve (not counted by the stopping rule); one beyond F is solved; the
    tolerance is part of the search (a resume asking another is refused); nonsense is refused."""
    from groundplane.errors import UserInputError
    from optimise.search import solved_rows

    ev, calls = _fake_eval(lambda p: 100.0 + (p.side - 12.0) ** 2 + 0.01 * math.sin(1e4 * p.side))  # "remeshing"
    res = optimise("square", 400.0, EvalSettings(), tmp_path / "tol", budget=25, evaluate_fn=ev, progress=False,
                   strategy="local", build_tolerance=0.01)
    alike = [r for r in res.history if r.get("built_alike")]
    assert alike, "COBYLA's last small steps should fall within 1 % of the side's range of a solved design"
    fam = family("square")
    span = fam.upper[0] - fam.lower[0]
    for r in alike:
        twin = res.history[r["same_metal_as"] - 1]
        assert abs(r["x"][0] - twin["x"][0]) <= 0.01 * span and r["fom_mk"] == twin["fom_mk"]
    assert len(calls) == len(solved_rows(res.history)) < len([r for r in res.history if r["status"] == "ok"])
    with pytest.raises(UserInputError, match="another search|differs|build_tolerance"):
        optimise("square", 400.0, EvalSettings(), tmp_path / "tol", budget=25, evaluate_fn=ev, progress=False,
                 strategy="local", build_tolerance=0.02)
    with pytest.raises(UserInputError, match="--build-tolerance 0.7: a fraction of each parameter's range"):
        optimise("square", 400.0, EvalSettings(), tmp_path / "bad", budget=5, evaluate_fn=ev, progress=False,
                 build_tolerance=0.7)
