"""Figures drawn on two cores: a forked child draws some of them while this process draws the
others (matplotlib draws on one core, and a figure costs ~0.1–0.3 s).

The child is forked after matplotlib and the data are loaded, so it starts in milliseconds
(a fresh process would pay the 0.5 s import again). Only on Linux with two usable cores; the
child writes its files (atomically, as every figure) and exits; if it fails, its figures are
drawn again here, so an error is raised exactly as without it.
"""

from __future__ import annotations

import os
import signal
import sys
import time
from collections.abc import Callable, Sequence


def _usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def can_fork() -> bool:
    """True where a forked child may draw figures: Linux (fork is safe for matplotlib's Agg
    canvas there; not on macOS) with at least two cores this process may use."""
    return sys.platform.startswith("linux") and hasattr(os, "fork") and _usable_cores() >= 2


def run_figures(
    jobs: Sequence[Callable[[], object]],
    progress: Callable[[int], None] | None = None,
    fork: bool | None = None,
) -> None:
    """Run ``jobs`` (each draws and writes one figure): the first half here, the rest in a
    forked child meanwhile (``fork``: None = where ``can_fork``). ``progress(done)`` is called
    as figures are written here and once the child's are. A child that fails, or is not done
    ``CHILD_TIMEOUT`` s after this process's share, is stopped and its jobs run here."""
    jobs = list(jobs)
    split = (len(jobs) + 1) // 2
    pid = -1
    if len(jobs) > 1 and (can_fork() if fork is None else fork):
        import matplotlib.backends.backend_agg  # noqa: F401  # once, here: the child inherits it
        import matplotlib.figure  # noqa: F401

        sys.stdout.flush()
        sys.stderr.flush()
        try:
            pid = os.fork()
        except OSError:  # no process to spare (limits, sandbox): draw them all here
            pid = -1
        if pid == 0:  # the child: its jobs, then leave without running any exit handler
            code = 1
            try:
                for job in jobs[split:]:
                    job()
                code = 0
            finally:
                os._exit(code)
    mine = jobs[:split] if pid > 0 else jobs
    try:
        for k, job in enumerate(mine):
            job()
            if progress is not None:
                progress(k + 1)
    finally:
        child_ok = pid <= 0 or _wait(pid)
    if pid > 0:
        if not child_ok:  # draw them here: the same files, or the error they raise
            for job in jobs[split:]:
                job()
        if progress is not None:
            progress(len(jobs))


#: seconds the child may take beyond this process's share before it is stopped and its
#: figures are drawn here (a figure takes ~0.1–0.3 s; a stuck child must not hang a command)
CHILD_TIMEOUT = 60.0


def _wait(pid: int) -> bool:
    """Wait for the child up to ``CHILD_TIMEOUT`` s (then kill it); True if it exited with
    status 0."""
    deadline = time.monotonic() + CHILD_TIMEOUT
    delay = 0.001
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            return os.waitstatus_to_exitcode(status) == 0
        if time.monotonic() > deadline:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            return False
        time.sleep(delay)
        delay = min(2 * delay, 0.01)
