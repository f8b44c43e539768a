"""fabricate --snap-to-sheet solves the designed and the snapped plane with the same settings
and reports the change (the solves replaced by a stand-in FoM: the plumbing, not physics)."""
import json

from groundplane.cli import main
from optimise import evaluate as ev


def test_snap_reports_metal_and_fom_change(tmp_path, monkeypatch, capsys):
    def fake(candidate, settings, progress=False):
        return {"status": "ok", "name": candidate.name, "lst_averaged_fom_mk": candidate.plane.metal_area / 10}
    monkeypatch.setattr(ev, "evaluate", fake)
    out = tmp_path / "fab"
    assert main(["fabricate", "--preset", "sawtooth-20-16", "--snap-to-sheet", "-o", str(out)]) == 0
    snap = json.loads((out / "snap.json").read_text())
    assert snap["moved"] == {"tooth_base": [5.0, 4.8]}
    assert snap["metal_area_m2"] == [600.0, 592.0]
    assert snap["fom_mk"] == [60.0, 59.2]
    assert json.loads((out / "plan.json").read_text())["metal_area_m2"] == 592.0  # the plan is the buildable one
    assert "FoM 60.0 -> 59.2 mK (-0.8, -1.3 %)" in capsys.readouterr().out


def test_snap_failure_is_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(ev, "evaluate", lambda c, s, progress=False: {"status": "failed", "name": c.name, "error": "boom"})
    assert main(["fabricate", "--preset", "sawtooth-20-16", "--snap-to-sheet", "-o", str(tmp_path / "f")]) == 1
    assert "solving the as designed plane failed: boom" in capsys.readouterr().err
