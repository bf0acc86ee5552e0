"""The kinematic bench (paper §4): rigid statics of a "real" robot that differs from its model.

The real robot (``real_robot``: unmodelled mass, backlash, sensor errors) takes each commanded
pose with its joint play; rigid statics then gives what its sensors see, and the raw-log writer
(``bench.log``) logs ``samples`` readings per pose, as a real robot would:

- joint read-backs: the commanded angle plus the part ``readback_seen`` (default 0.5) of the
  backlash δ that the servo's output-shaft encoder sees (gear play); the rest of δ (horn and
  bracket play) is invisible, so the read-backs still miss the actual angle by up to
  (1 − readback_seen)·b;
- standing (``mount="stand"``): the four pads of the support foot carry the true weight ``M g``
  spread by the bilinear weights of the true CoP in the pad rectangle (their centroid is exactly
  the CoP; with ``double_support`` the elastic split over the pads of every foot on the floor
  that press, a pad that would pull lifted); the lifted
  foot reads 0. A pose whose CoP leaves the pads (or the sole, without a sensor board) would
  tip: it is not measured and is listed in ``skipped``;
- in a gantry (``mount="gantry"``): the support link (pelvis, torso) is held level, the feet
  carry nothing, every pose is measured;
- balancing on a line (``mount="line"``: a wheel axle, an edge, ``Robot.line``): each pose is
  taken at the tilt about the line that puts the true CoM above it, and an IMU on
  ``imu_link`` (the profile's, else the support frame) logs its roll and pitch with
  ``imu_noise_deg`` of noise per sample;
- joint torques (``TorqueConfig``): the true holding torques of rigid statics with the support
  fixed (``bench.statics``; in double support with the other foot's floor forces), read through
  the torque sensor model.

The truth (``bench.truth.Truth``: true SESC vectors, actual poses, true CoPs and torques, the
sensor errors) is returned beside the log.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from sescid.base import G0
from sescid.bench.log import RawLogWriter, Readings
from sescid.bench.real_robot import (
    NO_POSE_MEASURED,
    ExperimentConfig,
    approach_sides,
    check_limits,
    draw_errors,
    real_bodies,
    real_robot,
)
from sescid.bench.statics import ExternalForce, holding_torques
from sescid.bench.truth import Truth, common_fields, settings_of, torque_truth
from sescid.errors import DataError
from sescid.robot import Robot
from sescid.sensors.feet import OFF_FLOOR_M, OFF_FLOOR_TILT
from sescid.sensors.pads import SensorConfig, bilinear_weights, check_sensors
from sescid.sesc import balance_gravity, balance_tilt
from sescid.simulation import check_count


@dataclass
class Experiment:
    """The raw log (column name → array) and the truth behind it."""

    columns: dict[str, np.ndarray]
    truth: Truth
    skipped: list[tuple[str, str]] = field(default_factory=list)  #: (pose, why) not measured

    def relabel(self, ids) -> Experiment:
        """The same experiment with pose k called ``ids[k]`` (a run labels poses "0", "1", …)."""
        ids = np.asarray([str(i) for i in ids])

        def new(p: str) -> str:
            return str(ids[int(p)])

        cols = dict(self.columns)
        cols["pose"] = np.array([new(p) for p in self.columns["pose"]])
        skipped = [(new(p), why) for p, why in self.skipped]
        truth = dataclasses.replace(
            self.truth, pose=tuple(new(p) for p in self.truth.pose), skipped=tuple(skipped)
        )
        return Experiment(cols, truth, skipped)


def pads_in_support(robot: Robot, foot, q: np.ndarray) -> np.ndarray:
    """(n, 4, 2) a foot's pad centres in the support frame (x, y) at poses q (n, nq)."""
    rot, org = robot.link_poses(q, foot.sole_frame)
    return org[:, None, :2] + np.einsum("nij,kj->nki", rot[:, :2, :2], foot.sensors)


def two_foot_split(
    robot: Robot, sensors: SensorConfig, q: np.ndarray, cop: np.ndarray, weight: float
):
    """Pad forces of every foot on the floor: the elastic split of the weight over the pads
    that press (unilateral: a pad does not pull).

    Feet count as on the floor where the model puts their sole within 10 mm of the ground and
    5° of level at q (``sensors.feet.OFF_FLOOR_*``). The split is the least-squares one (a rigid
    body on equal springs) over the pads in contact, the most pulling pad of a pose lifted and
    the rest split again until none pulls. Returns forces {foot: (n, 4)} N, a mask of poses
    that cannot stand so (the CoP outside the pads' support), and its description.
    """
    n = q.shape[0]
    pts, on = [], []
    for f in sensors.feet:
        rot, org = robot.link_poses(q, f.sole_frame)
        tilt = np.arccos(np.clip(rot[:, 2, 2], -1.0, 1.0))
        on.append((np.abs(org[:, 2]) <= OFF_FLOOR_M) & (tilt <= OFF_FLOOR_TILT))
        pts.append(pads_in_support(robot, f, q))
    mask = np.repeat(np.stack(on, axis=1), 4, axis=1)  # (n, 4·feet) pads in contact
    p = np.concatenate(pts, axis=1)  # (n, 4·feet, 2)
    rhs = weight * np.concatenate([np.ones((n, 1)), cop], axis=1)
    tol = 1e-9 * weight
    forces = np.zeros(mask.shape)
    bad = np.zeros(n, dtype=bool)
    todo = np.arange(n)
    for _ in range(mask.shape[1]):
        a = np.concatenate([np.ones(p[todo].shape[:2] + (1,)), p[todo]], axis=2)
        a = a * mask[todo, :, None]
        ata = np.einsum("nki,nkj->nij", a, a)
        ok = np.linalg.det(ata) > 1e-12 * np.maximum(np.einsum("nii->n", ata), 1.0) ** 3
        bad[todo[~ok]] = True
        todo, a, ata = todo[ok], a[ok], ata[ok]
        if not len(todo):
            break
        lam = np.linalg.solve(ata, rhs[todo][:, :, None])[:, :, 0]
        f = np.einsum("nki,ni->nk", a, lam)
        forces[todo] = f
        pull = np.any(f < -tol, axis=1)
        if not pull.any():
            break
        worst = np.argmin(f[pull], axis=1)
        mask[todo[pull], worst] = False  # that pad lifts
        todo = todo[pull]
    bad |= np.any(forces < -tol, axis=1)
    forces = np.clip(forces, 0.0, None)
    out = {f.name: forces[:, 4 * i : 4 * i + 4] for i, f in enumerate(sensors.feet)}
    return out, bad, "the pads of the feet on the floor"


@dataclass(frozen=True)
class _Stance:
    """Per commanded pose: the true pad forces, which poses tip, and why."""

    forces: dict[str, np.ndarray]  #: foot → (n, 4) N
    tips: np.ndarray  #: (n,) bool
    where: str


def _stance(robot: Robot, sensors, config, cop_true, q_act, weight) -> _Stance:
    """Pad forces of a standing robot (or none in a gantry) and the poses that would tip."""
    n = len(q_act)
    feet = sensors.feet if sensors is not None else ()
    if config.mount in ("gantry", "line"):
        return _Stance({f.name: np.zeros((n, 4)) for f in feet}, np.zeros(n, bool), "")
    if config.double_support:
        forces, tips, where = two_foot_split(robot, sensors, q_act, cop_true, weight)
        return _Stance(forces, tips, where)
    if sensors is None:  # no board: the sole's rectangle decides what tips
        sole = robot.sole
        if sole is None:
            return _Stance({}, np.zeros(n, bool), "")
        half = np.asarray(sole.size, dtype=float) / 2
        tips = np.any(np.abs(cop_true - robot.sole_centre) > half, axis=1)
        return _Stance({}, tips, f"the sole of {robot.support}")
    foot = support_foot(robot, sensors)
    uv = foot.board_coordinates(cop_true)
    tips = np.any((uv < 0) | (uv > 1), axis=1)
    w = bilinear_weights(uv[:, 0], uv[:, 1])
    forces = {f.name: (weight * w if f is foot else np.zeros((n, 4))) for f in feet}
    return _Stance(forces, tips, f"the sensor rectangle of {robot.support}")


def support_foot(robot: Robot, sensors: SensorConfig):
    """The foot whose sensor board sits on the support link (DataError naming the boards)."""
    support = [f for f in sensors.feet if f.sole_frame == robot.support]
    if not support:
        raise DataError(
            f"no foot sensor board sits on the support link '{robot.support}' "
            f"(boards: {', '.join(f.sole_frame for f in sensors.feet)})"
        )
    return support[0]


def floor_forces(robot: Robot, sensors, forces: dict, q_act, grav) -> tuple[ExternalForce, ...]:
    """The floor's push on the pads of feet other than the support (double support)."""
    out = []
    up = -(np.tile([0.0, 0.0, -1.0], (len(q_act), 1)) if grav is None else grav)
    for f in sensors.feet if sensors is not None else ():
        body = robot.model.link_frames[f.sole_frame][0]
        if body == 0 or not np.any(forces.get(f.name, 0.0)):
            continue
        rot, org = robot.link_poses(q_act, f.sole_frame)
        pads3 = np.concatenate([f.sensors, np.zeros((4, 1))], axis=1)
        points = org[:, None, :] + np.einsum("nij,kj->nki", rot, pads3)
        for k in range(4):
            out.append(ExternalForce(body, points[:, k], forces[f.name][:, k, None] * up))
    return tuple(out)


def _cop_expected(robot: Robot, sensors, forces, errors, q_act) -> np.ndarray | None:
    """(n, 2) noise-free measured CoP: what a perfect average of the biased pads gives."""
    if sensors is None or not forces or not any(np.any(f) for f in forces.values()):
        return None
    n = len(q_act)
    num, den = np.zeros((n, 2)), np.zeros(n)
    for f in sensors.feet:
        on = forces[f.name].sum(axis=1) > 0
        fb = np.where(
            on[:, None], forces[f.name] / errors.pad_gain[f.name] + errors.pad_bias[f.name], 0.0
        )
        num += np.einsum("nk,nki->ni", fb, pads_in_support(robot, f, q_act))
        den += fb.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return num / den[:, None]


def _imu_angles(robot: Robot, config, q: np.ndarray, grav: np.ndarray) -> np.ndarray:
    """(n, 2) roll, pitch [rad] an IMU on the line mount's IMU link reads under gravity
    (n, 3) (support frame): g_link = (sin θ, −cos θ sin φ, −cos θ cos φ)."""
    link = config.imu_link or robot.profile.imu_link or robot.support
    rot, _ = robot.link_poses(q, link)
    g = np.einsum("nji,nj->ni", rot, grav)  # R_support←linkᵀ g
    pitch = np.arcsin(np.clip(g[:, 0], -1.0, 1.0))
    roll = np.arctan2(-g[:, 1], -g[:, 2])
    return np.stack([roll, pitch], axis=1)


def _check_inputs(robot: Robot, q_cmd, sensors, samples, config) -> None:
    if samples < 1:
        raise DataError(f"samples per pose must be ≥ 1, got {samples}")
    n = q_cmd.shape[0]
    check_count(n * samples, 8 * (robot.nq + 16) * 16, "samples", "samples (poses × samples)")
    config.check()
    check_limits(robot, q_cmd)
    if sensors is not None:
        check_sensors(robot, sensors)
    if config.mount == "line":
        if robot.line is None:
            raise DataError(
                f"a line mount needs a support line: '{robot.support}' is not one (--line)"
            )
        return
    if sensors is None and not config.torque.joints:
        raise DataError("the bench measures nothing: give foot sensors or joint torque sensors")


def run_experiment(
    robot: Robot,
    q_cmd: np.ndarray,
    sensors: SensorConfig | None,
    samples: int = 100,
    seed: int | None = 0,
    config: ExperimentConfig | None = None,
    pose_ids: np.ndarray | None = None,
) -> Experiment:
    """Stand (or hang) the real robot in each commanded pose (n, nq) [rad]; log ``samples``
    readings per pose (module docstring). ``sensors`` None: no foot sensors."""
    config = config or ExperimentConfig()
    q_cmd = np.asarray(q_cmd, dtype=float)
    _check_inputs(robot, q_cmd, sensors, samples, config)
    n = q_cmd.shape[0]
    pose_ids = np.array([str(i) for i in range(n)]) if pose_ids is None else np.asarray(pose_ids)
    real = real_robot(robot, config)
    r_true, mass_true, _ = real
    rng = np.random.default_rng(seed)
    b = math.radians(config.backlash_deg)
    delta = rng.uniform(-b, b, size=q_cmd.shape)
    q_act = q_cmd + delta
    grav = None
    if config.mount == "line":  # balanced: the tilt about the line that puts the CoM above it
        assert robot.line is not None  # _check_inputs: a line mount needs a line support
        grav = balance_gravity(robot.line, balance_tilt(robot.tree, robot.line, q_act, r_true)[0])
    elif config.tilt_deg > 0:  # roll φ, pitch θ of the support: (sin θ, −cos θ sin φ, −cos θ cos φ)
        roll, pitch = rng.normal(0.0, math.radians(config.tilt_deg), size=(2, n))
        grav = np.stack(
            [np.sin(pitch), -np.cos(pitch) * np.sin(roll), -np.cos(pitch) * np.cos(roll)], axis=1
        )
    line = config.mount == "line"
    cop_true = np.zeros((n, 2)) if line else robot.cop(q_act, r_true, grav)
    st = _stance(robot, sensors, config, cop_true, q_act, mass_true * G0)
    skipped = [
        (
            str(pose_ids[i]),
            f"the real robot's CoP ({cop_true[i, 0] * 1e3:.1f}, {cop_true[i, 1] * 1e3:.1f}) mm "
            f"lies outside {st.where}: it would rest on the sole edge or tip over, so it was "
            "not measured",
        )
        for i in np.flatnonzero(st.tips)
    ]
    if st.tips.all():
        raise DataError(f"{NO_POSE_MEASURED}: pose {skipped[0][0]}: {skipped[0][1]}")
    keep = ~st.tips
    q_cmd, delta, q_act = q_cmd[keep], delta[keep], q_act[keep]
    cop_true, pose_ids = cop_true[keep], pose_ids[keep]
    grav = None if grav is None else grav[keep]
    forces = {name: f[keep] for name, f in st.forces.items()}
    errors = draw_errors(robot, sensors, config, seed, rng)
    q_read = q_cmd + config.readback_seen * delta
    tau = approach = None
    if errors.tau_joints:
        bodies, _ = real_bodies(robot, config)
        ext = floor_forces(robot, sensors, forces, q_act, grav)
        tau = holding_torques(robot, q_act, bodies, grav, ext)
        approach = approach_sides(config, len(q_act), seed)
    pose_of = np.repeat(np.arange(len(q_act)), samples)
    imu = _imu_angles(robot, config, q_act, grav) if line and grav is not None else None
    readings = Readings(
        q=q_read[pose_of],
        pads={name: f[pose_of] for name, f in forces.items()},
        tau=None if tau is None else tau[pose_of],
        approach=None if approach is None else approach[pose_of],
        gravity=None if grav is None or line else grav[pose_of],
        imu=None if imu is None else imu[pose_of],
    )
    noise = math.radians(config.imu_noise_deg) if line else 0.0
    writer = RawLogWriter(robot, sensors, config, errors, imu_noise=noise)
    cols = writer.log(pose_ids[pose_of], readings, rng)
    truth = Truth(
        engine="kinematic",
        settings=settings_of(config, sensors),
        pose=tuple(str(p) for p in pose_ids),
        q_commanded=q_cmd,
        q_actual=q_act,
        q_readback=q_read,
        cop_true=None if config.mount in ("gantry", "line") else cop_true,
        cop_expected=_cop_expected(robot, sensors, forces, errors, q_act),
        skipped=tuple(skipped),
        mount=config.mount,
        grav=grav,
        torque=None
        if tau is None or approach is None
        else torque_truth(errors, tau, approach, config.torque.noise),
        **common_fields(robot, real, errors, (seed, samples)),
    )
    return Experiment(columns=cols, truth=truth, skipped=skipped)
