"""``run_mujoco_experiment``: the physics bench measures a pose list into a raw log and truth.

Each pose: the servo targets are the command plus the backlash δ ~ U(−b, b) of
``ExperimentConfig``; gravity makes the joints sag below their targets by τ/kp; the settled
state is read ``samples`` times ``sample_steps`` time steps apart (``Simulation``) and logged by
the raw-log writer (``bench.log``): read-backs of the settled angle minus the part
``1 − readback_seen`` of δ the encoder does not see, pad forces (the contact normal forces),
``imu_roll``/``imu_pitch`` of the IMU body, ``grav_x/y/z`` (the gravity direction in the
support-sole frame), ``fz_total_n`` (the true total normal contact force, an ideal load cell),
and with torque sensors ``tau_<joint>``: the servos' actual torques at rest (the actuator
forces) through the torque sensor model.

Welded foot (``weld_foot``): the support body is fixed level to the world; the pads carry no
contact force, so the logged pad forces are the normal force of an ideal sole force/torque
sensor (inverse dynamics at rest) split over the pads by the bilinear weights of its CoP.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from sescid.bench.kinematic import Experiment
from sescid.bench.log import RawLogWriter, Readings
from sescid.bench.mujoco.sim import PoseResult, Simulation
from sescid.bench.mujoco.spec import MujocoBenchConfig, servo_gains
from sescid.bench.real_robot import (
    NO_POSE_MEASURED,
    ExperimentConfig,
    SensorErrors,
    approach_sides,
    check_limits,
    draw_errors,
    real_robot,
)
from sescid.bench.truth import (
    PhysicsTruth,
    Truth,
    common_fields,
    settings_of,
    torque_truth,
)
from sescid.errors import DataError
from sescid.robot import Robot
from sescid.sensors.pads import SensorConfig, bilinear_weights, check_sensors
from sescid.sesc import tilted_cop


def pose_readings(sim: Simulation, res: PoseResult, reads: list[PoseResult], unseen, approach):
    """``Readings`` of one settled pose's samples ``reads`` (``res``: the settled state).

    ``unseen`` (nq,) rad: the part of the backlash the encoders miss; ``approach`` ±1 or None.
    """
    m = len(reads)
    pads = {}
    for f in sim.sensors.feet if sim.sensors is not None else ():
        if sim.weld:
            fs = np.zeros((m, 4))
            if f.sole_frame == sim.robot.support and res.cop_ft is not None:
                uv = f.board_coordinates(res.cop_ft[None])
                fs[:] = bilinear_weights(uv[:, 0], uv[:, 1]) * res.force_ft
        else:
            fs = np.array([s.pads[f.name] for s in reads])
        pads[f.name] = fs
    fz = np.array([s.fz for s in reads])
    if sim.weld and res.force_ft is not None:
        fz = np.full(m, res.force_ft)
    return Readings(
        q=np.array([s.q for s in reads]) - unseen,
        pads=pads,
        tau=np.array([s.tau for s in reads]),
        approach=None if approach is None else np.full(m, float(approach)),
        gravity=-np.array([s.rot[2] for s in reads]),  # Rᵀ (0, 0, −1): gravity in the sole frame
        imu=np.array([s.imu for s in reads]),
        extra={"fz_total_n": fz},
    )


def _check(robot: Robot, q_cmd, sensors, samples, config, bench) -> None:
    if q_cmd.ndim != 2 or q_cmd.shape[1] != robot.nq:
        raise DataError(f"poses must be shaped (n, {robot.nq}), got {q_cmd.shape}")
    if samples < 1:
        raise DataError(f"samples per pose must be ≥ 1, got {samples}")
    config.check()
    bench.check()
    servo_gains(robot, bench)  # checks the gains
    check_limits(robot, q_cmd)
    if sensors is not None:
        check_sensors(robot, sensors)
    elif not config.torque.joints:
        raise DataError("the bench measures nothing: give foot sensors or joint torque sensors")


def _pad_cops(sensors, errors: SensorErrors, runs, readings) -> tuple[np.ndarray, np.ndarray]:
    """(k, 2) noise-free pad CoP and that of the biased pads, support frame, per pose."""
    k = len(runs)
    cop, cop_b, fsum, fsum_b = np.zeros((k, 2)), np.zeros((k, 2)), np.zeros(k), np.zeros(k)
    rot = np.array([r.rot for r, _ in runs])  # sole → world
    pos = np.array([r.pos for r, _ in runs])
    for f in sensors.feet if sensors is not None else ():
        fs = np.array([rd.pads[f.name][0] for rd in readings])
        fb = np.where(fs > 0, fs / errors.pad_gain[f.name] + errors.pad_bias[f.name], 0.0)
        rel_r = np.einsum("nji,njk->nik", rot, np.array([r.foot_rot[f.name] for r, _ in runs]))
        rel_o = np.einsum("nji,nj->ni", rot, np.array([r.foot_pos[f.name] for r, _ in runs]) - pos)
        pts = np.einsum("nij,kj->nki", rel_r[:, :2, :2], f.sensors) + rel_o[:, None, :2]
        cop += np.einsum("nk,nki->ni", fs, pts)
        cop_b += np.einsum("nk,nki->ni", fb, pts)
        fsum += fs.sum(axis=1)
        fsum_b += fb.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return cop / fsum[:, None], cop_b / fsum_b[:, None]


def _physics(
    robot: Robot, runs, target, r_true, q_act, cops, timings
) -> tuple[PhysicsTruth, np.ndarray]:
    """The physics truth per pose, and the gravity direction in the sole frame (k, 3)."""
    rot = np.array([r.rot for r, _ in runs])
    pos = np.array([r.pos for r, _ in runs])
    grav = np.einsum("nji,j->ni", rot, np.array([0.0, 0.0, -1.0]))
    com_sole = np.einsum("nji,nj->ni", rot, np.array([r.com for r, _ in runs]) - pos)
    cop_gravity = tilted_cop(robot.com(q_act, r_true), grav[:, :2] / grav[:, 2:3])
    cop_ft = [r.cop_ft for r, _ in runs]
    ph = PhysicsTruth(
        q_target=target,
        servo_sag=q_act - target,
        foot_tilt=np.arccos(np.clip(rot[:, 2, 2], -1.0, 1.0)),
        sole_height=pos[:, 2],
        com_sole=com_sole,
        cop_gravity=cop_gravity,
        cop_pads=cops[0],
        settle_s=np.array([r.settle for r, _ in runs]),
        wall_s=np.array(timings),
        cop_ft=None if any(c is None for c in cop_ft) else np.array(cop_ft),
    )
    return ph, grav


def run_mujoco_experiment(
    robot: Robot,
    q_cmd: np.ndarray,
    sensors: SensorConfig | None,
    samples: int = 100,
    seed: int | None = 0,
    config: ExperimentConfig | None = None,
    bench: MujocoBenchConfig | None = None,
) -> Experiment:
    """Stand (or hang) the real robot in each commanded pose (n, nq) [rad] in MuJoCo; log its
    sensors (module docstring). Poses that topple, touch the floor with another body or do not
    settle are listed in ``skipped`` with the reason and get no samples. Pose ids are "0", "1",
    … in the list's order (``Experiment.relabel`` gives them a pose list's ids)."""
    config = config or ExperimentConfig()
    bench = bench or MujocoBenchConfig()
    q_cmd = np.asarray(q_cmd, dtype=float)
    _check(robot, q_cmd, sensors, samples, config, bench)
    n = q_cmd.shape[0]
    pose_ids = np.array([str(i) for i in range(n)])
    sim = Simulation(robot, sensors, config, bench)
    real = real_robot(robot, config)
    rng = np.random.default_rng(seed)
    b = math.radians(config.backlash_deg)
    delta = rng.uniform(-b, b, size=q_cmd.shape)
    target = q_cmd + delta
    errors = draw_errors(robot, sensors, config, seed, rng)
    sides = approach_sides(config, n, seed) if errors.tau_joints else None
    unseen = (1.0 - config.readback_seen) * delta
    kept, skipped, runs, timings, readings = [], [], [], [], []
    for i in range(n):
        t0 = time.perf_counter()
        res, why = sim.run(target[i])
        if res is None:
            skipped.append((str(pose_ids[i]), why))
            continue
        reads = [sim.sample() for _ in range(samples)]
        timings.append(time.perf_counter() - t0)
        kept.append(i)
        runs.append((res, reads))
        readings.append(
            pose_readings(sim, res, reads, unseen[i], None if sides is None else sides[i])
        )
    if not kept:
        raise DataError(f"{NO_POSE_MEASURED}: pose {skipped[0][0]}: {skipped[0][1]}")
    idx = np.array(kept)
    all_r = Readings(
        q=np.concatenate([r.q for r in readings]),
        pads={k: np.concatenate([r.pads[k] for r in readings]) for k in readings[0].pads},
        tau=np.concatenate([r.tau for r in readings]),
        approach=None if sides is None else np.repeat(sides[idx], samples),
        gravity=np.concatenate([r.gravity for r in readings]),
        imu=np.concatenate([r.imu for r in readings]),
        extra={"fz_total_n": np.concatenate([r.extra["fz_total_n"] for r in readings])},
    )
    writer = RawLogWriter(robot, sensors, config, errors, bench.imu_noise)
    cols = writer.log(np.repeat(pose_ids[idx], samples), all_r, rng)
    q_act = np.array([r.q for r, _ in runs])
    tau_rest = np.array([np.mean([s.tau for s in reads], axis=0) for _, reads in runs])
    cops = _pad_cops(sensors, errors, runs, readings)
    physics, grav = _physics(robot, runs, target[idx], real[0], q_act, cops, timings)
    standing = config.mount != "gantry" and sensors is not None
    truth = Truth(
        engine="mujoco",
        settings=settings_of(config, sensors)
        | {
            "bench": dataclasses.asdict(bench),
            "servo_gains": dataclasses.asdict(servo_gains(robot, bench)),
        },
        pose=tuple(str(p) for p in pose_ids[idx]),
        q_commanded=q_cmd[idx],
        q_actual=q_act,
        q_readback=q_act - unseen[idx],
        cop_true=robot.cop(q_act, real[0]) if config.mount != "gantry" else None,
        cop_expected=cops[1] if standing else None,
        skipped=tuple(skipped),
        mount=config.mount,
        grav=grav,
        torque=None
        if sides is None
        else torque_truth(errors, tau_rest, sides[idx], config.torque.noise),
        physics=physics,
        units="m, kg, N, N·m, rad, s",
        **common_fields(robot, real, errors, (seed, samples)),
    )
    return Experiment(columns=cols, truth=truth, skipped=skipped)
