"""``sescid poses --seed 0`` writes the same bytes whatever the CPU: run in subprocesses on the
host CPU and as a generic x86-64 (numba's ``NUMBA_CPU_NAME=generic``: no FMA, no AVX; OpenBLAS's
oldest kernels), on the OP2 (uniform draws), on the synthetic humanoid (the CoM-Jacobian
search), for the OP2's torque rows held by its torso (the block search, a gantry) and over
three stances (both feet, the other foot, the torso held), and the files compared byte for
byte."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from refs import write_humanoid

GENERIC = {"NUMBA_CPU_NAME": "generic", "OPENBLAS_CORETYPE": "Prescott"}


def _poses(out, robot_args, extra_env) -> bytes:
    env = {k: v for k, v in os.environ.items() if k not in GENERIC} | extra_env
    args = [*robot_args, "--count", "22", "--candidates", "300", "--test-poses", "100",
            "--seed", "0", "--out", str(out)]  # fmt: skip
    code = "import sys; from _sescid_launch import main; sys.argv[:1] = ['sescid', 'poses']; main()"
    res = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True,
                         text=True, timeout=600)  # fmt: skip
    assert res.returncode == 0, res.stderr + res.stdout
    return out.read_bytes()


@pytest.mark.parametrize("which", ["op2", "humanoid", "op2-tau-gantry", "op2-stances"])
def test_poses_same_bytes_on_a_generic_cpu(tmp_path, which):
    if which == "op2":
        robot_args = ["--robot", "op2"]
    elif which == "op2-tau-gantry":
        robot_args = ["--robot", "op2", "--support", "MP_BODY", "--kinds", "tau"]
    elif which == "op2-stances":  # both feet closed by Newton's method, three stances pooled
        robot_args = ["--robot", "op2", "--stances", "double,l_sole,gantry:MP_BODY", "--kinds",
                      "both", "--stance-cost", "0"]  # fmt: skip
    else:
        robot_args = ["--robot", str(write_humanoid(tmp_path)), "--support", "legA_sole"]
    host = _poses(tmp_path / "host.csv", robot_args, {})
    generic = _poses(tmp_path / "generic.csv", robot_args, GENERIC)
    assert host == generic
    assert host.count(b"\n") == 23  # header + 22 poses (the minimum: min_poses)
    if which == "op2-stances":
        used = {r.split(b",")[1] for r in host.split()[1:]}
        assert len(used) >= 2 and used <= {b"double", b"l_sole", b"MP_BODY"}
