"""The Figure of Merit: fast path vs an independent integration, and physics sanity checks."""
import json
from pathlib import Path

import numpy as np
import pytest

from groundplane.cli import main
from groundplane.fom import (
    FomSettings,
)
from groundplane.shapes import PRESETS
from tests.conftest import EXAMPLE_BEAM

HIGH = FomSettings(fit_band_mhz=(90.0, 190.0))



def test_cli_fom_json_and_plot(tmp_path, capsys):
    png = tmp_path / "fom.png"
    rc = main(["fom", str(EXAMPLE_BEAM), "--fit-band", "90", "190", "--json", "--plot", str(png)])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("lst_averaged_fom_mk", "fom_mk", "lst_hours", "freqs_mhz", "settings"):
        assert key in out
    assert len(out["fom_mk"]) == 12  # the default: the paper's 2 h LST bins
    assert out["settings"]["fit_band_mhz"] == [90.0, 190.0]
    assert png.stat().st_size > 10_000

def test_cli_fom_reports_bad_fit_band(capsys):
    rc = main(["fom", str(EXAMPLE_BEAM)])
    assert rc == 2
    assert "the fit band is 55-97 MHz: 55-80 MHz missing" in capsys.readouterr().err


def test_cli_shapes_json(capsys):
    assert main(["shapes", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    by = {r["name"]: r for r in rows}
    assert set(by) == set(PRESETS)
    assert by["sawtooth-20-16"]["metal_area_m2"] == pytest.approx(600)
    assert by["plus-30"]["extent_m"] == pytest.approx(30)
    assert all({"name", "shape", "metal_area_m2", "extent_m"} <= set(r) for r in rows)

def test_cli_export_and_errors(tmp_path, capsys):
    out = tmp_path / "s.stl"
    assert main(["export", "sawtooth", "--side", "20", "--teeth-per-side", "4", "--tooth-base", "5",
                 "--tooth-height", "5", "-o", str(out)]) == 0
    assert out.exists()
    assert main(["export", "--preset", "plus-15", "-o", str(tmp_path / "p.png")]) == 0
    capsys.readouterr()
    assert main(["export", "sawtooth", "--side", "10", "--teeth-per-side", "3", "--tooth-base", "5",
                 "--tooth-height", "5", "-o", str(out)]) == 2
    assert "use teeth_per_side <= 2" in capsys.readouterr().err
    assert main(["export", "square", "-o", str(out)]) == 2
    assert "square needs --side" in capsys.readouterr().err
    assert main(["export", "square", "--side", "3", "--arm", "2", "-o", str(out)]) == 2
    assert "does not take --arm" in capsys.readouterr().err



def test_exit_codes_user_error_solver_failure_and_bug(capsys):
    from groundplane.cli import COMMANDS, command
    from groundplane.errors import SolveError, UserInputError

    def make(exc):
        def setup(p):
            return lambda args: (_ for _ in ()).throw(exc)
        return setup

    try:
        command("t-user", "test")(make(UserInputError("bad flag")))
        command("t-solver", "test")(make(SolveError("engine died")))
        command("t-bug", "test")(make(KeyError("oops")))
        assert main(["t-user"]) == 2 and "error: bad flag" in capsys.readouterr().err
        assert main(["t-solver"]) == 1 and "failed: engine died" in capsys.readouterr().err
        with pytest.raises(KeyError):  # a bug keeps its traceback
            main(["t-bug"])
    finally:
        for k in ("t-user", "t-solver", "t-bug"):
            COMMANDS.pop(k, None)


def test_shape_flags_say_which_family_uses_them(capsys):
    with pytest.raises(SystemExit):
        main(["export", "--help"])
    out = capsys.readouterr().out
    assert ("[square, sawtooth, teeth, teeth-xy] side of the central square (m) / side of the square (m) / side of the "
            "square core (m)") in " ".join(out.split())
    assert ("[sawtooth, teeth, teeth-xy] teeth on each side (4 x this in all, besides the corner teeth) / teeth on "
            "each side of the square (4 x this in all) / triangles on each side") in " ".join(out.split())


def test_outputs_checked_before_work_and_replaced_atomically(tmp_path, capsys):
    from groundplane.cli import main
    from tests.conftest import EXAMPLE_BEAM

    # a directory as the figure: refused before scoring (matplotlib would write <dir>.png)
    assert main(["fom", str(EXAMPLE_BEAM), "--fit-band", "90", "190", "--plot", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err and not (tmp_path.parent / (tmp_path.name + ".png")).exists()
    assert main(["fom", str(EXAMPLE_BEAM), "--fit-band", "90", "190", "--plot", str(tmp_path / "fig")]) == 2
    assert "needs one of the suffixes" in capsys.readouterr().err
    out = tmp_path / "b.npz"
    assert main(["convert", str(EXAMPLE_BEAM), "-o", str(out)]) == 0
    assert "replaced" not in capsys.readouterr().out
    assert main(["convert", str(EXAMPLE_BEAM), "-o", str(out)]) == 0
    assert "replaced the existing file atomically" in capsys.readouterr().out
    assert main(["convert", str(EXAMPLE_BEAM), "-o", str(tmp_path)]) == 2
    assert not list(tmp_path.glob("*.tmp*"))


def test_shipped_lowband_sample_scores_with_default_settings(capsys):
    """README's first command: the low-band sample covers 40-100 MHz at 1 MHz, so the
    paper's default FoM settings score it (the 40 MHz FEKO export in ../shared cannot be);
    every 1 deg of LST it is SPEC's 239.5 mK."""
    import json

    from groundplane.cli import main
    from tests.conftest import ROOT

    assert main(["fom", str(ROOT / "examples" / "lowband_square10_nec.npz"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["lst_averaged_fom_mk"] == pytest.approx(190.7, abs=0.1)  # 2 h LST bins, the default
    assert out["settings"]["fit_band_mhz"] == [55.0, 97.0]
    assert main(["fom", str(ROOT / "examples" / "lowband_square10_nec.npz"), "--json", "--lst-bin", "0"]) == 0
    assert json.loads(capsys.readouterr().out)["lst_averaged_fom_mk"] == pytest.approx(239.5, abs=0.1)
    # solving only --freqs fit-band gives the same FoM: nothing outside the fit band is used
    from groundplane.beam import Beam
    from groundplane.fom import figure_of_merit
    from groundplane.options import parse_freqs

    full = Beam.load(ROOT / "examples" / "lowband_square10_nec.npz")
    keep = np.isin(full.freqs_mhz, parse_freqs("fit-band"))
    fit_only = Beam(full.freqs_mhz[keep], full.theta_deg, full.phi_deg, full.gain[keep])
    assert figure_of_merit(fit_only).lst_averaged_mk == pytest.approx(out["lst_averaged_fom_mk"], rel=1e-9)


def test_freqs_fit_band_is_the_paper_fit_band_at_1_mhz():
    from groundplane.options import parse_freqs

    f = parse_freqs("fit-band")
    assert f[0] == 55.0 and f[-1] == 97.0 and len(f) == 43


def test_a_reader_that_goes_away_is_not_a_traceback():
    """`groundplane shapes | head -1`: the pipe closes before the command writes."""
    import subprocess
    import sys

    p = subprocess.Popen([sys.executable, "-m", "groundplane", "shapes"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE)
    p.stdout.close()  # the reader is gone before the child starts writing
    err = p.stderr.read().decode()
    assert p.wait(timeout=120) == 0 and "Traceback" not in err, err


def test_fom_never_imports_an_engine():
    """Scoring a beam needs no EM engine: building `groundplane fom`'s parser (and running it)
    imports nothing of solvers.engines, so a warm `fom` starts fast; `solve` still gets every
    engine's options."""
    import subprocess
    import sys

    probe = ("import sys; from groundplane.cli import build_parser; p = build_parser({argv!r}); "
             "p.parse_args({argv!r}); print(sorted(m for m in sys.modules if m.startswith('solvers.engines')))")
    fom = subprocess.run([sys.executable, "-c", probe.format(argv=["fom", str(EXAMPLE_BEAM)])],
                         capture_output=True, text=True, check=True)
    assert fom.stdout.strip() == "[]"
    solve = subprocess.run([sys.executable, "-c", probe.format(argv=["solve", "--preset", "square-10", "--method",
                                                                     "dense", "-o", "b.npz"])],
                           capture_output=True, text=True, check=True)
    assert "solvers.engines.surface" in solve.stdout and "solvers.engines.nec" in solve.stdout


@pytest.mark.parametrize("suffix", [".step", ".stl", ".svg"])
def test_export_replaces_atomically_keeps_a_good_file_on_failure_and_replaces_a_symlink(tmp_path, monkeypatch,
                                                                                        suffix, capsys):
    """A failed or interrupted export leaves the good file it would have replaced; a symlink
    at -o is replaced by the file, its target left alone (as convert does)."""
    from groundplane import cad
    from groundplane.cli import main

    out = tmp_path / f"plane{suffix}"
    assert main(["export", "--preset", "square-10", "-o", str(out)]) == 0
    good = out.read_bytes()
    assert len(good) > 100

    def broken(shape, path, *a, **k):  # writes half a file, then dies
        Path(path).write_bytes(good[: len(good) // 2])
        raise OSError("disk full")

    monkeypatch.setattr(cad, {".step": "export_step", ".stl": "export_stl", ".svg": "draw_outline"}[suffix], broken)
    assert main(["export", "--preset", "square-20", "-o", str(out)]) == 1  # one line, not a traceback
    assert "could not be written (disk full)" in capsys.readouterr().err
    assert out.read_bytes() == good and not list(tmp_path.glob("*.tmp*"))
    monkeypatch.undo()
    target, link = tmp_path / "target.txt", tmp_path / f"link{suffix}"
    target.write_text("keep me")
    link.symlink_to(target)
    assert main(["export", "--preset", "square-10", "-o", str(link)]) == 0
    assert not link.is_symlink() and target.read_text() == "keep me" and link.stat().st_size > 100


@pytest.mark.parametrize("argv, message", [
    (["export", "square", "--side", "1e12", "-o", "x.step"], "1e+12 m tip to tip; a ground plane is 1-1000 m"),
    (["export", "sawtooth", "--side", "10", "--teeth-per-side", "1000000", "--tooth-base", "1e-6",
      "--tooth-height", "1", "-o", "x.step"], "--teeth-per-side 1000000 is more than 1000"),
    (["solve", "square", "--side", "1e-6", "-o", "x.npz"], "1e-06 m tip to tip"),
    (["fom", "examples/lowband_square10_nec.npz", "--lst-bin", "0.5"], "(--n-lst 720 holds whole bins of it)"),
])
def test_impossible_input_is_one_line_before_any_work(argv, message, capsys, tmp_path, monkeypatch):
    """Issue 25 items 8 and 10: these were a 'not watertight' RuntimeError, 195 s of vertex
    building, 'solver failed' (exit 1) and a message that did not say how to fix it."""
    from tests.conftest import ROOT

    monkeypatch.chdir(ROOT)
    argv = [a if a not in ("x.step", "x.npz") else str(tmp_path / a) for a in argv]
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_an_empty_beam_file_says_empty(tmp_path, capsys):
    (tmp_path / "b.npz").write_bytes(b"")
    assert main(["fom", str(tmp_path / "b.npz")]) == 2
    assert "empty file (0 bytes)" in capsys.readouterr().err


def test_every_command_that_takes_a_design_takes_a_design_file(tmp_path, capsys):
    """--design FILE.json (an optimiser's best.json) works wherever --preset does, and is one of three."""
    import json

    design = tmp_path / "best.json"
    design.write_text(json.dumps({"params": {"side": 10.0}, "name": "Square(side=10.0)"}))
    assert main(["export", "--design", str(design), "-o", str(tmp_path / "d.svg")]) == 0
    assert (tmp_path / "d.svg").exists()
    capsys.readouterr()
    assert main(["export", "--design", str(design), "--preset", "square-10", "-o", str(tmp_path / "e.svg")]) == 2
    assert "give one design" in capsys.readouterr().err
    assert main(["solve", "--design", str(tmp_path / "missing.json"), "-o", str(tmp_path / "b.npz")]) == 2
    assert "no such design file" in capsys.readouterr().err


def test_every_command_prints_its_help(capsys):
    """--help of every command, the higher layers' included (a literal % in an option's help
    once made argparse trace back on optimise, score and sweep)."""
    import argparse

    from groundplane.cli import build_parser

    sub = next(a for a in build_parser([])._actions if isinstance(a, argparse._SubParsersAction))
    assert {"fom", "solve", "optimise", "score", "sweep", "study"} <= set(sub.choices)
    for name in sub.choices:
        with pytest.raises(SystemExit) as done:
            main([name, "--help"])
        assert done.value.code == 0, name
        assert "usage:" in capsys.readouterr().out
