"""Result logs after a kill: a torn last line is ended, skipped, and never swallows a row."""
from groundplane.files import append_jsonl, read_jsonl


def test_torn_line_is_dropped_and_the_next_row_is_its_own(tmp_path):
    p = tmp_path / "results.jsonl"
    append_jsonl(p, {"name": "a"})
    with open(p, "a") as fh:
        fh.write('{"name": "b", "lst_avera')  # kill -9 mid-write
    append_jsonl(p, {"name": "c"})
    assert [r["name"] for r in read_jsonl(p)] == ["a", "c"]
    assert len(p.read_text().splitlines()) == 3


def test_results_folder_checked_before_any_solve(tmp_path, capsys, monkeypatch):
    """Issue 25 item 6. As root, permission bits do not stop writes, so an unwritable folder is
    simulated by making the probe fail as a read-only folder would; a file in the way is real."""
    import errno
    import tempfile as tf

    from groundplane.cli import main

    (tmp_path / "afile").write_text("x")
    assert main(["sweep", "examples/sweep.toml", "-o", str(tmp_path / "afile")]) == 2
    assert "is a file; give a folder" in capsys.readouterr().err

    def read_only(*a, **k):
        raise PermissionError(errno.EACCES, "Permission denied")
    monkeypatch.setattr(tf, "mkstemp", read_only)
    assert main(["optimise", "--shape", "square", "--max-area", "100", "-o", str(tmp_path / "ro")]) == 2
    assert "cannot write results here (Permission denied)" in capsys.readouterr().err


def test_a_full_disk_is_one_line_and_keeps_the_rows_before(tmp_path, monkeypatch):
    """ENOSPC simulated at the fsync of the third row (no small disk can be made in CI)."""
    import errno

    import pytest

    from groundplane.errors import OutputError
    from groundplane.files import append_jsonl, atomic_path, read_jsonl

    log = tmp_path / "history.jsonl"
    append_jsonl(log, {"a": 1})
    append_jsonl(log, {"a": 2})

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr("groundplane.files.os.fsync", full)
    with pytest.raises(OutputError, match="history.jsonl: could not append \\(No space left on device\\)"):
        append_jsonl(log, {"a": 3})
    monkeypatch.undo()
    assert [r["a"] for r in read_jsonl(log)][:2] == [1, 2]
    target = tmp_path / "report.md"
    target.write_text("old")
    with pytest.raises(OutputError, match="report.md: could not be written"):
        with atomic_path(target):
            raise OSError(errno.ENOSPC, "No space left on device")
    assert target.read_text() == "old"  # the earlier file is untouched


def test_an_unwritable_cache_costs_the_reuse_not_the_result(tmp_path, capsys, monkeypatch):
    """A cache folder that cannot be made (a file where a folder should be: fails even as root)."""
    import json

    from groundplane.cli import main
    from tests.conftest import ROOT

    (tmp_path / "blocker").write_text("x")
    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "blocker" / "cache"))
    assert main(["fom", str(ROOT / "examples" / "lowband_square10_nec.npz"), "--n-lst", "24", "--json"]) == 0
    out = capsys.readouterr()
    assert json.loads(out.out)["lst_averaged_fom_mk"] > 0 and "cannot be" in out.err
