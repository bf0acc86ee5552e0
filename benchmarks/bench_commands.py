"""Benchmark: what a user waits for — command start-up, and million-row files.

Each figure is printed beside a reference measured in the same run:
- start-up: wall time of ``sescid --version``, ``info``, ``identify``/``predict`` on 38 poses,
  against the floor of ``python -c "import numpy"`` (the interpreter and numpy alone);
- ``make demo`` (``sescid demo``) and the README's six-command walk-through (``poses`` →
  ``experiment`` → ``fsr`` → ``identify`` → ``report`` → ``truth``, each command in a fresh
  process, its wall and CPU time), against the same floor;
- large files: ``simulate`` writing N poses, ``identify`` on that CSV (wall, peak memory), the
  streamed CSV reader against pyarrow's own ``read_csv`` and the ``csv`` module, and the CSV
  writer against pyarrow's ``write_csv`` and the ``csv`` module writing ``repr`` (the same
  bytes), on 10⁵ rows of that file;
- joint torques: ``identify`` on N poses with 20 torques each (its default: the Huber IRLS,
  streamed), beside least squares on the same file (``--no-robust``: one pass); ``measure`` of N
  raw samples with torques (chunks), beside the same log reduced whole in memory (the API's
  ``sensors.fsr`` of ``read_table``): wall time and peak memory;
- with ``--huge``: ``identify`` on 10 N poses (10 ``simulate`` runs joined: a 4.6 GB CSV for
  N = 10⁶, in the temporary folder, deleted after), beside the N-pose figure: time ×10 and the
  same peak memory mean linear time and flat memory. Not part of ``make bench`` (~2 min more).

Wall times are the best of ``--repeat`` runs (each a fresh process); peak memory is the
process's maximum resident set; the load average is printed beside the large-file figures.
Usage: ``python benchmarks/bench_commands.py [--poses 1000000] [--huge]``.
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import NamedTuple

from timing import best_of, environment

CLI = "import sys; from _sescid_launch import main; sys.argv[0] = 'sescid'; main()"


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


#: a fresh process running one command while a thread samples its resident memory every 5 ms;
#: prints its peak RSS and the peaks of its anonymous and file-backed parts (MB; -1 without /proc)
_MEMORY_CHILD = """
import os, resource, sys, threading, time
peak = {"RssAnon": 0, "RssFile": 0}
proc = os.path.exists("/proc/self/status")
def sample():
    while True:
        for line in open("/proc/self/status"):
            key = line.split(":")[0]
            if key in peak:
                peak[key] = max(peak[key], int(line.split()[1]))
        time.sleep(0.005)
if proc:
    threading.Thread(target=sample, daemon=True).start()
if sys.argv[1] == "--code":
    exec(sys.argv[2])
else:
    from _sescid_launch import main
    sys.argv = ["sescid", *sys.argv[1:]]
    try:
        main()
    except SystemExit as exc:
        if exc.code:
            raise
kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(kb / 1024, *((peak[k] / 1024 for k in peak) if proc else (-1, -1)))
"""


class Peak(NamedTuple):
    """One run of a command: wall time (s, the process's start included), peak RSS (MB) and the
    peaks of its anonymous memory (what it allocated) and of its file-backed pages (shared
    libraries — numba's LLVM is a 179 MB library — and mapped files, which depend on the page
    cache), MB, nan where the system does not say."""

    wall: float
    mb: float
    anon: float
    file: float


def peak_of(args: list[str], cwd: Path) -> Peak:
    """Wall time and memory of one run of ``sescid ARGS`` (or ``--code SOURCE``: Python) in a
    fresh process."""
    t = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", _MEMORY_CHILD, *args], cwd=cwd, check=True,
                         capture_output=True, text=True, env=_env())  # fmt: skip
    wall = time.perf_counter() - t
    mb, anon, file = (float(x) for x in out.stdout.split()[-3:])
    return Peak(wall, mb, *(x if x >= 0 else float("nan") for x in (anon, file)))


def readers(path: Path) -> dict[str, float]:
    """Seconds to read ``path``: sescid's streamed reader, pyarrow.read_csv, the csv module."""
    import pyarrow.csv as pcsv

    from sescid.tables import iter_table

    out = {
        "sescid iter_table": best_of(lambda: sum(t.n for t in iter_table(path)), 3),
        "pyarrow read_csv (threads)": best_of(lambda: pcsv.read_csv(path), 3),
    }

    def plain():
        with path.open(newline="") as fh:
            return list(csv.reader(fh))

    out["csv module (rows only)"] = best_of(plain, 1)
    return out


def writers(path: Path, out: Path) -> dict[str, float]:
    """Seconds to write the float columns of ``path`` as CSV: sescid's writer (two threads, one
    thread), pyarrow's ``write_csv`` (its shortest float form, one thread) and the ``csv``
    module writing ``repr`` (the bytes sescid writes)."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    from sescid.tables import read_table, write_table
    from sescid.tables import write as tables

    cols = read_table(path).columns
    table = pa.table(cols)
    names = list(cols)
    rows = list(zip(*[c.tolist() for c in cols.values()], strict=True))

    def one_thread():
        threads, tables.WRITE_THREADS = tables.WRITE_THREADS, 1
        try:
            write_table(out, cols)
        finally:
            tables.WRITE_THREADS = threads

    def plain():
        with out.open("w", newline="") as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(names)
            w.writerows(rows)

    pa.set_cpu_count(1)
    return {
        f"sescid write_table ({tables.WRITE_THREADS} threads)": best_of(
            lambda: write_table(out, cols), 3
        ),
        "sescid write_table (1 thread)": best_of(one_thread, 3),
        "pyarrow write_csv (1 thread)": best_of(lambda: pcsv.write_csv(table, out), 3),
        "csv module, repr (rows given, 1 run)": best_of(plain, 1),
    }


def load() -> str:
    return "load average " + " ".join(f"{x:.1f}" for x in os.getloadavg())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=1_000_000, help="rows of the large file")
    ap.add_argument("--repeat", type=int, default=3, help="runs per start-up figure")
    ap.add_argument(
        "--huge", action="store_true", help="also identify 10 × --poses poses (not in make bench)"
    )
    args = ap.parse_args()
    print(environment())
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        r = args.repeat
        run(["simulate", "--robot", "op2", "--count", "38", "--seed", "0", "--out", "s38.csv"], d)
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
        print(f"large files ({n} poses of the OP2, best of {r} fresh processes; {load()})")
        figures = large(n, d, r)
        print(f"joint torques ({n} poses, {n} raw samples; {load()})")
        torques(n, d)
        small = d / "rows1e5.csv"
        with (d / "big.csv").open() as src, small.open("w") as dst:
            for i, line in enumerate(src):
                if i > 100_000:
                    break
                dst.write(line)
        print("  reading 10⁵ rows (same file's head), best of 3:")
        for label, t in readers(small).items():
            print(f"    {label:<38} {t:6.2f} s")
        print(f"  writing those 10⁵ rows (24 float64 columns), best of 3 ({load()}):")
        for label, t in writers(small, d / "w.csv").items():
            print(f"    {label:<38} {t:6.2f} s")
        (d / "big.csv").unlink()
        if args.huge:
            print(f"huge file ({10 * n} poses: 10 simulate runs joined; {load()})")
            wall, mb = huge_csv(n, d)
            print(f"  {'identify huge.csv':<40} {wall:6.2f} s  {mb:5.0f} MB peak")
            w1, m1 = figures[1]
            print(f"  ×{wall / w1:.1f} the time of {n} poses, ×{mb / m1:.2f} the peak memory")
            (d / "huge.csv").unlink()


def huge_csv(n: int, d: Path) -> tuple[float, float]:
    """Wall and peak memory of ``identify`` on 10 n poses: 10 ``simulate`` runs of n poses
    (seeds 1–10) joined into one CSV (one header)."""
    with (d / "huge.csv").open("wb") as dst:
        for seed in range(1, 11):
            part = d / "part.csv"
            sim = ["simulate", "--robot", "op2", "--count", str(n), "--seed", str(seed)]
            run([*sim, "--out", part.name], d)
            with part.open("rb") as src:
                if seed > 1:
                    src.readline()
                shutil.copyfileobj(src, dst, 1 << 24)
            part.unlink()
    fit = peak_of(["identify", "huge.csv", "--robot", "op2", "--out", "huge.json"], d)
    return fit.wall, fit.mb


#: the whole-log reduction in memory (the reference of the chunked ``measure``)
_MEASURE_WHOLE = """
import sescid
from sescid.tables import read_table
from sescid.sensors import fsr, load_sensors
robot = sescid.load_robot("op2")
fsr(robot, read_table("raw.csv"), load_sensors(None, robot.profile))
"""


def torques(n: int, d: Path) -> None:
    """``identify`` of n poses with 20 joint torques (default: Huber IRLS, streamed) beside
    least squares (``--no-robust``), and ``measure`` of n raw samples with torques (chunks)
    beside the whole log reduced in memory: wall time and peak memory of one run each."""
    run(["simulate", "--robot", "op2", "--poses", str(n), "--measure", "tau", "--seed", "0",
         "--out", "tau.csv"], d)  # fmt: skip
    fit = ["identify", "tau.csv", "--robot", "op2", "--out", "tau.json", "--force"]
    poses = max(n // 100, 21)
    run(["poses", "--robot", "op2", "--select", "random", "--count", str(poses), "--seed", "1",
         "--out", "p.csv"], d)  # fmt: skip
    run(["experiment", "--robot", "op2", "--poses", "p.csv", "--samples", str(n // poses),
         "--torques", "all", "--seed", "2", "--out", "raw.csv"], d)  # fmt: skip
    measure = ["measure", "raw.csv", "--robot", "op2", "--poses", "p.csv", "--out", "m.csv"]
    for label, args, target in [
        ("identify tau.csv (Huber IRLS, default)", fit, "≤ 500 MB"),
        ("  reference: --no-robust (least squares)", [*fit, "--no-robust"], ""),
        ("measure raw.csv (chunks)", measure, "≤ 1 GB"),
        ("  reference: the whole log in memory", ["--code", _MEASURE_WHOLE], ""),
    ]:
        r = peak_of(args, d)
        aim = f"   (target {target} for 10⁶)" if target else ""
        print(
            f"  {label:<40} {r.wall:6.2f} s  {r.mb:5.0f} MB peak (anonymous {r.anon:.0f} MB){aim}"
        )
    for name in ("tau.csv", "raw.csv"):
        (d / name).unlink()


def large(n: int, d: Path, repeat: int) -> list[tuple[float, float]]:
    """Best wall and highest peak memory of ``repeat`` runs of ``simulate`` of n poses into
    big.csv and of ``identify`` of it."""
    sim = ["simulate", "--robot", "op2", "--count", str(n), "--seed", "0", "--out", "big.csv"]
    fit = ["identify", "big.csv", "--robot", "op2", "--out", "big.json", "--force"]
    out = []
    for what, args, target in [
        ("simulate", sim, "≤ 4 s"),
        ("identify big.csv", fit, "≤ 5 s, ≤ 300 MB"),
    ]:
        runs = []
        for _ in range(repeat):
            if what == "simulate":
                (d / "big.csv").unlink(missing_ok=True)  # a fresh file each time
            runs.append(peak_of(args, d))
        wall, mb = min(r.wall for r in runs), max(r.mb for r in runs)
        if what == "simulate":
            what = f"simulate --count {n} ({(d / 'big.csv').stat().st_size / 2**20:.0f} MB CSV)"
        print(f"  {what:<40} {wall:6.2f} s  {mb:5.0f} MB peak   (target {target} for 10⁶)")
        anon, file = max(r.anon for r in runs), max(r.file for r in runs)
        if what == "identify big.csv" and anon == anon:  # not nan: the system says
            print(
                f"    of which anonymous (sescid's arrays, the interpreter) {anon:.0f} MB at "
                f"most, file-backed (shared libraries, mapped files) {file:.0f} MB at most"
            )
        out.append((wall, mb))
    shm = Path("/dev/shm")
    if shm.is_dir() and os.access(shm, os.W_OK):  # the same into memory: the disk's share
        target = shm / f"sescid-bench-{os.getpid()}.csv"
        try:
            runs = []
            for _ in range(repeat):
                target.unlink(missing_ok=True)
                runs.append(peak_of([*sim[:-1], str(target)], d).wall)
            print(f"  {'  the same into /dev/shm (no disk)':<40} {min(runs):6.2f} s")
        finally:
            target.unlink(missing_ok=True)
    return out


if __name__ == "__main__":
    main()
