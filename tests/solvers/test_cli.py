"""NEC-2 adapter: golden values, engine guard, gain normalisation, mesh, cache, CLI.
CI solves stay small (blade alone, or a 3 m plate at a coarse mesh, few frequencies)."""




def test_cli_solve_and_fom(tmp_path, capsys, monkeypatch):
    from groundplane.cli import main

    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "cache"))
    out, deck = tmp_path / "b.npz", tmp_path / "b.nec"
    rc = main(["solve", "--engine", "nec", "square", "--side", "3", "--mesh", "1.0", "--freqs", "55:97:4",
               "--workers", "1", "-o", str(out), "--deck", str(deck)])
    assert rc == 0, capsys.readouterr().err
    text = deck.read_text()
    assert text.startswith("CM") and "GN 2 0 0 0 3.5 0.02" in text and text.rstrip().endswith("EN")
    assert main(["fom", str(out), "--n-lst", "24"]) == 0
    assert "mK" in capsys.readouterr().out
    assert main(["solve", "-o", str(out)]) == 2
    assert "needs a ground plane" in capsys.readouterr().err



def test_default_solve_is_the_surface_engine_and_methods_agree(tmp_path, capsys, monkeypatch):
    """`groundplane solve` without --engine is the surface engine's fast solve; --method dense
    is the reference and gives the same beam (a coarse 4 m plate, three frequencies)."""
    import numpy as np

    from groundplane.beam import Beam
    from groundplane.cli import main

    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "cache"))
    common = ["solve", "square", "--side", "4", "--mesh", "1.5", "--blade-cells", "4", "4", "--freqs", "60,70,80",
              "--workers", "1"]
    beams = {}
    for method in ("fast", "dense"):
        out = tmp_path / f"{method}.npz"
        assert main([*common, *(["--method", method] if method == "dense" else []), "-o", str(out)]) == 0, \
            capsys.readouterr().err
        beams[method] = Beam.load(out)
    assert beams["fast"].meta["solver"] == "surface" and beams["fast"].meta["mesh"]["method"] == "fast"
    assert beams["dense"].meta["mesh"]["method"] == "dense"
    up = beams["fast"].theta_deg <= 80
    assert np.abs(10 * np.log10(beams["fast"].gain[:, up] / beams["dense"].gain[:, up])).max() < 0.01


def test_deck_is_an_engine_capability(tmp_path, capsys):
    """--deck asks the engine for its input file: NEC writes one, the surface engine says it has none."""
    from groundplane.cli import main

    rc = main(["solve", "square", "--side", "3", "--mesh", "1.0", "--freqs", "55:97:4", "-o",
               str(tmp_path / "b.npz"), "--deck", str(tmp_path / "b.deck")])
    assert rc == 2 and "the surface engine has no input deck to write" in capsys.readouterr().err
    assert not (tmp_path / "b.npz").exists()  # refused before solving
