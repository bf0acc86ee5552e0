"""``sescid poses`` end to end: the physics check, its missing extra, a support frame that is
not level, unlimited joints stated, and the README physics walk-through's poses standing."""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest
from click.testing import CliRunner
from refs import erd, write_humanoid

import sescid
from sescid import planning as design
from sescid.bench.standing import stands
from sescid.cli import cli
from sescid.planning.feasibility.limits import unlimited_joints
from sescid.tables import read_poses, read_table


def _run(*args):
    return CliRunner().invoke(cli, ["poses", *map(str, args)])


def test_check_mujoco_keeps_only_poses_that_stand(tmp_path, op2):
    """--rigid --check mujoco: the rigid box lets toppling poses in, the check replaces them;
    every written pose stands on the bench (run again here)."""
    out = tmp_path / "p.csv"
    res = _run("--count", 22, "--select", "random", "--candidates", 400, "--test-poses", 100,
               "--seed", 1, "--rigid",
               "--check", "mujoco", "--out", out)  # fmt: skip
    assert res.exit_code == 0, res.output
    line = next(x for x in res.output.splitlines() if "MuJoCo bench check" in x)
    simulated, failed = (int(w) for w in line.split() if w.isdigit())
    assert failed > 0 and simulated >= 21 + failed
    q = read_poses(read_table(out), op2.joint_names, op2.profile.servo)
    assert stands(op2, q).mask.all()


def test_check_mujoco_without_the_extra_is_one_line(tmp_path, monkeypatch):
    find = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda n, *a: None if n == "mujoco" else find(n, *a)
    )
    out = tmp_path / "p.csv"
    res = _run("--count", 22, "--candidates", 300, "--check", "mujoco", "--out", out)
    assert res.exit_code == 2 and not out.exists()
    assert "needs the mujoco extra: pip install 'sescid[mujoco]'" in res.output
    assert "pip install '.[mujoco]'" in res.output  # the form that works in a clone
    assert "Traceback" not in res.output


def test_support_not_level_is_one_line_naming_the_fix(tmp_path):
    path = write_humanoid(tmp_path)
    out = tmp_path / "p.csv"
    res = _run("--robot", path, "--support", "legA_heel", "--count", 22, "--out", out)
    assert res.exit_code == 2 and not out.exists()
    (msg,) = [x for x in res.output.splitlines() if x.startswith("sescid: error:")]
    assert "'legA_heel' is not level" in msg and "legA_sole" in msg


def test_unlimited_joint_sampled_within_the_stated_range(tmp_path):
    """A hinge without a range (MJCF): sampled within ±90°, said in the output and the plan."""
    path = write_humanoid(tmp_path)
    text = path.read_text().replace('name="neck" axis="0 1 0" range="-0.5 0.5"', 'name="neck"'
                                    ' axis="0 1 0"')  # fmt: skip
    path.write_text(text)
    robot = sescid.load_robot(path, "legA_sole")
    assert unlimited_joints(robot) == ["neck"]
    np.testing.assert_allclose(design.sampling_limits(robot)[robot.joint_names.index("neck")],
                               [-math.pi / 2, math.pi / 2])  # fmt: skip
    out = tmp_path / "p.csv"
    res = _run("--robot", path, "--support", "legA_sole", "--count", 22, "--candidates", 200,
               "--test-poses", 50, "--out", out)  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "1 joint(s) without limits sampled within ±90°: neck" in res.output
    plan = sescid.plan_poses(robot, count=22, n_candidates=200, n_test=50)
    assert plan.unlimited == ["neck"] and plan.unlimited_range == pytest.approx(math.pi / 2)
    assert np.all(np.abs(plan.q[:, robot.joint_names.index("neck")]) <= math.pi / 2)
    wide = design.sampling_limits(robot, range_deg=150)[robot.joint_names.index("neck")]
    np.testing.assert_allclose(wide, np.radians([-150, 150]))


def test_unlimited_joint_urdf_humanoid(tmp_path):
    """iCub with its neck pitch made continuous (URDF): ±90° by default."""
    text = erd("icub_description/robots/icub.urdf").read_text()
    i = text.index('<joint name="neck_pitch" type="revolute">')
    text = text[:i] + text[i:].replace('type="revolute"', 'type="continuous"', 1)
    path = tmp_path / "icub.urdf"
    path.write_text(text)
    robot = sescid.load_robot(path, "r_sole")
    assert unlimited_joints(robot) == ["neck_pitch"]
    k = robot.joint_names.index("neck_pitch")
    np.testing.assert_allclose(design.sampling_limits(robot)[k], [-math.pi / 2, math.pi / 2])


@pytest.mark.slow
def test_readme_physics_walk_through_stands(op2, tmp_path):
    """The README's walk-through poses (seed 0, 38, D-optimal): at least 37 measured on the
    MuJoCo bench with the real robot's unmodelled masses and backlash (the truth)."""
    from sescid.bench import ExperimentConfig
    from sescid.bench.mujoco import run_mujoco_experiment
    from sescid.sensors.pads import load_sensors

    plan = sescid.plan_poses(op2, count=38, seed=0)
    ex = run_mujoco_experiment(op2, plan.q, load_sensors(op2.profile.sensors_file), samples=1,
                               seed=0, config=ExperimentConfig())  # fmt: skip
    assert len(ex.skipped) <= 1, ex.skipped
