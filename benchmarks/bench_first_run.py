"""Benchmark: the first command after a fresh plain install, against the second.

Two fresh virtual environments get a plain ``pip install`` of this tree's tracked files (each
install its own copy in a temporary folder: setuptools keeps ``build/`` in the source folder,
and a wheel built there again would carry the earlier build's files):

- as a user installs it: the wheel is built with the kernels compiled in (``sescid
  precompile`` at build time, ``tools/build_backend``);
- the reference, in the same run: ``SESCID_PRECOMPILE=0`` (the wheel without kernels: they
  compile on first use, as before).

In each, ``sescid poses`` (the README's walk-through's first command) runs twice, each a fresh
process; printed: the install's wall time, each run's wall and CPU time (user + system), and the
first run's excess over the second (target: within 3 s). Takes 3–6 minutes (two installs).
Usage: ``python benchmarks/bench_first_run.py [--command "poses --kinds tau --out p.csv"]``.
"""

from __future__ import annotations

import argparse
import os
import resource
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from timing import environment

ROOT = Path(__file__).resolve().parents[1]
POSES = "poses --robot op2 --count 38 --select d-optimal --seed 0 --out poses.csv --force"


def copy_tree(dst: Path) -> None:
    """This tree's tracked files (as they are in the working tree) into ``dst``."""
    files = subprocess.run(
        ["git", "ls-files", "-z"], cwd=ROOT, check=True, capture_output=True
    ).stdout.split(b"\0")
    for name in filter(None, files):
        src = ROOT / os.fsdecode(name)
        if src.is_file():
            (dst / os.fsdecode(name)).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dst / os.fsdecode(name))


def clean_env(**extra: str) -> dict[str, str]:
    """The environment without this venv's or numba's settings (a user's shell)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "PYTHON"))}
    env.pop("VIRTUAL_ENV", None)
    env.update(extra)
    return env


def timed(args: list[str], cwd: Path, env: dict[str, str]) -> tuple[float, float]:
    """Wall and CPU time (user + system, s) of one process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run(args, cwd=cwd, env=env, check=True, capture_output=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def install(root: Path, src: Path, label: str, **extra: str) -> tuple[Path, float]:
    """A fresh venv with a plain ``pip install`` of ``src``; its bin folder and the install's
    wall time (pip's own upgrade excluded)."""
    venv = root / label
    env = clean_env(**extra)
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, env=env)
    pip = [str(venv / "bin" / "python"), "-m", "pip", "install", "-q"]
    subprocess.run([*pip, "--upgrade", "pip"], check=True, env=env, capture_output=True)
    t = time.perf_counter()
    done = subprocess.run([*pip, str(src)], env=env, capture_output=True, text=True)
    if done.returncode:
        sys.exit(f"pip install failed ({label}):\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}")
    return venv / "bin", time.perf_counter() - t


def versions(bin_dir: Path) -> str:
    """numpy, numba, llvmlite and scipy versions of a venv."""
    out = subprocess.run([str(bin_dir / "python"), "-m", "pip", "list", "--format=freeze"],
                         check=True, capture_output=True, text=True).stdout  # fmt: skip
    keep = ("numpy==", "numba==", "llvmlite==", "scipy==", "setuptools==")
    return ", ".join(line for line in out.splitlines() if line.lower().startswith(keep))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--command", default=POSES, help="the sescid command timed (without 'sescid')")
    args = ap.parse_args()
    command = shlex.split(args.command)
    print(environment())
    with tempfile.TemporaryDirectory(prefix="sescid-first-run-") as tmp:
        root = Path(tmp)
        rows = []
        for label, extra in [("wheel with kernels", {}), ("reference: SESCID_PRECOMPILE=0", {
            "SESCID_PRECOMPILE": "0"})]:  # fmt: skip
            src = root / f"src-tree-{len(rows)}"  # its own copy: setuptools keeps build/ in it
            copy_tree(src)
            bin_dir, took = install(root, src, label.split(":")[0].replace(" ", "_"), **extra)
            work = root / f"work-{len(rows)}"
            work.mkdir()
            env = clean_env()
            runs = [timed([str(bin_dir / "sescid"), *command], work, env) for _ in range(2)]
            rows.append((label, took, runs))
            if len(rows) == 1:
                print("  the fresh install's " + versions(bin_dir))
        print(f"sescid {' '.join(command)}, each run a fresh process (load average "
              f"{os.getloadavg()[0]:.1f})")  # fmt: skip
        print(f"  {'':<34} {'install':>8} {'1st wall':>9} {'2nd wall':>9} {'1st CPU':>8} "
              f"{'2nd CPU':>8} {'1st − 2nd':>10}")  # fmt: skip
        for label, took, ((w1, c1), (w2, c2)) in rows:
            print(f"  {label:<34} {took:7.1f}s {w1:8.2f}s {w2:8.2f}s {c1:7.2f}s {c2:7.2f}s "
                  f"{w1 - w2:9.2f}s")  # fmt: skip
        (w1, _), (w2, _) = rows[0][2]
        print(f"  target: the first run within 3 s of the second: {w1 - w2:.2f} s "
              f"({'met' if w1 - w2 <= 3.0 else 'NOT met'})")  # fmt: skip


if __name__ == "__main__":
    main()
