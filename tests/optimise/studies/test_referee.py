"""The referee study's report: every verdict a condition on its rows (synthetic rows here: the
engines themselves are tested in tests/solvers/engines)."""
import numpy as np
import pytest

from groundplane.errors import UserInputError
from groundplane.shapes import Square
from optimise.studies import STUDIES, referee


def _fake_case(foms: dict):
    """_run_case stand-in: FoM per (case name, soil, engine) from ``foms``."""
    def run(case, freqs, cell, beams, cached_only=False):
        rows = [{"case": case.name, "soil": case.soil_name, "engine": e, "fom_mk": foms[(case.name, case.soil_name, e)],
                 "fom_every_lst_mk": 2 * foms[(case.name, case.soil_name, e)], "loss_55_percent": 0.4,
                 "loss_max_percent": 0.5, "s11_max_db": -6.0, "s11_min_db": -20.0} for e in referee.ENGINES]
        diffs = [{"case": case.name, "soil": case.soil_name, "pair": "fdtd vs surface", "freq_mhz": float(f),
                  "rms_db": 0.05, "max_db": 0.3} for f in freqs]
        bins = [{"case": case.name, "soil": case.soil_name, "engine": e, "lst_bin": i, "fom_mk": 50.0 + i}
                for e in referee.ENGINES for i in range(12)]
        return rows, diffs, bins
    return run


def _foms(star_fdtd_mro: float) -> dict:
    out = {}
    for soil in ("MRO", "dry"):
        out |= {("sawtooth-20-16", soil, "surface"): 109.0, ("sawtooth-20-16", soil, "nec"): 124.0,
                ("sawtooth-20-16", soil, "fdtd"): 110.0, ("star", soil, "surface"): 81.0, ("star", soil, "nec"): 132.0,
                ("star", soil, "fdtd"): 85.0}
    out[("star", "MRO", "fdtd")] = star_fdtd_mro
    out |= {("square-30", "MRO", "surface"): 117.0, ("square-30", "MRO", "nec"): 130.0,
            ("square-30", "MRO", "fdtd"): 180.0, ("plus-30", "MRO", "surface"): 114.0,
            ("plus-30", "MRO", "nec"): 120.0, ("plus-30", "MRO", "fdtd"): 118.0}
    return out


@pytest.mark.parametrize("star_mro, beats", [(85.0, True), (130.0, False)])
def test_the_verdict_follows_the_rows(tmp_path, monkeypatch, star_mro, beats):
    monkeypatch.setattr(referee, "_run_case", _fake_case(_foms(star_mro)))
    rows = referee.referee(tmp_path, "groundplane study referee ...", Square(20.0), "star", freqs=np.arange(55, 98, 2.0))
    assert len(rows) == 3 * 6
    text = (tmp_path / "referee.md").read_text()
    mro = next(ln for ln in text.splitlines() if ln.startswith("- On MRO soil"))
    assert ("**beats**" in mro) is beats and ("does **not** beat" in mro) is not beats
    assert "nearer the **surface** engine's" in mro if beats else "nearer the **nec** engine's" in mro
    assert "- square-30: FDTD 180.0 mK" in text and "sides with **the paper**" in text  # 180 is nearer 192
    assert "plus-30" in text and "sides with **the surface engine**" in text  # 118 is nearer 114 than 181
    # FDTD / surface / NEC: sawtooth 110 / 109 / 124 on both soils and the star on dry 85 / 81 / 132 are nearer the
    # surface engine; square-30 180 / 117 / 130 and plus-30 118 / 114 / 120 nearer NEC-2; the star on MRO either way
    near = 4 if beats else 3
    assert f"nearer the surface engine's in {near} of 6 cases and NEC-2's in {6 - near}" in text
    assert (tmp_path / "referee.png").exists() and (tmp_path / "fom_bins.csv").exists()
    assert "Not run yet" not in text


def test_a_partial_run_says_what_is_still_to_run(tmp_path, monkeypatch):
    done = []

    def stop_after_two(case, *a):
        if len(done) == 2:
            raise KeyboardInterrupt
        done.append(case)
        return _fake_case(_foms(85.0))(case, *a)

    monkeypatch.setattr(referee, "_run_case", stop_after_two)
    with pytest.raises(KeyboardInterrupt):
        referee.referee(tmp_path, "cmd", Square(20.0), "star", freqs=np.arange(55, 98, 2.0))
    text = (tmp_path / "referee.md").read_text()
    assert "Not run yet" in text and "sawtooth-20-16 on dry" in text and "plus-30 on MRO" in text
    assert "- On MRO soil" in text  # both designs on MRO landed: its verdict is there


def test_cached_only_reports_what_landed_and_names_the_rest(tmp_path, monkeypatch):
    landed = _fake_case(_foms(85.0))
    monkeypatch.setattr(referee, "_run_case", lambda case, *a: landed(case, *a) if case.soil_name == "MRO"
                        and case.name in ("sawtooth-20-16", "star") else None)
    referee.referee(tmp_path, "cmd", Square(20.0), "star", freqs=np.arange(55, 98, 2.0), cached_only=True)
    text = (tmp_path / "referee.md").read_text()
    assert "- On MRO soil" in text and "- On dry soil" not in text
    assert "Not run yet" in text and "sawtooth-20-16 on dry, star on dry, square-30 on MRO, plus-30 on MRO" in text


def test_the_study_needs_a_candidate():
    with pytest.raises(UserInputError, match="--design"):
        STUDIES["referee"].validate({})
