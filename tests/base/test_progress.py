"""Progress is drawn on a terminal only."""

from __future__ import annotations

import io

from fitting import identify_ls

from sescid.base.progress import TerminalProgress
from sescid.simulation import simulate


class FakeTTY(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_quiet_when_piped_and_drawn_on_a_terminal(op2):
    sim = simulate(op2, 5000, seed=0)
    piped, tty = io.StringIO(), FakeTTY()
    for stream in (piped, tty):
        with TerminalProgress("identify", stream=stream, delay=0.0) as bar:
            identify_ls(op2, sim.q, sim.cop, progress=bar)
    assert piped.getvalue() == ""
    text = tty.getvalue()
    assert "identify: 2048/5000 (41%)" in text and "5000/5000 (100%)" in text
    assert text.endswith("\n")


def test_line_ends_when_done_and_repeats_are_not_redrawn():
    tty = FakeTTY()
    bar = TerminalProgress("fold", stream=tty, delay=0.0)
    for i in range(1, 4):
        bar(i, 3)
    bar(3, 3)  # a caller reporting completion twice
    bar(1, 2)  # a second run with the same object starts a new line
    bar(2, 2)
    bar.close()
    assert tty.getvalue() == (
        "\rfold: 1/3 (33%)\rfold: 2/3 (67%)\rfold: 3/3 (100%)\n"
        "\rfold: 1/2 (50%)\rfold: 2/2 (100%)\n"
    )
