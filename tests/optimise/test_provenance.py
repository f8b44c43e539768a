"""Reports carry what made them; ``study --check`` tells current from stale from unknown."""
import json

from groundplane.cli import main
from optimise import provenance as prov


def test_stamp_then_check_current_stale_and_unknown(tmp_path, capsys):
    cur = tmp_path / "a.md"
    cur.write_text("# A\n\nCommand: `groundplane study a -o x`\n")
    prov.stamp(cur, "study a", "groundplane study a -o x", {"k": 1})
    head = prov.read(cur)
    assert head["models"] == prov.model_versions() and head["settings"] == {"k": 1}
    assert cur.read_text().split("\n", 2)[1] == "# A"  # the report itself is untouched below the line
    prov.stamp(cur, "study a", "groundplane study a -o x")  # restamping replaces the line, not adds one
    assert cur.read_text().count(prov.PREFIX) == 1
    stale = tmp_path / "sub" / "b.md"
    stale.parent.mkdir()
    old = {e: v - 1 for e, v in prov.model_versions().items()}
    stale.write_text(prov.PREFIX + json.dumps({"models": old, "command": "groundplane study b"}) + prov.SUFFIX + "\n# B\n")
    (tmp_path / "c.md").write_text("# C\n\nCommand: `groundplane study c -o results`\n")
    (tmp_path / "answer.md").write_text("hand-written\n")  # never checked: interpretation, not output
    rows = {r["path"].split("/")[-1]: r for r in prov.check(tmp_path)}
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
