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


def best_of_both(f, repeat: int = 5) -> tuple[float, float]:
    """Shortest wall time and shortest CPU time of this process (all its threads: spinning BLAS
    threads count) of ``repeat`` calls of ``f()``, in seconds."""
    wall, cpu = [], []
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        f()
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return min(wall), min(cpu)
