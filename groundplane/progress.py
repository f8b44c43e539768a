"""Progress on stderr for long work (solves, sweeps, the sky transform): a tqdm bar on a
terminal, plain timestamped lines otherwise (logs, CI, a batch queue), so a run that
takes minutes is never silent."""
from __future__ import annotations

import sys
import time
from typing import Any


class Progress:
    """``update()`` per finished item; ``close()`` at the end. Plain mode prints a line
    per item, at most one every ``every_s`` seconds, and always the last."""

    def __init__(self, total: int, desc: str, unit: str = "it", initial: int = 0, every_s: float = 10.0,
                 stream: Any = None) -> None:
        self.stream = stream or sys.stderr
        self.total, self.desc, self.unit, self.n = total, desc, unit, initial
        self.every_s, self.t0, self.last = every_s, time.monotonic(), -1e9
        self.bar = None
        if getattr(self.stream, "isatty", lambda: False)():
            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=initial, desc=desc, unit=unit, file=self.stream)
        elif initial:
            self._line(f"{initial} already done")

    def _line(self, extra: str = "") -> None:
        el = time.monotonic() - self.t0
        print(f"[{time.strftime('%H:%M:%S')}] {self.desc}: {self.n}/{self.total} {self.unit} "
              f"({el:.0f} s){' ' + extra if extra else ''}", file=self.stream, flush=True)
        self.last = time.monotonic()

    def update(self, n: int = 1, note: str = "") -> None:
        self.n += n
        if self.bar is not None:
            self.bar.update(n)
            if note:
                self.bar.set_postfix_str(note)
        elif self.n >= self.total or time.monotonic() - self.last >= self.every_s or note:
            self._line(note)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
