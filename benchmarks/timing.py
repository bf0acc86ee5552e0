"""Timing helpers shared by the benchmark scripts, and the record of where they ran."""

from __future__ import annotations

import os
import platform
import sys
import time
from importlib import metadata

#: the packages whose versions a figure depends on
PACKAGES = ("numpy", "scipy", "numba", "llvmlite", "pyarrow", "pin", "mujoco")


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


def cpu_name() -> str:
    """The CPU's model name (Linux), else the platform's processor string."""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def load() -> str:
    """The load averages (1, 5, 15 min)."""
    return "load average " + " ".join(f"{x:.1f}" for x in os.getloadavg())


def environment() -> str:
    """Two lines: the machine (CPU, usable cores) and the versions the figures depend on."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    versions = []
    for name in PACKAGES:
        try:
            versions.append(f"{name} {metadata.version(name)}")
        except metadata.PackageNotFoundError:
            versions.append(f"{name} (not installed)")
    blas = os.environ.get("OPENBLAS_CORETYPE", "OpenBLAS's own choice")
    return (
        f"machine: {cpu_name()}, {cores} usable cores, {platform.machine()}; {load()}\n"
        f"versions: Python {sys.version.split()[0]}, {', '.join(versions)}; BLAS kernels: {blas}"
    )


def verdict(ok: bool) -> str:
    """'met' or 'NOT met', beside a target."""
    return "met" if ok else "NOT met"
