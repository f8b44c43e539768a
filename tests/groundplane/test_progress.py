"""Progress: plain lines when stderr is not a terminal (logs, CI), never silence."""
import io

from groundplane.progress import Progress


def test_plain_lines_when_not_a_terminal():
    out = io.StringIO()
    bar = Progress(3, "nec square-10", "freq", initial=1, every_s=0.0, stream=out)
    bar.update()
    bar.update(1, "done")
    bar.close()
    lines = out.getvalue().splitlines()
    assert "nec square-10: 1/3 freq" in lines[0] and "already done" in lines[0]
    assert "2/3 freq" in lines[1] and lines[-1].endswith("done") and "3/3 freq" in lines[-1]


def test_throttled_but_always_the_last():
    out = io.StringIO()
    bar = Progress(100, "sky", "LST", every_s=3600.0, stream=out)
    for _ in range(100):
        bar.update()
    lines = out.getvalue().splitlines()
    assert len(lines) == 2 and "1/100" in lines[0] and "100/100" in lines[1]
