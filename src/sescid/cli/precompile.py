"""``sescid precompile``: compile the numba kernels the commands use, now, into numba's cache.

A plain ``pip install .`` (or ``pip wheel .``) runs this while it builds the wheel
(``tools/build_backend/sescid_build.py``), so the first ``sescid poses`` after installing
loads its kernels instead of compiling them (10–20 s). numba's cache is keyed by the numba
version, the kernels' source, their signatures and the CPU (name and features): run the
command yourself where the wheel's kernels do not fit — a wheel built on another CPU or with
another numba, an install built with ``SESCID_PRECOMPILE=0``, a cache folder of your own
(``NUMBA_CACHE_DIR``). Where the package folder is read-only, numba caches in the user's
folder (seeded from the package's).

It runs the commands users wait for (``WORKLOAD``) on the embedded OP2 in a temporary folder,
with files large enough for the compiled path (``kinematics.NUMPY_JOB``), and discards their
output; and the API's one-pose CoM and collision check. A robot other than the OP2 takes the
same kernels (they are compiled per argument type, not per robot).
"""

from __future__ import annotations

import contextlib
import io
import os
import tempfile
import time

import click
import numpy as np

#: poses of the files the fits read: above ``kinematics.NUMPY_JOB`` for the OP2's CoP rows
#: (147 work units a pose), so ``identify`` and ``predict`` take the compiled path
FILE_POSES = "20000"
#: a short plan (the kernels do not depend on the counts)
PLAN = ("--candidates", "1000", "--test-poses", "100", "--seed", "0")

#: the commands run, in order, in one temporary folder
WORKLOAD: tuple[tuple[str, ...], ...] = (
    ("poses", *PLAN, "--out", "p.csv"),
    ("poses", *PLAN, "--kinds", "tau", "--out", "pt.csv"),
    ("poses", *PLAN, "--kinds", "both", "--out", "pb.csv"),
    ("poses", *PLAN, "--kinds", "tau", "--mount", "gantry", "--support", "MP_BODY",
     "--out", "pg.csv"),
    ("simulate", "--poses", FILE_POSES, "--measure", "both", "--out", "s.csv"),
    ("identify", "s.csv", "--out", "f.json"),
    ("identify", "s.csv", "--kinds", "cop", "--out", "fc.json"),
    ("identify", "s.csv", "--kinds", "tau", "--out", "ft.json"),
    ("identify", "s.csv", "--kinds", "all", "--out", "fb.json"),
    ("predict", "fb.json", "s.csv", "--out", "pr.csv"),
    ("simulate", "--poses", FILE_POSES, "--measure", "both", "--tau-friction", "0.02",
     "--out", "a.csv"),
    ("identify", "a.csv", "--kinds", "all", "--out", "fa.json"),
    ("simulate", "--poses", FILE_POSES, "--tilt-deg", "2", "--out", "t.csv"),
    ("identify", "t.csv", "--out", "ftilt.json"),
    ("experiment", "--poses", "p.csv", "--samples", "20", "--torques", "all", "--out", "raw.csv"),
    ("measure", "raw.csv", "--poses", "p.csv", "--out", "m.csv"),
)  # fmt: skip


def run_workload(folder: str, progress=None) -> list[str]:
    """Run ``WORKLOAD`` in ``folder`` (its output discarded); the kernels compiled (not loaded
    from numba's cache), by name. ``progress(done, total)`` after each command. Raises
    ``SescidError`` naming the command that failed."""
    from sescid.cli import cli
    from sescid.errors import SescidError
    from sescid.kinematics import counting_compiles, load_kernels
    from sescid.planning import collision_capsules, collision_free_mask
    from sescid.robot import load_robot

    cwd = os.getcwd()
    os.chdir(folder)
    try:
        with counting_compiles() as names:
            load_kernels()  # the single-pose kernel (robot.com) too, not only what jobs call
            robot = load_robot("op2")
            robot.com([0.0] * robot.nq)
            # the API's collision check (the commands use the broad phase's)
            rot, org = robot.forward(np.zeros((1, robot.nq)))
            collision_free_mask(collision_capsules(robot), rot, org)
            for done, args in enumerate(WORKLOAD, 1):
                sink = io.StringIO()
                try:
                    with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
                        cli.main(args=list(args), prog_name="sescid", standalone_mode=False)
                except (Exception, SystemExit) as exc:  # noqa: BLE001 - named in one line
                    said = sink.getvalue().strip().splitlines()[-1:] or [repr(exc)]
                    raise SescidError(f"precompile: sescid {' '.join(args)}: {said[0]}") from exc
                if progress is not None:
                    progress(done, len(WORKLOAD))
    finally:
        os.chdir(cwd)
    return names


@click.command()
def precompile():
    """Compile the numba kernels the commands use into numba's on-disk cache now, so that no
    command compiles them on its first run. A pip install does this when it builds the wheel;
    run it where that did not happen or does not fit: an install moved to another CPU or numba
    version, SESCID_PRECOMPILE=0, a NUMBA_CACHE_DIR of your own. Prints where the cache is."""
    from sescid.base import TerminalProgress
    from sescid.errors import SescidError
    from sescid.kinematics import cache_folder

    start = time.perf_counter()
    with (
        tempfile.TemporaryDirectory(prefix="sescid-precompile-") as folder,
        TerminalProgress("precompile: commands run") as progress,
    ):
        names = run_workload(folder, progress)
    took = time.perf_counter() - start
    where = cache_folder()
    if where is None:
        raise SescidError(
            "precompile: numba has no cache folder it can write, so the kernels compiled for "
            "this process only: set NUMBA_CACHE_DIR to a folder of yours"
        )
    if names:
        click.echo(
            f"compiled {len(set(names))} kernels for this CPU in {took:.1f} s "
            f"({len(WORKLOAD)} commands on the OP2); later runs load them from numba's cache"
        )
    else:
        click.echo(f"every kernel was already compiled for this CPU ({took:.1f} s)")
    click.echo(f"numba's cache: {where}")
