"""Joint torques on the kinematic bench: the sensor model, the gantry, the reduction."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from op2_stance import stable_poses

import sescid
from sescid.bench import ExperimentConfig, TorqueConfig, Truth, holding_torques, run_experiment
from sescid.bench.real_robot import real_bodies
from sescid.cli import cli
from sescid.errors import SescidError
from sescid.sensors import fsr, load_sensors, table_from_columns
from sescid.tables import read_table, write_table

#: no joint play or unmodelled mass: the actual pose is the command
EXACT = dict(extra_mass_fraction=0.0, backlash_deg=0.0)


@pytest.fixture(scope="module")
def sensors(op2):
    return load_sensors(None, op2.profile)


def test_ideal_torque_sensors_read_the_holding_torques(op2, sensors):
    """Noise-free, offset-free sensors on every joint log rigid statics at the actual pose."""
    q = stable_poses(op2, 8, seed=1)
    cfg = ExperimentConfig(torque=TorqueConfig("all", noise=0.0, offset=0.0), backlash_deg=0.5)
    ex = run_experiment(op2, q, sensors, samples=3, seed=2, config=cfg)
    t = ex.truth
    assert t.torque is not None and t.torque.joints == tuple(op2.joint_names)
    bodies, _ = real_bodies(op2, cfg)
    ref = holding_torques(op2, t.q_actual, bodies)
    np.testing.assert_allclose(t.torque.tau, ref, atol=1e-14)
    logged = np.column_stack([ex.columns[f"tau_{j}"] for j in op2.joint_names])
    np.testing.assert_allclose(logged, np.repeat(ref, 3, axis=0), atol=1e-14)
    assert set(np.unique(ex.columns["approach"])) <= {-1, 1}


def test_sensor_model_offset_gain_friction_approach(op2, sensors):
    """The reduction's per-pose mean is gain τ + offset + approach f within its standard error."""
    q = stable_poses(op2, 30, seed=3)
    joints = ("r_knee", "r_hip_pitch", "l_sho_pitch")
    tc = TorqueConfig(joints, noise=0.05, offset=0.1, gain=0.05, friction=(0.1, 0.3))
    cfg = ExperimentConfig(torque=tc, **EXACT)
    ex = run_experiment(op2, q, sensors, samples=40, seed=4, config=cfg)
    res, _ = fsr(op2, table_from_columns(ex.columns), sensors)
    tt = ex.truth.torque
    assert tt is not None and res.data.tau is not None and res.data.tau_se is not None
    assert res.data.tau_joints == ("r_hip_pitch", "r_knee", "l_sho_pitch")[:0] + tuple(
        j for j in op2.joint_names if j in joints
    )
    keep = [ex.truth.pose.index(p) for p in res.pose]
    np.testing.assert_array_equal(res.data.approach, tt.approach[keep])
    z = (res.data.tau - tt.expected[keep]) / res.data.tau_se
    assert np.sqrt(np.mean(z**2)) < 1.5  # standard normal: RMS ≈ 1
    np.testing.assert_allclose(res.data.tau_se, 0.05 / np.sqrt(40), rtol=0.5)
    # the friction band shows: the two sides differ by 2 f on average
    assert 0.1 <= tt.friction.min() and tt.friction.max() <= 0.3
    assert np.all(np.abs(tt.gain - 1) < 0.25) and np.any(tt.offset != 0)
    # seeds: the torque errors come from their own stream, the CoP log is unchanged by them
    plain = run_experiment(op2, q, sensors, samples=40, seed=4, config=ExperimentConfig(**EXACT))
    for c in plain.columns:
        np.testing.assert_array_equal(plain.columns[c], ex.columns[c])


def test_gantry_measures_every_pose_with_no_load_on_the_feet(op2, sensors):
    """Held by the torso: no pose is skipped, the pads read 0, the torques are the fixed-base
    ones; the reduction runs on the torques alone."""
    robot = sescid.load_robot("op2", "MP_BODY")
    q = np.random.default_rng(5).uniform(-0.5, 0.5, (6, robot.nq))
    q = np.clip(q, robot.joint_limits[:, 0], robot.joint_limits[:, 1])
    tc = TorqueConfig("all", noise=0.01, offset=0.0)
    cfg = ExperimentConfig(torque=tc, mount="gantry", **EXACT)
    ex = run_experiment(robot, q, sensors, samples=10, seed=6, config=cfg)
    assert not ex.skipped and ex.truth.cop_true is None and ex.truth.mount == "gantry"
    assert all(np.all(ex.columns[f"{f}{k}"] == 0) for f in ("r_fsr", "l_fsr") for k in range(1, 5))
    np.testing.assert_allclose(ex.truth.torque.tau, holding_torques(robot, q), atol=1e-14)
    res, _ = fsr(robot, table_from_columns(ex.columns), sensors)
    assert res.mode == "torque" and res.data.cop is None and len(res.pose) == 6
    assert np.abs(res.data.tau - holding_torques(robot, q)).max() < 5 * 0.01 / np.sqrt(10) * 3
    with pytest.raises(SescidError, match="no double support"):
        run_experiment(
            robot, q, sensors, config=ExperimentConfig(mount="gantry", double_support=True)
        )


def test_torque_log_without_foot_sensors(icub_path, tmp_path):
    """A robot with torque sensors and no sensor file: experiment, measure and the truth file
    round trip, from the command line."""
    robot = sescid.load_robot(icub_path, "root_link")
    lim = robot.joint_limits
    q = lim.mean(axis=1) + np.random.default_rng(7).uniform(-0.2, 0.2, (4, robot.nq)) * np.ptp(
        lim, axis=1
    )
    poses = tmp_path / "poses.csv"
    write_table(poses, {j: q[:, i] for i, j in enumerate(robot.joint_names)})
    raw, truth, out = tmp_path / "raw.csv", tmp_path / "t.json", tmp_path / "m.csv"
    common = ["--robot", str(icub_path), "--support", "root_link"]
    args = ["experiment", *common, "--poses", str(poses), "--samples", "10", "--mount", "gantry"]
    res = CliRunner().invoke(
        cli, [*args, "--torques", "all", "--out", str(raw), "--truth", str(truth)]
    )
    assert res.exit_code == 0, res.output
    assert not any(c.endswith("_fsr1") for c in read_table(raw).names())
    res = CliRunner().invoke(cli, ["measure", str(raw), *common, "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "4 poses from torque" in res.output
    m = read_table(out)
    assert {f"tau_{j}" for j in robot.joint_names} <= set(m.names())
    assert {f"tau_se_{j}" for j in robot.joint_names} <= set(m.names())
    assert "approach" in m.names() and "cop_x" not in m.names()
    t = Truth.load(truth)
    assert t.torque is not None and t.torque.tau.shape == (4, robot.nq)
    again = Truth.load(truth)
    np.testing.assert_array_equal(again.torque.expected, t.torque.expected)
    # without torques and foot sensors the bench measures nothing: one line
    args = ["experiment", *common, "--poses", str(poses), "--out", str(tmp_path / "r2.csv")]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 2 and res.output.count("\n") == 1


def test_truth_record_round_trips_through_its_file(op2, sensors, tmp_path):
    """Every field of the typed truth survives save/load; the old dict keys still answer."""
    q = stable_poses(op2, 5, seed=8)
    cfg = ExperimentConfig(torque=TorqueConfig(("r_knee",), friction=(0.1, 0.2)), tilt_deg=1.0)
    t = run_experiment(op2, q, sensors, samples=2, seed=9, config=cfg).truth
    t.save(tmp_path / "t.json")
    u = Truth.load(tmp_path / "t.json")
    for f in (
        "q_commanded",
        "q_actual",
        "q_readback",
        "cop_true",
        "cop_expected",
        "grav",
        "r_true",
    ):
        np.testing.assert_array_equal(getattr(u, f), getattr(t, f))
    for f in ("tau", "expected", "offset", "gain", "friction", "approach"):
        np.testing.assert_array_equal(getattr(u.torque, f), getattr(t.torque, f))
    assert u.pose == t.pose and u.true_mass == t.true_mass and u.extra_masses == t.extra_masses
    assert np.array(t.pad_bias["right"]).shape == (4,)


def test_torque_options_are_checked(op2, sensors):
    q = stable_poses(op2, 2, seed=10)
    for tc, match in (
        (TorqueConfig(("nope",)), "no joint 'nope'"),
        (TorqueConfig("some"), "expected 'all'"),
        (TorqueConfig("all", friction=(0.3, 0.1)), "friction band"),
        (TorqueConfig("all", noise=-1.0), "noise: must be ≥ 0"),
        (TorqueConfig("all", approach="sideways"), "approach: must be one of"),
    ):
        with pytest.raises(SescidError, match=match):
            run_experiment(op2, q, sensors, config=ExperimentConfig(torque=tc))
