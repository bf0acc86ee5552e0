"""The command-line path of a robot balancing on a line: bench (line mount) → measure →
identify → predict → truth, on the example two-wheeled humanoid."""

from __future__ import annotations

import math

import numpy as np
from cli_run import invoke as run

import sescid
from sescid import tables
from sescid.bench import Truth
from sescid.robots import EXAMPLES
from sescid.sesc import balance_tilt
from sescid.simulation import random_poses

WHEELED = EXAMPLES["wheeled_humanoid"]
ROBOT = ["--robot", str(WHEELED), "--support", "axle", "--line", "y"]


def test_line_bench_to_fit(tmp_path):
    robot = sescid.load_robot(WHEELED, "axle", line="y")
    q = random_poses(robot, 40, 40.0, 1, clip=True)
    tables.write_table(
        tmp_path / "poses.csv", {j: q[:, i] for i, j in enumerate(robot.joint_names)}
    )
    res = run(
        "experiment", *ROBOT, "--mount", "line", "--poses", tmp_path / "poses.csv",
        "--samples", 20, "--imu-noise-deg", 2, "--out", tmp_path / "raw.csv",
        "--truth", tmp_path / "truth.json",
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "(line)" in res.output and "IMU noise 2°" in res.output
    raw = tables.read_table(tmp_path / "raw.csv")
    assert {"imu_roll", "imu_pitch"} <= set(raw.names()) and "grav_x" not in raw.names()
    truth = Truth.load(tmp_path / "truth.json")
    # the bench balanced each pose: the logged gravity puts the true CoM over the axle
    tilt, _ = balance_tilt(robot.tree, robot.line, truth.q_actual, truth.r_true)
    np.testing.assert_allclose(truth.grav[:, 0], np.sin(tilt), atol=1e-12)
    res = run("measure", tmp_path / "raw.csv", *ROBOT, "--imu-link", "axle",
              "--out", tmp_path / "m.csv")  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "40 poses from imu" in res.output
    res = run("identify", tmp_path / "m.csv", *ROBOT, "--method", "map",
              "--out", tmp_path / "fit.json")  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "balance tilt: sigma_hat" in res.output and "the data carry no scale" in res.output
    fit = sescid.load_fit(tmp_path / "fit.json")
    assert fit.robot.line is not None and fit.scale is not None
    # 20 samples of 2° each: ~0.45° per pose, plus the joints' 1° play the encoders half see
    sigma = math.degrees(fit.kinds[0].sigma)
    assert 0.2 < sigma < 1.5, sigma
    res = run("predict", tmp_path / "fit.json", tmp_path / "poses.csv", "--level", 0.95,
              "--out", tmp_path / "pred.csv")  # fmt: skip
    assert res.exit_code == 0, res.output
    pred = tables.read_table(tmp_path / "pred.csv")
    assert "cop_x" not in pred.names()
    np.testing.assert_allclose(pred.get("balance_tilt"), fit.predict_balance(q), atol=1e-15)
    assert np.all(pred.get("balance_tilt_lower") < pred.get("balance_tilt"))
    res = run("truth", tmp_path / "fit.json", tmp_path / "truth.json")
    assert res.exit_code == 0, res.output
    assert "RMS balance tilt error" in res.output and "CoM distance from the line" in res.output


def test_line_robot_file_errors(tmp_path):
    robot = sescid.load_robot(WHEELED, "axle", line="y")
    cols = {j: np.zeros(3) for j in robot.joint_names}
    tables.write_table(tmp_path / "a.csv", cols | {"cop_x": np.zeros(3)})
    res = run("identify", tmp_path / "a.csv", *ROBOT, "--out", tmp_path / "f.json")
    assert res.exit_code == 2 and "has no centre of pressure" in res.output
    tables.write_table(tmp_path / "b.csv", cols)
    res = run("identify", tmp_path / "b.csv", *ROBOT, "--out", tmp_path / "f.json")
    assert res.exit_code == 2 and "needs the gravity direction" in res.output
    res = run("identify", tmp_path / "b.csv", "--robot", WHEELED, "--support", "axle",
              "--line", "q", "--out", tmp_path / "f.json")  # fmt: skip
    assert res.exit_code == 2 and "is not a direction" in res.output
    assert not (tmp_path / "f.json").exists()
