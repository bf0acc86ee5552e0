"""The same bytes on every CPU: fits and the demo computed with the kernels compiled for a
generic x86-64 (no FMA instruction, 128-bit vectors: ``NUMBA_CPU_NAME=generic``) and for this
machine's CPU are the same files, byte for byte; no kernel of the package asks for fastmath."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: in a fresh process: the demo (numpy path), a CLI fit of a file large enough for the compiled
#: fused pass, and an API fit of CoPs and joint torques with friction (the torque kernels)
SCRIPT = r"""
import sys
from pathlib import Path
import numpy as np
import sescid
from sescid.cli import main
out = Path(sys.argv[1])

def cli(*args):
    sys.argv = ["sescid", *args]
    try:
        main()
    except SystemExit as exc:
        assert not exc.code, exc.code

import os
os.chdir(out)  # files named as a user names them: the fit's messages quote the data file's name
cli("demo", "--out-dir", "demo")
cli("simulate", "--robot", "op2", "--count", "25000", "--seed", "3", "--out", "s.csv")
cli("identify", "s.csv", "--robot", "op2", "--out", "cli_fit.json")
robot = sescid.load_robot("op2")
rng = np.random.default_rng(7)
n = 5000
q = rng.uniform(-0.6, 0.6, (n, robot.nq))
names = tuple(robot.joint_names[::2])
tau = robot.torques(q, joints=names) + rng.normal(0, 0.05, (n, len(names)))
side = rng.choice([-1.0, 1.0], n)
cop = robot.cop(q) + rng.normal(0, 0.005, (n, 2))
data = sescid.Measurements(q=q, cop=cop, tau=tau + 0.1 * side[:, None], tau_joints=names,
                           approach=side)
sescid.save_fit(sescid.identify(robot, data, total_mass=robot.total_mass), out / "api_fit.json")
"""


def _run(tmp: Path, cpu: str | None) -> dict[str, bytes]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_CPU")}
    env["PYTHONPATH"] = str(ROOT / "src")
    if cpu:
        env["NUMBA_CPU_NAME"] = cpu
    out = tmp / (cpu or "host")
    out.mkdir()
    res = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(out)], env=env, capture_output=True, text=True
    )
    assert res.returncode == 0, res.stderr[-3000:]
    files = ["demo/fit.json", "demo/summary.csv", "cli_fit.json", "api_fit.json"]
    return {f: (out / f).read_bytes() for f in files}


def test_fits_are_the_same_bytes_on_a_generic_cpu(tmp_path):
    host, generic = _run(tmp_path, None), _run(tmp_path, "generic")
    for name, data in host.items():
        assert data == generic[name], f"{name} differs between the host CPU and a generic one"


def test_no_kernel_of_the_package_uses_fastmath():
    """``fastmath`` lets LLVM contract and reassociate by CPU; the package's kernels use explicit
    FMAs (``kinematics._kernels.simd``) instead. (Planning's kernels are another area's.)"""
    src = ROOT / "src" / "sescid"
    mine = [*src.glob("kinematics/**/*.py"), *src.glob("estimation/**/*.py")]
    hits = [f"{p.name}" for p in mine if re.search(r"fastmath\s*=", p.read_text())]
    assert not hits, hits


@pytest.mark.parametrize("core", ["Prescott"])
def test_the_command_line_pins_openblas_to_its_baseline_kernels(core):
    """On x86-64 the ``sescid`` command asks OpenBLAS for its SSE3 kernels (the same code on every
    x86-64 CPU), keeping a choice the user made."""
    from sescid.base import threads

    code = (
        "import os, _sescid_launch\n_sescid_launch.pin_blas()\n"
        "print(os.environ.get('OPENBLAS_CORETYPE'))\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    env["PYTHONPATH"] = str(ROOT / "src")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    import platform

    expect = threads.BLAS_CORE if platform.machine().lower() in ("x86_64", "amd64") else "None"
    assert out.stdout.strip() == expect == (core if expect != "None" else "None")
    env["OPENBLAS_CORETYPE"] = "Haswell"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.stdout.strip() == "Haswell"
