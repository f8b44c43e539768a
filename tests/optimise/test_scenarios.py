"""Scenario sets (members, aggregates, TOML), constraints on the ground loss, and the search that
holds designs to them: the plumbing on stand-in FoMs, one real scoring of a small plate."""
import json

import numpy as np
import pytest

from groundplane.errors import ConfigError, UserInputError
from groundplane.shapes import PRESETS, Square, TeethXY, preset
from optimise.evaluate import Candidate, EvalSettings
from optimise.scenarios import (
    Constraints,
    Member,
    ScenarioSet,
    aggregate,
    evaluate_scenarios,
    load_set,
    scenario_set,
)
from optimise.search import flat_over_last_half, optimise


def test_built_in_sets_are_the_named_members():
    soil = scenario_set("soil")
    assert len(soil.members) == 5 and all(m.soil_only and m.axis == "soil" for m in soil.members)
    pairs = {(s.soil.eps_r, s.soil.sigma) for s in (m.settings(EvalSettings()) for m in soil.members)}
    assert pairs == {(2.5, 0.005), (2.5, 0.05), (5.0, 0.005), (5.0, 0.05), (3.5, 0.02)}
    model = [m.settings(EvalSettings()) for m in scenario_set("model").members]
    assert {(s.model.feed_width, s.model.plate_height) for s in model} == {(0.04, 0.0025), (0.04, 0.01),
                                                                         (1.252, 0.0025), (1.252, 0.01)}
    assert all((s.soil.eps_r, s.soil.sigma) == (3.5, 0.02) for s in model)
    field = scenario_set("field")
    assert {m.axis for m in field.members} == {"soil", "model", "as built"} and len(field.members) == 18
    assert scenario_set("soil").aggregate == "worst" and scenario_set("soil", "worst-2").aggregate == "worst-2"
    with pytest.raises(UserInputError, match="choose one of nominal"):
        scenario_set("monsoon")


def test_as_built_members_build_the_variants_or_skip_designs_without_the_part():
    plane = preset("extended")  # 4.8 m teeth: +0.2 m still fits its sides (sawtooth-20-16's 5 m teeth do not)
    for m in scenario_set("as-built").members[1:]:
        built, note = m.plane(plane)
        assert note and built != plane
    jobs_square = [m for m in scenario_set("as-built").members if m.as_built and m.as_built.startswith("tooth-base")]
    from optimise.scenarios import NotApplicable

    with pytest.raises(NotApplicable):
        jobs_square[0].plane(Square(10.0))
    with pytest.raises(NotApplicable, match="teeth of base 5.2 m"):
        jobs_square[1].plane(preset("sawtooth-20-16"))
    # and the check before any solve skips it too, as the solve does (it had refused the whole field set)
    from optimise.scenarios import check_set

    check_set(scenario_set("field"), EvalSettings(), preset("sawtooth-20-16"))


def test_member_overrides_are_type_checked_and_refused_by_name():
    s = Member("hot", (("plate_height", 0.01), ("eps_r", 4.0))).settings(EvalSettings())
    assert s.model.plate_height == 0.01 and s.soil.eps_r == 4.0 and s.soil.sigma == 0.02
    with pytest.raises(ConfigError, match="model has no 'wire_radius'"):
        Member("nec only", (("wire_radius", 0.01),)).settings(EvalSettings())
    with pytest.raises(ConfigError, match="scenario 'neg'"):
        Member("neg", (("plate_height", -1.0),)).settings(EvalSettings())


def test_a_setting_the_members_set_themselves_is_refused_not_ignored():
    """--eps-r 3 --scenarios soil used to score no member at eps_r 3 and say nothing; with `field`
    only the as-built members took it, their moves then read against MRO soil."""
    from dataclasses import replace

    from groundplane.design import Soil
    from optimise.scenarios import check_set

    wet = EvalSettings(soil=Soil(eps_r=3.0))
    with pytest.raises(UserInputError, match=r"eps_r = 3.0 \(--eps-r\).*'soil'.*5 of its 5.*reach none of them"):
        check_set(scenario_set("soil"), wet)
    with pytest.raises(UserInputError, match=r"'field' sets eps_r itself on 9 of its 18.*only the other 9"):
        check_set(scenario_set("field"), wet)
    wide = EvalSettings(model=replace(EvalSettings().model, feed_width=1.0))
    with pytest.raises(UserInputError, match=r"feed_width = 1.0 \(--feed-width\).*'model'"):
        check_set(scenario_set("model"), wide)
    # where no member sets it, the setting reaches every member: taken
    check_set(scenario_set("soil"), wide)
    check_set(scenario_set("nominal"), wet)
    check_set(scenario_set("as-built"), wet)
    check_set(scenario_set("soil"), EvalSettings(soil=Soil()))  # the default, as if not given


def test_a_toml_set_is_read_and_its_mistakes_named(tmp_path):
    good = tmp_path / "wet.toml"
    good.write_text('name = "wet"\naggregate = "mean"\n[[member]]\nname = "wet"\neps_r = 5.0\nsigma = 0.05\n'
                    '[[member]]\nname = "gap"\nplate_height = 0.01\n[[member]]\nname = "turned"\nas_built = "turned:3"\n')
    s = load_set(good)
    assert [m.axis for m in s.members] == ["soil", "model", "as built"] and s.aggregate == "mean"
    assert scenario_set(str(good)).name == "wet"
    for body, match in (('[[member]]\nname = "a"\n[[member]]\nname = "a"\n', "unique"),
                        ('aggregate = "worst-3"\n[[member]]\nname = "a"\n', "has 1 member"),
                        ('[[member]]\nflag = true\n', "not a value"), ("season = 1\n", "unknown key"),
                        ("member = 5\n", "must be"), ("[[member\n", "wet.toml")):
        good.write_text(body)
        with pytest.raises(ConfigError, match=match):
            load_set(good)


def test_aggregates():
    v = [10.0, 40.0, 20.0, 30.0]
    assert aggregate(v, "mean") == 25.0 and aggregate(v, "worst") == 40.0 and aggregate(v, "worst-2") == 35.0
    with pytest.raises(UserInputError):
        ScenarioSet("x", (Member("a"),), "worst-zero")


def _member_fn(fom_of, loss_of):
    """A stand-in for one member's solve and score: FoM and ground loss from the plane and settings."""
    def fn(candidate, settings):
        loss = loss_of(candidate.plane, settings)
        return {"status": "ok", "lst_averaged_fom_mk": fom_of(candidate.plane, settings), "max_ground_loss": loss,
                "ground_loss": [loss, loss / 2], "freqs_mhz": [60.0, 80.0]}
    return fn


def test_worst_k_of_more_members_than_a_design_scores_is_refused_not_averaged_over_fewer():
    """A square skips the as-built set's two tooth-base members: worst-9 of its 8 was their mean."""
    from optimise.scenarios import check_set

    worst9 = scenario_set("as-built", "worst-9")
    with pytest.raises(UserInputError, match=r"worst-9: this design has 8 member.*2 skipped: tooth bases.*K <= 8"):
        check_set(worst9, EvalSettings(), Square(10.0))
    check_set(worst9, EvalSettings(), preset("extended"))  # its teeth take every variant: 10 members
    row = evaluate_scenarios(Candidate("sq", plane=Square(10.0)), EvalSettings(), worst9,
                             member_fn=_member_fn(lambda p, s: 100.0, lambda p, s: 0.001))
    assert row["status"] == "failed" and "K <= 8" in row["error"]
    row = evaluate_scenarios(Candidate("sq", plane=Square(10.0)), EvalSettings(), scenario_set("as-built", "worst-8"),
                             member_fn=_member_fn(lambda p, s: 100.0, lambda p, s: 0.001))
    assert row["status"] == "ok" and row["skipped_members"] == ["tooth bases -0.2 m", "tooth bases +0.2 m"]


def test_the_row_aggregates_members_and_reads_the_loss_on_soil_members_only():
    scen = ScenarioSet("mix", (Member("dry", (("eps_r", 2.5), ("sigma", 0.005))), Member("wet", (("sigma", 0.05),)),
                               Member("gap", (("plate_height", 0.01),))), "worst")
    fn = _member_fn(lambda p, s: 100.0 / s.soil.eps_r + 1000 * s.model.plate_height,
                    lambda p, s: 0.01 if s.model.plate_height > 0.005 else 0.004 * 2.5 / s.soil.eps_r)
    row = evaluate_scenarios(Candidate("sq", plane=Square(10.0)), EvalSettings(), scen, Constraints(0.005, 0.002),
                             member_fn=fn)
    assert row["per_member_mk"] == pytest.approx([40.0 + 5, 100 / 3.5 + 5, 100 / 3.5 + 10])
    assert row["lst_averaged_fom_mk"] == pytest.approx(45.0) and row["worst_fom_mk"] == pytest.approx(45.0)
    assert row["max_loss"] == pytest.approx(0.004)  # the plate-height member's 1 % is not a soil member
    assert row["loss_spread"] == pytest.approx(0.004 - 0.004 * 2.5 / 3.5)
    assert row["feasible"] is True
    tight = evaluate_scenarios(Candidate("sq", plane=Square(10.0)), EvalSettings(), scen, Constraints(0.003, 0.0005),
                               member_fn=fn)
    assert not tight["feasible"] and len(tight["violations"]) == 2
    assert "ground loss 0.400 % > 0.300 % (by 0.100 points)" in tight["violations"][0]
    failing = evaluate_scenarios(Candidate("sq", plane=Square(10.0)), EvalSettings(), scen, member_fn=lambda c, s: {
        "status": "failed", "error": "boom"})
    assert failing["status"] == "failed" and "on scenario 'dry': boom" in failing["error"]


def test_the_search_never_answers_an_infeasible_design_and_the_loss_binds(tmp_path):
    """Loss falls with metal, FoM rises with it: the answer is the smallest plate whose loss is
    within the limit, not the smaller plate with the lower FoM."""
    scen = ScenarioSet("two soils", (Member("dry", (("eps_r", 2.5),)), Member("wet", (("eps_r", 5.0),))))
    fn = _member_fn(lambda p, s: 50.0 + p.side, lambda p, s: 0.4 / p.side ** 2 * (3.5 / s.soil.eps_r))

    def ev(c, s):
        return evaluate_scenarios(c, s, scen, Constraints(0.003), member_fn=fn)
    res = optimise("square", 900.0, EvalSettings(), tmp_path, budget=30, evaluate_fn=ev, progress=False,
                   constraints=Constraints(0.003))
    limit = np.sqrt(0.4 / 0.003 * 3.5 / 2.5)  # the side where the dry soil's loss is 0.3 %
    assert res.best["params"]["side"] >= limit - 1e-6
    assert res.best["params"]["side"] < limit * 1.1  # and close to it: the constraint binds
    assert all(r.get("feasible") is False for r in res.history if r["status"] == "ok" and r["x"][0] < limit - 1e-6)
    assert res.best["fom_mk"] > min(r["fom_mk"] for r in res.history if r["status"] == "ok")  # a lower one was infeasible
    nothing = optimise("square", 50.0, EvalSettings(), tmp_path / "small", budget=6, evaluate_fn=ev, progress=False,
                       constraints=Constraints(0.003))
    assert nothing.best is None and nothing.closest is not None and not nothing.closest["feasible"]
    # with nothing feasible the search still spends its budget, refining from the closest design (the robust
    # front's 200 m^2 stopped at 108 of 120), and its stopping rule reads the least violation
    assert nothing.stopping["solves"] == 6 and nothing.stopping["measure"] == "violation"
    assert nothing.closest["params"]["side"] == pytest.approx(np.sqrt(50.0), rel=0.02)  # the most metal it may have
    # asked to confirm, the closest is re-solved at that level too: its FoM then reads on the presets' frequencies
    fine = EvalSettings().with_spacing(0.25)
    confirmed = optimise("square", 50.0, EvalSettings(), tmp_path / "small", budget=6, evaluate_fn=ev, progress=False,
                         constraints=Constraints(0.003), confirm_settings=fine).closest
    assert confirmed["confirmed_at"] == 0.25 and confirmed["search_fom_mk"] == nothing.closest["fom_mk"]
    assert confirmed["x"] == nothing.closest["x"] and not confirmed["feasible"]


def _rule(stop: dict) -> dict:
    """The stopping rule's reading without its tolerance (checked on its own below)."""
    assert stop["tolerance"] == pytest.approx(0.01) and stop["scatter"] is None
    return {k: stop[k] for k in ("solves", "best_at", "flat", "measure")}


def test_with_nothing_feasible_the_stopping_rule_reads_the_least_violation():
    rows = [{"status": "ok", "fom_mk": 50.0, "feasible": False, "margins": [m]} for m in (0.9, 0.5, 0.52, 0.6)]
    assert _rule(flat_over_last_half(rows)) == {"solves": 4, "best_at": 2, "flat": True, "measure": "violation"}
    rows.append({"status": "ok", "fom_mk": 60.0, "feasible": False, "margins": [0.3]})
    assert flat_over_last_half(rows)["flat"] is False


def test_stopping_rule_reads_where_the_best_so_far_was_found():
    rows = [{"status": "ok", "fom_mk": v} for v in (50, 40, 45, 41, 42, 43)]
    assert _rule(flat_over_last_half(rows)) == {"solves": 6, "best_at": 2, "flat": True, "measure": "fom"}
    rows.append({"status": "ok", "fom_mk": 39.9})  # better by less than 1 %: still flat
    assert flat_over_last_half(rows)["flat"] is True
    rows.append({"status": "ok", "fom_mk": 35.0})  # better by 12 % at the end: not flat
    assert _rule(flat_over_last_half(rows)) == {"solves": 8, "best_at": 8, "flat": False, "measure": "fom"}
    rows += [{"status": "failed", "fom_mk": None}] * 8 + [{"status": "ok", "fom_mk": 10, "feasible": False}]
    assert _rule(flat_over_last_half(rows)) == {"solves": 17, "best_at": 8, "flat": True, "measure": "fom"}  # an infeasible one never counts


def test_max_budget_goes_on_until_flat(tmp_path):
    """A FoM that keeps improving toward a corner: past --budget the search refines from its best
    until the best so far lies in the first half, or the cap."""
    def ev(c, s):
        return {"status": "ok", "lst_averaged_fom_mk": 100.0 + (c.plane.side - 13.3) ** 2}
    res = optimise("square", 900.0, EvalSettings(), tmp_path, budget=6, evaluate_fn=ev, progress=False,
                   max_budget=40)
    assert res.stopping["flat"] and res.stopping["solves"] <= 40
    assert res.best["fom_mk"] == pytest.approx(100.0, abs=0.5)


def test_a_round_that_solves_nothing_restarts_elsewhere_until_the_budget(tmp_path):
    """The 200 m^2 robust search stopped at 96 of 120 solves: a round from its closest design (on the
    area wall) proposed only planes it could not solve. Here rounds from the best propose only planes
    built alike a solved one (a 0.52 m build tolerance on the side): the search restarts from other
    designs and fresh draws until the budget is spent, resumes without a solve, and says so; with a
    tolerance that leaves the family nothing new it stops short and says why."""
    from optimise.cli import stopping_sentence

    calls = []

    def ev(c, s):
        calls.append(c.plane.side)
        return {"status": "ok", "lst_averaged_fom_mk": 100.0 + (c.plane.side - 13.3) ** 2}
    kw = dict(budget=16, evaluate_fn=ev, progress=False, explore=3, max_budget=40)
    res = optimise("square", 900.0, EvalSettings(), tmp_path / "a", build_tolerance=0.02, **kw)
    stop = res.stopping
    assert stop["solves"] == 16 and stop["barren_starts"] >= 1 and not stop["exhausted"] and len(calls) == 16
    assert "refinement rounds solved nothing from their start" in stopping_sentence(stop)
    again = optimise("square", 900.0, EvalSettings(), tmp_path / "a", build_tolerance=0.02, **kw)
    assert len(calls) == 16 and again.stopping == stop and again.best == res.best  # replayed, same path
    short = optimise("square", 900.0, EvalSettings(), tmp_path / "b", build_tolerance=0.04, **kw).stopping
    assert short["exhausted"] and short["solves"] < 16
    assert f"The search stopped at {short['solves']} solves: no design of a fresh" in stopping_sentence(short)


def test_teeth_xy_holds_the_paper_planes_crosses_and_stars():
    for name, plane in PRESETS.items():
        m = TeethXY.member(plane)
        assert m is not None and m.outline().symmetric_difference(plane.outline()).area < 1e-6, name
    cross = TeethXY(4.6, 1, 0.0, 2.25, 9.8, 1.0, 2.25, 5.0, 1.0, 0.0, 0.0, 0.0)  # arms longer along the axis
    assert cross.extent == pytest.approx(4.6 + 2 * 9.8) and all(cross.mirror_symmetry.values())
    star = TeethXY(10.0, 1, 3.0, 2.0, 8.0, 0.0, 2.0, 8.0, 0.0, 4.0, 8.0, 0.0)
    assert star.metal_area == pytest.approx(star.outline().area) and star.edge_count == 32
    with pytest.raises(Exception, match="do not fit a chamfer"):
        TeethXY(10.0, 1, 1.0, 2.0, 8.0, 0.0, 2.0, 8.0, 0.0, 4.0, 8.0, 0.0)


def test_sensitivity_verdicts_are_computed_per_axis_and_written_into_the_report(tmp_path):
    """Each axis's largest move from the MRO member, fragile beyond 25 % either way, in the score and
    sweep reports' table (both outcomes reachable: the wide feed moves it 30 %, the dry soil 10 %)."""
    from optimise.report import write_report
    from optimise.scenarios import FRAGILE, sensitivity

    scen = ScenarioSet("mix", (Member("MRO (eps_r 3.5, sigma 0.02)", (("eps_r", 3.5), ("sigma", 0.02))),
                               Member("dry", (("eps_r", 2.5), ("sigma", 0.005))),
                               Member("wide feed", (("feed_width", 1.252),))), "worst")
    fn = _member_fn(lambda p, s: 70.0 if s.model.feed_width > 1 else (110.0 if s.soil.eps_r < 3 else 100.0),
                    lambda p, s: 0.003)
    row = evaluate_scenarios(Candidate("sq", plane=Square(10.0)), EvalSettings(), scen, Constraints(0.005),
                             member_fn=fn)
    sens = sensitivity(row)
    assert sens.nominal_mk == pytest.approx(100.0) and sens.nominal_name == "the MRO soil member"
    by_axis = {r["axis"]: r for r in sens.rows}
    assert by_axis["soil"]["member"] == "dry" and by_axis["soil"]["change"] == pytest.approx(0.10)
    assert by_axis["model"]["change"] == pytest.approx(-0.30) and abs(by_axis["model"]["change"]) > FRAGILE
    assert [r["fragile"] for r in sens.rows] == [False, True]
    assert "**fragile**" in sens.verdicts()[1] and "not fragile" in sens.verdicts()[0]
    assert sensitivity({**row, "members": [m for m in row["members"] if m["axis"] != "soil"]}) is None  # no MRO
    text = write_report([row], tmp_path)["md"].read_text()
    assert "| model | 1 | wide feed | 70.0 | -30.0 % | **fragile** |" in text
    assert "| soil | 2 | dry | 110.0 | +10.0 % | not fragile |" in text


def test_score_command_solves_a_plate_on_every_soil(tmp_path, monkeypatch, capsys):
    """The real thing, small: a 4 m square at a 1.5 m mesh on the soil set, the soils solved together."""
    from groundplane.cli import main

    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "cache"))
    argv = ["score", "square", "--side", "4", "--mesh", "1.5", "--blade-cells", "4", "4", "--freqs", "55:97:4",
            "--n-lst", "24", "--workers", "0"]
    assert main([*argv, "--json", "-o", str(tmp_path / "out")]) == 0
    row = json.loads(capsys.readouterr().out)
    assert len(row["members"]) == 5 and row["scenario_set"] == "soil"
    losses = {m["member"]: m["max_ground_loss"] for m in row["members"]}
    assert all(0.001 < v < 0.3 for v in losses.values())
    assert row["max_loss"] == max(losses.values()) and row["feasible"] is False  # a 4 m plate loses more than 0.5 %
    report = (tmp_path / "out" / "report.md").read_text()
    assert report.count("| eps_r") >= 4 and "against the MRO soil member" in report
    assert main([*argv, "--max-loss", "none", "--scenarios", "nominal"]) == 0
    assert "meets the constraints" in capsys.readouterr().out
    assert main([*argv, "--scenarios", "nope"]) == 2
    assert main([*argv, "--max-loss", "2"]) == 2


def test_a_constrained_family_samples_its_valid_region():
    """teeth-xy's validity couples its parameters (teeth beside the chamfers, the corner tooth on
    its chamfer): a box sample was valid 6 times in 16384 at 200 m^2; the family's own map is."""
    from optimise.search import family, space_filling

    fam = family("teeth-xy")
    found = space_filling(fam, fam.integer_values, 200.0, 100)
    assert len(found) == 100 and {n for _, n in found} == set(fam.integer_values)
    for x, n in found:
        assert all(v <= 0 for v in fam.validity(x, n)) and 100.0 <= fam.area(x, n) <= 200.0


def test_a_candidate_is_scored_with_one_sky_convolution(monkeypatch):
    """The FoM and the G(nu)-smoothed diagnostic come from one sky product (the integral is
    linear in G), equal to scoring the smoothed beam on its own to 1e-9."""
    import importlib

    fom_module = importlib.import_module("groundplane.fom")  # the module (groundplane.fom is the public function)
    from groundplane.fom import FomSettings, figure_of_merit
    from optimise.evaluate import SMOOTHING_DEGREE, evaluate
    from tests.conftest import ROOT

    calls = []
    real = fom_module.sky_products
    monkeypatch.setattr(fom_module, "sky_products", lambda *a, **k: calls.append(1) or real(*a, **k))
    example = str(ROOT / "examples" / "lowband_square10_nec.npz")
    settings = EvalSettings(fom=FomSettings(n_lst=24))
    row = evaluate(Candidate("example", beam_paths=(example,)), settings)
    assert row["status"] == "ok" and len(calls) == 1
    beam = __import__("groundplane.beam", fromlist=["Beam"]).Beam.load(example)
    alone = figure_of_merit(beam.frequency_smoothed(SMOOTHING_DEGREE), settings.fom).lst_averaged_mk
    assert row["fom_smoothed_mk"] == pytest.approx(alone, rel=1e-9)


def test_the_flat_tolerance_is_the_search_levels_own_scatter_where_that_is_larger():
    """Near-identical designs (every parameter within 0.1 % of its range) whose FoMs differ by ~2.5 %
    are the search level's remeshing, not progress: a best that creeps by less than that late in
    the search is flat; with fewer than 20 such pairs the rule keeps its 1 %."""
    rng = np.random.default_rng(0)
    span = np.array([10.0, 10.0])
    far = [{"status": "ok", "fom_mk": 100.0 - i, "x": [float(i), 0.0], "integer": None} for i in range(10)]
    near = [{"status": "ok", "fom_mk": 90.0 * (1 + 0.08 * rng.random()), "x": [5.0 + 1e-4 * i, 5.0], "integer": None}
            for i in range(12)]  # 66 pairs within 0.1 % of the range, their FoMs spread over 8 %
    late = [{"status": "ok", "fom_mk": min(r["fom_mk"] for r in near) * 0.985, "x": [5.0, 5.0], "integer": None}]
    rows = far + near + late
    plain = flat_over_last_half(rows)  # 1 %: the late 1.5 % step is progress, found at the last solve
    assert plain["flat"] is False and plain["best_at"] == len(rows)
    stop = flat_over_last_half(rows, span=span)
    assert stop["scatter_pairs"] >= 66 and 0.015 < stop["scatter"] < 0.08 and stop["tolerance"] == stop["scatter"]
    assert stop["best_at"] < len(rows)
    few = flat_over_last_half(far + near[:5] + late, span=span)  # 15 pairs (six near designs): not enough
    assert few["scatter"] is None and few["tolerance"] == pytest.approx(0.01) and few["scatter_pairs"] == 15


def test_the_report_says_how_often_the_best_plane_was_solved_and_how_far_its_median_lies_above_the_best():
    """A local search that keeps sampling one plane keeps finding luckier remeshings of it: the stop
    carries how often the best's plane was solved and its median's gap above the best (facts beside
    the rule, which they do not change), and the sentence says whether that gap exceeds the tolerance."""
    from optimise.cli import stopping_sentence

    span = np.array([10.0, 10.0])
    far = [{"status": "ok", "fom_mk": 100.0 - i, "x": [float(i), 0.0], "integer": None} for i in range(10)]
    same = [{"status": "ok", "fom_mk": f, "x": [5.0 + 1e-4 * i, 5.0], "integer": None}
            for i, f in enumerate([90.0, 95.0, 99.0, 93.0, 97.0])]  # one plane, median 95
    other = [{"status": "ok", "fom_mk": 80.0, "x": [5.0, 9.0], "integer": None, "feasible": False}]  # never counts
    stop = flat_over_last_half(far + same + other, span=span)
    plain = flat_over_last_half(far + same + other)
    assert stop["best_plane_solves"] == 5 and stop["best_plane_gap"] == pytest.approx(95.0 / 90.0 - 1)
    assert {k: stop[k] for k in ("best_at", "flat")} == {k: plain[k] for k in ("best_at", "flat")}
    text = stopping_sentence(stop)
    assert "solved 5 times" in text and "5.6 % above the best" in text and "more than the tolerance" in text
    lone = flat_over_last_half(far, span=span)
    assert lone["best_plane_solves"] == 1 and lone["best_plane_gap"] is None
    assert "own plane" not in stopping_sentence(lone)
