"""Progress is drawn on a terminal only."""

from __future__ import annotations

import io

from sescid.estimate import identify
from sescid.progress import TerminalProgress
from sescid.simulate import simulate


class FakeTTY(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_quiet_when_piped_and_drawn_on_a_terminal(op2):
    sim = simulate(op2, 5000, seed=0)
    piped, tty = io.StringIO(), FakeTTY()
    for stream in (piped, tty):
        with TerminalProgress("identify", stream=stream, delay=0.0) as bar:
            identify(op2, sim.q, sim.cop, progress=bar)
    assert piped.getvalue() == ""
    text = tty.getvalue()
    assert "identify: 2048/5000 (41%)" in text and "5000/5000 (100%)" in text
    assert text.endswith("\n")
