"""Reports carry what made them; ``study --check`` tells current from stale from unknown."""
import json

from groundplane.cli import main
from optimise import provenance as prov


def test_write_md_then_check_current_stale_and_unknown(tmp_path, capsys):
    cur = tmp_path / "a.md"
    prov.write_md(cur, "# A\n\nCommand: `groundplane study a -o x`\n", "study a", "groundplane study a -o x", {"k": 1})
    head = prov.read(cur)
    assert head["models"] == prov.model_versions() and head["settings"] == {"k": 1}
    assert cur.read_text().split("\n", 2)[1] == "# A"  # the report itself is untouched below the line
    prov.write_md(cur, cur.read_text(), "study b", "other")  # a text that has its line keeps it, not adds one
    assert cur.read_text().count(prov.PREFIX) == 1 and prov.read(cur)["command"] == "groundplane study a -o x"
    stale = tmp_path / "sub" / "b.md"
    stale.parent.mkdir()
    old = {e: v - 1 for e, v in prov.model_versions().items()}
    stale.write_text(prov.PREFIX + json.dumps({"models": old, "command": "groundplane study b"}) + prov.SUFFIX + "\n# B\n")
    (tmp_path / "c.md").write_text("# C\n\nCommand: `groundplane study c -o results`\n")
    (tmp_path / "answer.md").write_text("hand-written\n")  # never checked: interpretation, not output
    (tmp_path / "c_runs").mkdir()
    (tmp_path / "c_runs" / "report.md").write_text("# the study's sweep table, with no command of its own\n")
    rows = {r["path"].split("/")[-1]: r for r in prov.check(tmp_path)}
    assert rows.pop("report.md")["command"] == "groundplane study c -o results"  # its study's command
    (tmp_path / "c_runs" / "report.md").unlink()
    assert set(rows) == {"a.md", "b.md", "c.md"}
    assert rows["a.md"]["status"] == "current"
    assert rows["b.md"]["status"] == "stale" and "surface v" in rows["b.md"]["why"]
    assert rows["c.md"]["status"] == "unknown" and rows["c.md"]["command"] == "groundplane study c -o results"
    assert main(["study", "--check", "-o", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert [ln.split()[0] for ln in out.splitlines()[:-1]] == ["stale", "unknown", "current"]
    assert "regenerate: groundplane study b" in out
    stale.unlink()
    assert main(["study", "--check", "-o", str(tmp_path)]) == 0


def test_two_commands_into_one_folder_each_report_names_its_own(tmp_path, monkeypatch, capsys):
    """A sweep's report and then a study's, in one folder: each names the command that wrote it
    (a study used to stamp every new markdown file of its folder with its own command)."""
    from optimise.studies import STUDIES, Study

    cfg = tmp_path / "s.toml"
    example = str(__import__("tests.conftest", fromlist=["ROOT"]).ROOT / "examples" / "lowband_square10_nec.npz")
    cfg.write_text(f'[fom]\nn_lst = 24\n[[candidate]]\nname = "example"\nbeam = "{example}"\n')
    assert main(["sweep", str(cfg), "-o", str(tmp_path)]) == 0

    def toy(out, settings, command, **extra):
        prov.write_md(out / "toy.md", "# Toy\n", "study toy", command)
    monkeypatch.setitem(STUDIES, "toy", Study("toy", "a toy", toy))
    prov.write_md(tmp_path / "toy.md", "# placeholder\n", "x", "x")  # the study must overwrite its own file
    from optimise.studies import run_study

    run_study("toy", tmp_path, None, "groundplane study toy -o here")
    sweep = prov.read(tmp_path / "report.md")  # written by the sweep: its own kind and command line, untouched
    assert sweep["report"] == "report" and sweep["command"] != "groundplane study toy -o here"
    assert prov.read(tmp_path / "toy.md")["command"] == "groundplane study toy -o here"
    assert (tmp_path / "toy.md").read_text().count(prov.PREFIX) == 1
