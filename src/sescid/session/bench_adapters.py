"""The benches as robots a session drives: rigid statics (``KinematicAdapter``) and MuJoCo
(``MujocoAdapter``), both logging through the benches' one raw-log writer (``bench.log``).

Per commanded pose (``move``): the servo targets are the command plus the pose's backlash
δ ~ U(−b, b) of ``ExperimentConfig``; with torque sensors the pose is approached from one side
(``TorqueConfig.approach``). ``wait_settled``: MuJoCo simulates until still (toppled, floor
contact and not settled are failures, ``bench.mujoco.Simulation``); rigid statics fails a pose
whose true CoP leaves the support foot's pads. ``read(n)``: ``n`` samples of the same columns
``sescid experiment`` writes (read-backs missing the unseen part of δ, pad forces with bias,
gain error and noise, gravity, joint torques). ``truth`` keeps per measured pose the actual
angles, the true CoP ``robot.cop(q_actual, r_true)`` and, with torque sensors, the true
holding torques.

A robot without foot sensors (``feet=False``: it logs joint torques only) stands on the same
foot (its pads still carry it in MuJoCo) but its log has no foot-sensor columns; without a
board on the support foot, rigid statics fails a pose whose CoP leaves the support sole. In a
gantry (``ExperimentConfig.mount = "gantry"``) the support link is held: every pose holds, no
foot is loaded.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from sescid.base import G0
from sescid.bench.kinematic import floor_forces, two_foot_split
from sescid.bench.log import RawLogWriter, Readings
from sescid.bench.real_robot import (
    ExperimentConfig,
    approach_sides,
    draw_errors,
    real_bodies,
    real_robot,
    stance_config,
)
from sescid.bench.statics import holding_torques
from sescid.errors import DataError, OptionError
from sescid.robot import Robot
from sescid.sensors.pads import SensorConfig, bilinear_weights, check_sensors

if TYPE_CHECKING:
    from sescid.bench.mujoco import PoseResult


class _BenchAdapter:
    """What both bench adapters share: the real robot, its errors, the writer, one pose."""

    def __init__(
        self,
        robot: Robot,
        sensors: SensorConfig | None,
        config,
        seed: int | None,
        imu=0.0,
        feet=True,
    ):
        self.robot = robot
        self.sensors = sensors
        self.config = config or ExperimentConfig()
        self.config.check()
        if sensors is not None:
            check_sensors(robot, sensors)
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        self.errors = draw_errors(robot, sensors, self.config, seed, self.rng)
        if not feet and not self.errors.tau_joints:
            raise OptionError("torques", "a robot without foot sensors needs torque sensors")
        logged = sensors if feet else None  # feet=False: the pads carry it, nothing logs them
        self.writer = RawLogWriter(robot, logged, self.config, self.errors, imu)
        self.r_true, self.mass_true, _ = real_robot(robot, self.config)
        self.reference, self.base_config = robot, self.config
        self.stance = ("", "")  #: (support, mount) asked by ``change_stance`` ("": as built)
        self.truth: dict[str, dict[str, Any]] = {}
        self._pose = ""
        self._count = 0
        self._delta = np.zeros(robot.nq)
        self._target = np.zeros(robot.nq)
        self._approach: float | None = None
        self._settled = False

    def move(self, pose: str, q: np.ndarray) -> None:
        """See ``RobotAdapter.move``."""
        b = math.radians(self.config.backlash_deg)
        self._pose = pose
        self._delta = self.rng.uniform(-b, b, size=self.robot.nq)
        self._target = np.asarray(q, dtype=float) + self._delta
        self._approach = None
        if self.errors.tau_joints:
            self._approach = float(approach_sides(self.config, 1, self.seed, self._count)[0])
        self._count += 1
        self._settled = False

    def _unseen(self) -> np.ndarray:
        return (1.0 - self.config.readback_seen) * self._delta

    def change_stance(self, support: str, mount: str) -> None:
        """Put the real robot in another stance (a session over stances): standing on the sole
        ``support`` (``mount`` "stand"), on both feet ("double": the CoP in the frame of the
        robot this adapter was made with) or held by the link ``support`` ("gantry"); the same
        physical robot (``bench.stance_config``) and the same sensors (their errors kept)."""
        robot = self.reference if mount == "double" else self.reference.at(support)
        cfg = stance_config(self.reference, robot, self.base_config)
        cfg = dataclasses.replace(
            cfg, mount="gantry" if mount == "gantry" else "stand", double_support=mount == "double"
        )
        cfg.check()
        self.robot, self.config, self.stance = robot, cfg, (support, mount)
        self.r_true, self.mass_true, _ = real_robot(robot, cfg)
        self._settled = False
        self._restand()

    def _restand(self) -> None:
        """What a bench rebuilds for a new stance."""

    def stop(self) -> None:
        """See ``RobotAdapter.stop``."""
        self._settled = False


class KinematicAdapter(_BenchAdapter):
    """The kinematic bench as a robot: rigid statics of the real robot on its support foot, or
    held in a gantry (module docstring)."""

    def __init__(
        self,
        robot: Robot,
        sensors: SensorConfig | None,
        config=None,
        seed: int | None = 0,
        feet=True,
    ):
        super().__init__(robot, sensors, config, seed, feet=feet)
        self._restand()
        if self.foot is None and not self.held and feet:
            boards = sensors.feet if sensors is not None else ()
            boards_on = ", ".join(f.sole_frame for f in boards) or "no layout"
            raise DataError(
                f"no foot sensor board sits on the support link '{robot.support}' (boards: "
                f"{boards_on}): give a layout with one (--sensors), or --no-foot-sensors for a "
                "robot that logs its joint torques only (--torques all)"
            )
        self._pads = np.zeros(4)
        self._feet: dict[str, np.ndarray] | None = None  #: on both feet: pad forces per foot
        self._tau = np.zeros(robot.nq)

    def _restand(self) -> None:
        """The support foot's board, whether held, and the real bodies of this stance."""
        boards = self.sensors.feet if self.sensors is not None else ()
        self.foot = next((f for f in boards if f.sole_frame == self.robot.support), None)
        self.held = self.config.mount == "gantry"
        self.bodies, _ = real_bodies(self.robot, self.config)

    def _tipped(self, cop: np.ndarray) -> str:
        """Why the true CoP (2,) [m] tips the robot over ('' when it stands): off the pads of
        the support foot's board, else off its sole."""
        where = f"the CoP ({cop[0] * 1e3:.1f}, {cop[1] * 1e3:.1f}) mm left the"
        if self.foot is not None:
            uv = self.foot.board_coordinates(cop[None])
            if np.any((uv < 0) | (uv > 1)):
                return f"toppled: {where} pads"
            self._pads = self.mass_true * G0 * bilinear_weights(uv[:, 0], uv[:, 1])[0]
            return ""
        sole = self.robot.sole
        if sole is not None and np.any(
            np.abs(cop - self.robot.sole_centre) > np.asarray(sole.size) / 2
        ):
            return f"toppled: {where} sole"
        return ""

    def wait_settled(self) -> str:
        """See ``RobotAdapter.wait_settled``: a pose whose CoP leaves the pads (the sole) tips
        over; a held robot always holds."""
        q = self._target[None]
        cop = self.robot.cop(q, self.r_true)
        ext: tuple = ()
        self._feet = None
        if self.config.double_support and self.sensors is not None:
            forces, tips, _ = two_foot_split(self.robot, self.sensors, q, cop, self.mass_true * G0)
            if tips[0]:
                c = cop[0] * 1e3
                return f"toppled: the CoP ({c[0]:.1f}, {c[1]:.1f}) mm left both feet"
            self._feet = {k: v[0] for k, v in forces.items()}
            ext = floor_forces(self.robot, self.sensors, forces, q, None)
        elif not self.held and (why := self._tipped(cop[0])):
            return why
        self._tau = holding_torques(self.robot, q, self.bodies, None, ext)[0]
        truth: dict[str, Any] = {"q_actual": self._target, "tau": self._tau}
        if not self.held:
            truth["cop_true"] = cop[0]
        self.truth[self._pose] = truth
        self._settled = True
        return ""

    def read(self, n: int) -> dict[str, np.ndarray]:
        """See ``RobotAdapter.read``."""
        if not self._settled:
            raise DataError(f"pose {self._pose}: read before the robot settled")
        pads = {f.name: np.zeros((n, 4)) for f in (self.sensors.feet if self.sensors else ())}
        if self._feet is not None:
            pads |= {k: np.tile(v, (n, 1)) for k, v in self._feet.items()}
        elif self.foot is not None and not self.held:
            pads[self.foot.name] = np.tile(self._pads, (n, 1))
        r = Readings(
            q=np.tile(self._target - self._unseen(), (n, 1)),
            pads=pads,
            tau=np.tile(self._tau, (n, 1)),
            approach=None if self._approach is None else np.full(n, self._approach),
        )
        return self.writer.columns(r, self.rng)


class MujocoAdapter(_BenchAdapter):
    """The MuJoCo physics bench as a robot: the "real" robot of ``ExperimentConfig`` in
    MuJoCo, one MjModel/MjData kept across poses."""

    def __init__(
        self,
        robot: Robot,
        sensors: SensorConfig | None,
        config=None,
        bench=None,
        seed: int | None = 0,
        feet: bool = True,
    ):
        from sescid.bench.mujoco import MujocoBenchConfig, Simulation  # the mujoco extra

        bench = bench or MujocoBenchConfig()
        if bench.weld_foot:
            raise OptionError("weld_foot", "a session stands the robot on its foot (no weld)")
        super().__init__(robot, sensors, config, seed, bench.imu_noise, feet)
        self.bench = bench
        self.sim = Simulation(robot, sensors, self.config, bench)
        self._res: PoseResult | None = None

    def _restand(self) -> None:
        from sescid.bench.mujoco import Simulation

        bench = dataclasses.replace(self.bench, double_support=self.config.double_support)
        self.sim = Simulation(self.robot, self.sensors, self.config, bench)

    def wait_settled(self) -> str:
        """See ``RobotAdapter.wait_settled``."""
        res, why = self.sim.run(self._target)
        self._res = res
        self._settled = res is not None
        if res is not None:
            self.truth[self._pose] = {
                "q_actual": res.q,
                "cop_true": self.robot.cop(res.q[None], self.r_true)[0],
                "com_world": res.com,
                "tau": res.tau,
            }
        return why

    def read(self, n: int) -> dict[str, np.ndarray]:
        """See ``RobotAdapter.read``."""
        from sescid.bench.mujoco import pose_readings

        if not self._settled or self._res is None:
            raise DataError(f"pose {self._pose}: read before the robot settled")
        reads = [self.sim.sample() for _ in range(n)]
        r = pose_readings(self.sim, self._res, reads, self._unseen(), self._approach)
        return self.writer.columns(r, self.rng)
