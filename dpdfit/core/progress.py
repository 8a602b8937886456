"""A minimal progress display for long loops (stderr; silent when not wanted).

Hand-written because none of the project's dependencies provides one
(tqdm is not a dependency); it prints ``label: k/n (elapsed)`` on one updating
line when stderr is a terminal and a few plain lines otherwise (CI logs).
"""

from __future__ import annotations

import sys
import time

__all__ = ["Progress"]


class Progress:
    """``with Progress(label, total) as p: ... p.update()``."""

    def __init__(self, label: str, total: int, *, enabled: bool = True, stream=None):
        self.label, self.total, self.enabled = label, int(total), enabled
        self.stream = stream or sys.stderr
        self.k = 0
        self.t0 = time.perf_counter()
        self.tty = getattr(self.stream, "isatty", lambda: False)()
        self._last_pct = -1

    def __enter__(self):
        return self

    def update(self, n: int = 1) -> None:
        self.k += n
        if not self.enabled:
            return
        dt = time.perf_counter() - self.t0
        if self.tty:
            self.stream.write(f"\r{self.label}: {self.k}/{self.total} ({dt:.1f} s)")
            self.stream.flush()
        else:
            pct = int(100 * self.k / max(self.total, 1)) // 25 * 25
            if pct != self._last_pct:
                self._last_pct = pct
                self.stream.write(f"{self.label}: {self.k}/{self.total} ({dt:.1f} s)\n")

    def __exit__(self, *exc):
        if self.enabled and self.tty:
            self.stream.write("\n")
        return False
