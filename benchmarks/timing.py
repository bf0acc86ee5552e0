"""Timing helper shared by the benchmark scripts."""

from __future__ import annotations

import time


def best_of(f, repeat: int = 5) -> float:
    """Shortest wall time of ``repeat`` calls of ``f()``, in seconds."""
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return min(times)
