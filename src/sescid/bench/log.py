"""The one raw-log writer: what a bench's "real" robot measured → the columns a robot logs.

The kinematic bench, the MuJoCo bench and the session adapters give this writer the same
``Readings`` (per sample: the angle each joint encoder sees, the true pad normal forces, the true
joint torques, the gravity direction and IMU angles) and get the same columns and encoding for
the same sensor configuration:

- ``<joint>_ticks`` (int, the profile's servo encoder: the angle quantised to ticks, then
  ``readback_jitter_ticks`` of noise, rounded and clipped), or ``<joint>`` in rad (a robot
  whose profile has no servo: unquantised, without jitter);
- per foot ``<prefix>1..4`` (int counts of ``force_unit``: ``F / gain + bias + noise``, rounded,
  clipped to 0–saturation; a pad without contact force reads 0: an unloaded FSR conducts
  nothing) and/or the centroid registers ``<prefix>_x``, ``<prefix>_y`` (int, as the board
  computes them from the counts: X = 254 (F2 + F4)/F, Y = 254 (F3 + F4)/F, ``no_load`` below
  the minimum foot force), as ``ExperimentConfig.registers`` says;
- ``imu_roll``, ``imu_pitch`` (rad) and ``grav_x/y/z`` (unit, support frame) when the bench
  gives them (with ``imu_noise``), and any bench-specific extra column (``fz_total_n``);
- ``tau_<joint>`` (float, N·m) for the joints with a torque sensor: ``gain τ + offset +
  approach · f + noise``, and ``approach`` (±1, the pose's side).

Random draws, in this order from the bench's stream: read-back jitter (m, nq); per foot with any
load, pad noise (m, 4); IMU then gravity noise (when ``imu_noise`` > 0); torque noise (m, k).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sescid.bench.real_robot import ExperimentConfig, Registers, SensorErrors
from sescid.robot import Robot
from sescid.sensors.pads import Foot, SensorConfig
from sescid.tables import APPROACH_COLUMN, TAU_PREFIX


@dataclass(frozen=True)
class Readings:
    """What the real robot's sensors were exposed to, per sample (m samples)."""

    q: np.ndarray  #: (m, nq) angle each joint encoder sees, rad
    pads: dict[str, np.ndarray] = field(default_factory=dict)  #: foot → (m, 4) true force, N
    tau: np.ndarray | None = None  #: (m, nq) true actuator torques, N·m
    approach: np.ndarray | None = None  #: (m,) ±1, the side the sample's pose came from
    gravity: np.ndarray | None = None  #: (m, 3) true gravity direction, support frame
    imu: np.ndarray | None = None  #: (m, 2) true IMU roll, pitch, rad
    extra: dict[str, np.ndarray] = field(default_factory=dict)  #: bench-specific columns


def pad_columns(
    foot: Foot, counts: np.ndarray, registers: Registers, sensors: SensorConfig
) -> dict[str, np.ndarray]:
    """Raw-log columns of one foot board from its force counts (m, 4): the four forces, the
    centroid registers the board computes from them, or both (``registers``)."""
    cols: dict[str, np.ndarray] = {}
    if registers in ("forces", "both"):
        for k in range(4):
            cols[f"{foot.columns}{k + 1}"] = counts[:, k]
    if registers in ("centroid", "both"):
        total = counts.sum(axis=1)
        on = total * sensors.force_unit >= sensors.min_foot_force
        safe = np.where(on, total, 1)
        x = np.round(sensors.centroid_max * (counts[:, 1] + counts[:, 3]) / safe)
        y = np.round(sensors.centroid_max * (counts[:, 2] + counts[:, 3]) / safe)
        cols[f"{foot.columns}_x"] = np.where(on, x, sensors.no_load).astype(int)
        cols[f"{foot.columns}_y"] = np.where(on, y, sensors.no_load).astype(int)
    return cols


class RawLogWriter:
    """Turns ``Readings`` into raw-log columns with the run's sensor errors and noise."""

    def __init__(
        self,
        robot: Robot,
        sensors: SensorConfig | None,
        config: ExperimentConfig,
        errors: SensorErrors,
        imu_noise: float = 0.0,
    ):
        self.robot = robot
        self.sensors = sensors
        self.config = config
        self.errors = errors
        self.imu_noise = imu_noise

    def columns(self, r: Readings, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """The sensor columns (no ``pose``/``sample``) of the readings ``r`` (module doc)."""
        cols = self._joints(r.q, rng)
        if self.sensors is not None:
            for f in self.sensors.feet:
                cols |= self._pads(f, r.pads.get(f.name), len(r.q), rng)
        noisy = self.imu_noise > 0
        if r.imu is not None:
            imu = r.imu + rng.normal(0.0, self.imu_noise, size=r.imu.shape) if noisy else r.imu
            cols |= {"imu_roll": imu[:, 0], "imu_pitch": imu[:, 1]}
        if r.gravity is not None:
            g = r.gravity
            if noisy:
                g = g + rng.normal(0.0, self.imu_noise, size=g.shape)
                g = g / np.linalg.norm(g, axis=1, keepdims=True)
            cols |= {f"grav_{a}": g[:, i] for i, a in enumerate("xyz")}
        cols |= r.extra
        if self.errors.tau_joints:
            cols |= self._torques(r, rng)
        return cols

    def log(self, pose: np.ndarray, r: Readings, rng: np.random.Generator) -> dict:
        """``pose`` (m,) ids, ``sample`` (0, 1, … within each pose) and ``columns``."""
        pose = np.asarray(pose)
        sample = np.zeros(len(pose), dtype=int)
        if len(pose):
            starts = np.r_[True, pose[1:] != pose[:-1]]
            run = np.cumsum(starts) - 1
            first = np.flatnonzero(starts)
            sample = np.arange(len(pose)) - first[run]
        return {"pose": pose, "sample": sample} | self.columns(r, rng)

    def _joints(self, q: np.ndarray, rng) -> dict[str, np.ndarray]:
        servo = self.robot.profile.servo
        names = self.robot.joint_names
        if servo is None:
            return {name: q[:, j] for j, name in enumerate(names)}
        exact = q * (servo.ticks_per_turn / (2 * math.pi)) + servo.zero_tick
        jitter = rng.normal(0.0, self.config.readback_jitter_ticks, size=q.shape)
        ticks = np.clip(np.round(np.round(exact) + jitter), 0, servo.max_tick).astype(int)
        return {f"{name}_ticks": ticks[:, j] for j, name in enumerate(names)}

    def _pads(self, foot: Foot, true: np.ndarray | None, m: int, rng) -> dict[str, np.ndarray]:
        assert self.sensors is not None
        s, cfg = self.sensors, self.config
        if true is None or not np.any(true):
            counts = np.zeros((m, 4), dtype=int)
        else:
            reading = true / self.errors.pad_gain[foot.name] + self.errors.pad_bias[foot.name]
            noisy = reading + rng.normal(0.0, cfg.fsr_noise, size=(m, 4))
            counts = np.clip(np.round(noisy / s.force_unit), 0, s.saturation)
            counts = np.where(true > 0, counts, 0).astype(int)  # unloaded: an FSR conducts nothing
        return pad_columns(foot, counts, cfg.registers, s)

    def _torques(self, r: Readings, rng) -> dict[str, np.ndarray]:
        e, tc = self.errors, self.config.torque
        if r.tau is None or r.approach is None:
            raise ValueError("a robot with torque sensors needs true torques and approach sides")
        meas = expected_torques(e, r.tau, r.approach)
        meas = meas + rng.normal(0.0, tc.noise, size=meas.shape)
        cols = {TAU_PREFIX + j: meas[:, i] for i, j in enumerate(e.tau_joints)}
        cols[APPROACH_COLUMN] = r.approach.astype(int)
        return cols


def expected_torques(errors: SensorErrors, tau: np.ndarray, approach: np.ndarray) -> np.ndarray:
    """(n, k) noise-free readings ``gain τ + offset + approach f`` of true torques (n, nq)."""
    true = tau[:, errors.tau_index]
    return errors.tau_gain * true + errors.tau_offset + approach[:, None] * errors.tau_friction
