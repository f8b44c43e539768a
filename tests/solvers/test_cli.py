"""NEC-2 adapter: golden values, engine guard, gain normalisation, mesh, cache, CLI.
CI solves stay small (blade alone, or a 3 m plate at a coarse mesh, few frequencies)."""




def test_cli_solve_and_fom(tmp_path, capsys, monkeypatch):
    from groundplane.cli import main

    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "cache"))
    out, deck = tmp_path / "b.npz", tmp_path / "b.nec"
    rc = main(["solve", "--engine", "nec", "square", "--side", "3", "--mesh", "1.0", "--freqs", "55:97:6",
               "--workers", "1", "-o", str(out), "--deck", str(deck)])
    assert rc == 0, capsys.readouterr().err
    text = deck.read_text()
    assert text.startswith("CM") and "GN 2 0 0 0 3.5 0.02" in text and text.rstrip().endswith("EN")
    assert main(["fom", str(out), "--n-lst", "24"]) == 0
    assert "mK" in capsys.readouterr().out
    assert main(["solve", "-o", str(out)]) == 2
    assert "needs a ground plane" in capsys.readouterr().err

