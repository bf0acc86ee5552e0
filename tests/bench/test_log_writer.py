"""One raw-log writer: the kinematic bench, the MuJoCo bench and the session adapters give the
same columns and encoding for the same sensor configuration; the MuJoCo servos' torques."""

from __future__ import annotations

import numpy as np
import pytest
from op2_stance import stable_poses

from sescid.bench import ExperimentConfig, TorqueConfig, holding_torques, run_experiment
from sescid.bench.real_robot import real_bodies
from sescid.sensors import fsr, load_sensors, table_from_columns
from sescid.session import KinematicAdapter

mujoco = pytest.importorskip("mujoco")

from sescid.bench.mujoco import (  # noqa: E402
    MujocoBenchConfig,
    Simulation,
    run_mujoco_experiment,
)
from sescid.session import MujocoAdapter  # noqa: E402

#: the same sensor configuration for all: registers and forces, torques on a subset, friction
CFG = ExperimentConfig(
    registers="both",
    fsr_gain=0.05,
    torque=TorqueConfig(("r_knee", "r_hip_pitch", "head_tilt"), friction=(0.1, 0.2)),
)
QUICK = MujocoBenchConfig(settle_time=6.0)
#: columns only the physics bench has (an IMU, the true total load)
PHYSICS = {"imu_roll", "imu_pitch", "grav_x", "grav_y", "grav_z", "fz_total_n"}


@pytest.fixture(scope="module")
def sensors(op2):
    return load_sensors(None, op2.profile)


@pytest.fixture(scope="module")
def poses(op2):
    return stable_poses(op2, 3, seed=21)


def _kinds(cols: dict) -> dict[str, str]:
    return {k: np.asarray(v).dtype.kind for k, v in cols.items()}


def test_benches_and_adapters_write_the_same_columns(op2, sensors, poses):
    """Same names, order and dtype kinds (ticks, counts and registers int; torques float)."""
    kin = run_experiment(op2, poses, sensors, samples=4, seed=1, config=CFG).columns
    mj = run_mujoco_experiment(op2, poses[:1], sensors, 4, 1, CFG, QUICK).columns
    logs = {"kinematic bench": kin, "mujoco bench": mj}
    for name, cls in (("kinematic adapter", KinematicAdapter), ("mujoco adapter", MujocoAdapter)):
        bot = cls(op2, sensors, CFG, seed=1)
        bot.move("0", poses[0])
        assert bot.wait_settled() == ""
        logs[name] = {"pose": np.full(4, "0"), "sample": np.arange(4)} | bot.read(4)
    ref = [c for c in kin]
    assert {"r_fsr1", "r_fsr_x", "tau_r_knee", "approach", "r_knee_ticks"} <= set(ref)
    for name, cols in logs.items():
        core = [c for c in cols if c not in PHYSICS]
        assert core == ref, name
        kinds = _kinds(cols)
        assert {c: kinds[c] for c in ref} == _kinds(kin), name
    assert PHYSICS <= set(mj) and PHYSICS <= set(logs["mujoco adapter"])
    assert kin["r_knee_ticks"].dtype.kind == "i" and kin["tau_r_knee"].dtype.kind == "f"


def test_the_adapter_applies_the_pad_gains_and_registers(op2, sensors, poses):
    """The MuJoCo adapter now logs what the bench logs: pad gain errors and both registers."""
    bot = MujocoAdapter(op2, sensors, CFG, seed=2)
    assert np.any(bot.errors.pad_gain["right"] != 1)
    bot.move("0", poses[0])
    assert bot.wait_settled() == ""
    cols = bot.read(20)
    res, _ = fsr(op2, table_from_columns({"pose": np.full(20, "0")} | cols), sensors)
    truth = bot.truth["0"]
    assert np.abs(res.data.cop[0] - truth["cop_true"]).max() < 3e-3
    assert {"r_fsr_x", "r_fsr_y"} <= set(cols)


def test_welded_servo_torques_are_the_gravity_torques(op2, sensors, poses):
    """Welded support foot, at rest: the servos' torques are MuJoCo's qfrc_bias on the joints
    and rigid statics of the real robot at the settled angles."""
    weld = MujocoBenchConfig(weld_foot=True, settle_time=6.0)
    cfg = ExperimentConfig(torque=TorqueConfig("all", noise=0.0, offset=0.0))
    sim = Simulation(op2, sensors, cfg, weld)
    res, why = sim.run(poses[0] + 0.0)
    assert why == ""
    m, d = sim.model, sim.data
    dofs = np.array([m.jnt_dofadr[m.joint(j).id] for j in op2.joint_names])
    d2 = mujoco.MjData(m)
    d2.qpos[:] = d.qpos
    mujoco.mj_forward(m, d2)
    bias = d2.qfrc_bias[dofs]
    assert np.abs(res.tau - bias).max() < 5e-4 * np.abs(bias).max()  # residual motion: 1.3e-4 N·m
    bodies, _ = real_bodies(op2, cfg)
    statics = holding_torques(op2, res.q[None], bodies)[0]
    np.testing.assert_allclose(bias, statics, atol=1e-9)


def test_standing_servo_torques_are_bias_minus_contact(op2, sensors, poses):
    """Free-standing on the pads: the servos' torques are qfrc_bias minus the contact forces'
    share (qfrc_constraint) on the joints, and rigid statics with the foot held under the
    gravity the tilted foot sees; the truth carries them."""
    cfg = ExperimentConfig(torque=TorqueConfig("all", noise=0.0, offset=0.0))
    ex = run_mujoco_experiment(op2, poses[:2], sensors, 3, 0, cfg, QUICK)
    t = ex.truth
    bodies, _ = real_bodies(op2, cfg)
    statics = holding_torques(op2, t.q_actual, bodies, t.grav)
    scale = np.abs(statics).max()
    assert np.abs(t.torque.tau - statics).max() < 5e-4 * scale  # measured 4.5e-5 N·m
    sim = Simulation(op2, sensors, cfg, QUICK)
    res, why = sim.run(t.physics.q_target[0])
    assert why == ""
    m, d = sim.model, sim.data
    dofs = np.array([m.jnt_dofadr[m.joint(j).id] for j in op2.joint_names])
    contact = d.qfrc_bias[dofs] - d.qfrc_constraint[dofs]
    assert np.abs(res.tau - contact).max() < 5e-4 * scale


def test_mujoco_gantry_hangs_the_robot_from_its_torso(sensors):
    """mount="gantry": the torso welded level, no floor; every pose holds and the servos carry
    the fixed-base gravity torques, with or without foot sensors."""
    import sescid

    robot = sescid.load_robot("op2", "MP_BODY")
    rng = np.random.default_rng(0)
    q = np.clip(rng.uniform(-0.4, 0.4, (3, robot.nq)), *robot.joint_limits.T)
    cfg = ExperimentConfig(torque=TorqueConfig("all", noise=0.0, offset=0.0), mount="gantry")
    for layout in (sensors, None):
        ex = run_mujoco_experiment(robot, q, layout, 3, 0, cfg, QUICK)
        t = ex.truth
        assert not ex.skipped and t.cop_true is None
        bodies, _ = real_bodies(robot, cfg)
        statics = holding_torques(robot, t.q_actual, bodies)
        assert np.abs(t.torque.tau - statics).max() < 1e-6 * np.abs(statics).max()
        assert ("r_fsr1" in ex.columns) == (layout is not None)
