"""Benchmark: what a user waits for — command start-up, and million-row files.

Each figure is printed beside a reference measured in the same run:
- start-up: wall time of ``sescid --version``, ``info``, ``identify``/``predict`` on 38 poses,
  against the floor of ``python -c "import numpy"`` (the interpreter and numpy alone);
- ``make demo`` (``sescid demo``) and the README's six-command walk-through (``poses`` →
  ``experiment`` → ``fsr`` → ``identify`` → ``report`` → ``truth``, each command in a fresh
  process, its wall and CPU time), against the same floor;
- large files: ``simulate`` writing N poses, ``identify`` on that CSV (wall, peak memory), and
  the streamed CSV reader against pyarrow's own ``read_csv`` and the ``csv`` module (on 10⁵
  rows) as references.

Wall times are the best of ``--repeat`` runs (each a fresh process); peak memory is the
process's maximum resident set. Usage: ``python benchmarks/bench_commands.py [--poses 1000000]``.
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from timing import best_of

CLI = "import sys; from sescid.cli import main; sys.argv[0] = 'sescid'; main()"


def _env() -> dict[str, str]:
    """The environment of the timed processes: this sescid (absolute path), whatever the cwd."""
    import sescid

    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # warm-up runs leave bytecode, as an install does
    src = str(Path(sescid.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join([src, *filter(None, [env.get("PYTHONPATH")])])
    return env


def run(args: list[str], cwd: Path) -> float:
    """Wall time (s) of one fresh ``sescid`` process."""
    t = time.perf_counter()
    subprocess.run(
        [sys.executable, "-c", CLI, *args], cwd=cwd, check=True, capture_output=True, env=_env()
    )
    return time.perf_counter() - t


def best(args: list[str], cwd: Path, repeat: int) -> float:
    return min(run(args, cwd) for _ in range(repeat))


def floor(repeat: int) -> float:
    def once():
        subprocess.run([sys.executable, "-c", "import numpy"], check=True)

    return best_of(once, repeat)


def _walk_commands() -> list[list[str]]:
    """The README's walk-through, verbatim (one home: ``tools/readme_numbers.COMMANDS``)."""
    path = Path(__file__).resolve().parents[1] / "tools" / "readme_numbers.py"
    spec = importlib.util.spec_from_file_location("readme_numbers", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return [line.split()[1:] for line in mod.COMMANDS]


def timed(args: list[str], cwd: Path) -> tuple[float, float]:
    """Wall and CPU time (user + system of the process and any child it waited for), s."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = run(args, cwd)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def walk_through(root: Path, repeat: int) -> None:
    """``make demo`` and the README walk-through, best of ``repeat`` fresh runs of each command
    (the six in order, each run in its own folder: a command reads the files of the one
    before), with the load average at start and end: wall time on a shared machine is the
    figure, CPU time what it would be alone."""
    load = os.getloadavg()[0]
    for k in range(repeat):
        (root / f"demo{k}").mkdir()
        (root / f"walk{k}").mkdir()
    demo = [timed(["demo", "--out-dir", "demo_out"], root / f"demo{k}") for k in range(repeat)]
    walk = _walk_commands()
    best: list[tuple[float, float]] = [(1e9, 1e9)] * len(walk)
    for k in range(repeat):
        folder = root / f"walk{k}"
        for i, cmd in enumerate(walk):
            wall, cpu = timed(cmd, folder)
            best[i] = (min(best[i][0], wall), min(best[i][1], cpu))
    print(
        f"demo and walk-through (best of {repeat}; load average {load:.1f} → "
        f"{os.getloadavg()[0]:.1f})"
    )
    print(f"  {'':<40} {'wall':>6}   {'CPU':>6}")
    wall, cpu = min(w for w, _ in demo), min(c for _, c in demo)
    print(f"  {'sescid demo (make demo)':<40} {wall:6.2f} s {cpu:6.2f} s   (target ≤ 2 s)")
    for cmd, (wall, cpu) in zip(walk, best, strict=True):
        label = f"sescid {cmd[0]}"
        print(f"  {label:<40} {wall:6.2f} s {cpu:6.2f} s")
    wall, cpu = sum(w for w, _ in best), sum(c for _, c in best)
    print(f"  {'walk-through, six commands':<40} {wall:6.2f} s {cpu:6.2f} s   (target ≤ 8 s)")


def peak_of(args: list[str], cwd: Path) -> tuple[float, float]:
    """Wall and peak RSS of one run, measured by a fresh child (ru_maxrss is per child)."""
    code = (
        "import resource, subprocess, sys, time; t = time.perf_counter(); "
        f"subprocess.run([sys.executable, '-c', {CLI!r}, *sys.argv[1:]], check=True, "
        "capture_output=True); "
        "print(time.perf_counter() - t, "
        "resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, *args],
        cwd=cwd,
        check=True,
        capture_output=True,
        text=True,
        env=_env(),
    )
    wall, mb = out.stdout.split()
    return float(wall), float(mb)


def readers(path: Path) -> dict[str, float]:
    """Seconds to read ``path``: sescid's streamed reader, pyarrow.read_csv, the csv module."""
    import pyarrow.csv as pcsv

    from sescid.io import iter_table

    out = {
        "sescid iter_table": best_of(lambda: sum(t.n for t in iter_table(path)), 3),
        "pyarrow read_csv (threads)": best_of(lambda: pcsv.read_csv(path), 3),
    }

    def plain():
        with path.open(newline="") as fh:
            return list(csv.reader(fh))

    out["csv module (rows only)"] = best_of(plain, 1)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=1_000_000, help="rows of the large file")
    ap.add_argument("--repeat", type=int, default=3, help="runs per start-up figure")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        r = args.repeat
        run(["simulate", "--robot", "op2", "--poses", "38", "--seed", "0", "--out", "s38.csv"], d)
        run(["identify", "s38.csv", "--robot", "op2", "--out", "fit.json"], d)  # numba cache
        print(f"start-up (best of {r} fresh processes)")
        base = floor(r)
        print(f"  reference: python -c 'import numpy'        {base:6.2f} s")
        for label, cmd, target in [
            ("sescid --version", ["--version"], 0.3),
            ("sescid info --robot op2", ["info", "--robot", "op2"], 0.8),
            ("sescid identify (38 poses)", ["identify", "s38.csv", "--out", "f.json"], 1.0),
            (
                "sescid predict (38 poses)",
                ["predict", "fit.json", "s38.csv", "--out", "p.csv"],
                1.0,
            ),
        ]:
            t = best(cmd, d, r)
            print(f"  {label:<40} {t:6.2f} s   (target ≤ {target} s, {t / base:4.1f}× the floor)")
        walk_through(d, r)

        n = args.poses
        print(f"large files ({n} poses of the OP2, one process each)")
        wall, mb = peak_of(
            ["simulate", "--robot", "op2", "--poses", str(n), "--seed", "0", "--out", "big.csv"], d
        )
        size = (d / "big.csv").stat().st_size / 2**20
        print(
            f"  simulate --poses {n} (writes {size:.0f} MB CSV)  {wall:6.2f} s  {mb:5.0f} MB peak"
        )
        wall, mb = peak_of(["identify", "big.csv", "--robot", "op2", "--out", "big.json"], d)
        print(f"  {'identify big.csv':<40} {wall:6.2f} s  {mb:5.0f} MB peak")
        small = d / "rows1e5.csv"
        with (d / "big.csv").open() as src, small.open("w") as dst:
            for i, line in enumerate(src):
                if i > 100_000:
                    break
                dst.write(line)
        print("  reading 10⁵ rows (same file's head), best of 3:")
        for label, t in readers(small).items():
            print(f"    {label:<38} {t:6.2f} s")


if __name__ == "__main__":
    main()
