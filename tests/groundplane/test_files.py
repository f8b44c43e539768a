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
