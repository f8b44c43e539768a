"""The soil-sweep study's runs, table and reading (the sweep itself is stood in for: its
machinery is tested in tests/optimise/test_sweep.py)."""
from groundplane import paper


def test_soil_sweep_scores_both_binnings_and_reads_each_planes_spread(tmp_path, monkeypatch):
    from optimise.evaluate import EvalSettings
    from optimise.studies import soil_sweep as study

    calls = []

    def fake_run_sweep(candidates, settings, out_dir, **_):
        (c,) = candidates
        calls.append((c.name, settings.fom.lst_bin_hours))
        fom = 100.0 + 1000 * settings.soil.sigma + 10 * settings.soil.eps_r  # moves with the soil
        fom *= (2.0 if c.name.startswith("square-10") else 1.0) * (0.5 if settings.fom.lst_bin_hours else 1.0)
        return [{"status": "ok", "lst_averaged_fom_mk": fom}]

    monkeypatch.setattr(study, "run_sweep", fake_run_sweep)
    from dataclasses import replace

    from groundplane.fom import FomSettings

    # a user's --lst-bin does not turn the every-LST column into a second binned one
    rows = study.soil_sweep(EvalSettings(fom=replace(FomSettings(), lst_bin_hours=2.0)), tmp_path, "cmd",
                            progress=False)
    planes = [r["plane"] for r in rows]
    assert planes.count("square-10") == len(paper.SOIL_SWEEP_EPS_R) + len(paper.SOIL_SWEEP_SIGMA)
    ext = {(r["eps_r"], r["sigma"]) for r in rows if r["plane"] == "extended"}
    assert ext == set(study.EXTENDED_SOILS)
    assert {b for _, b in calls} == {0.0, paper.DATA_LST_BIN_HOURS}  # every run scored both ways
    assert all(r["fom_binned_mk"] == r["fom_mk"] / 2 for r in rows)
    md = (tmp_path / "soil_sweep.md").read_text()
    # sigma 0.001-0.1 moves square-10 by 2 * 1000 * 0.099 = 198 mK of its 2 * (100 + 20 + 35) = 310 at MRO
    assert "`square-10` 272.0-470.0 mK (64 % of its MRO value)" in md
    assert "`extended` 136.0-235.0 mK (64 % of its MRO value)" in md
    assert (tmp_path / "soil_sweep.png").stat().st_size > 1000

