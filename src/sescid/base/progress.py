"""Progress on a terminal: a callback ``(done, total)`` that draws on stderr only for a TTY.

The line ends when ``done`` reaches ``total`` (or on ``close()``), so one object can serve
several consecutive runs (CV folds, chunks).
"""

from __future__ import annotations

import sys
import time


class TerminalProgress:
    """Call with (done, total); silent when stderr is not a terminal or the work is quick."""

    def __init__(self, label: str, stream=None, delay: float = 1.0):
        self.label = label
        self.stream = stream or sys.stderr
        self.start = time.perf_counter()
        self.delay = delay  #: s before anything is drawn, so quick work stays quiet
        self.drawn = False
        self.last: tuple[int, int] | None = None
        self.enabled = bool(getattr(self.stream, "isatty", lambda: False)())

    def __call__(self, done: int, total: int) -> None:
        """Report ``done`` of ``total`` (redraws at most every ``delay`` s)."""
        if not self.enabled or time.perf_counter() - self.start < self.delay:
            return
        if (done, total) == self.last:  # the same state again: nothing new to draw
            return
        self.last = (done, total)
        frac = done / total if total else 1.0
        self.stream.write(f"\r{self.label}: {done}/{total} ({frac:.0%})")
        self.drawn = True
        if done >= total:  # finished: end the line, a later call starts a new one
            self.close()
        self.stream.flush()

    def close(self) -> None:
        """End the progress line (if one was drawn)."""
        if self.drawn:
            self.stream.write("\n")
            self.stream.flush()
            self.drawn = False

    def __enter__(self) -> TerminalProgress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
