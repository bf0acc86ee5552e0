"""One MuJoCo model kept across poses: settle each pose, then read its sensors.

Per pose: start at rest at the servo targets with the support sole level on the floor, simulate
until every joint and root velocity stays below ``vel_tol`` for ``still_time`` (at least
``min_settle``; at most ``settle_time``: else the pose failed, "did not settle"); the pose
fails when the support sole tilts by more than ``topple_deg`` (it topples) or a body other than
the feet's pads touches the floor. Each read gives the settled angles, the pads' contact normal
forces (``mj_contactForce``), the servos' torques (the actuator forces), the IMU body's roll and
pitch, the support sole's pose and the CoM; with a welded root, an ideal force/torque sensor at
the sole centre read by inverse dynamics at rest.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.bench.mujoco.spec import (
    BENCH_NEEDS,
    build_spec,
    standing_feet,
    support_sole_plane,
)
from sescid.bench.real_robot import ExperimentConfig
from sescid.errors import OptionError
from sescid.model.mjcf_compile import mujoco_module
from sescid.robot import Robot
from sescid.sensors.pads import SensorConfig


@dataclass
class PoseResult:
    """What one settled pose gives (internal)."""

    q: np.ndarray  #: (nq,) settled joint angles, rad
    rot: np.ndarray  #: (3, 3) support sole in the world
    pos: np.ndarray  #: (3,) support sole origin in the world, m
    foot_rot: dict  #: foot name → (3, 3) its sole in the world
    foot_pos: dict  #: foot name → (3,) m
    pads: dict  #: foot name → (4,) pad normal forces, N
    imu: np.ndarray  #: (2,) roll, pitch, rad
    fz: float  #: N, total normal contact force
    com: np.ndarray  #: (3,) CoM in the world, m
    settle: float  #: s simulated until still
    tau: np.ndarray  #: (nq,) servo torques (actuator forces), N·m
    cop_ft: np.ndarray | None = None  #: (2,) welded mode: F/T CoP in the sole frame, m
    force_ft: float | None = None  #: welded mode: F/T normal force, N


class Simulation:
    """A compiled model with index maps, simulating one pose at a time."""

    def __init__(self, robot: Robot, sensors: SensorConfig | None, config: ExperimentConfig, bench):
        mujoco = mujoco_module(BENCH_NEEDS)
        self.mj = mujoco
        self.robot, self.sensors, self.bench = robot, sensors, bench
        self.weld = bench.weld_foot or config.mount == "gantry"
        feet = sensors.feet if sensors is not None else ()
        spec = build_spec(robot, sensors, config, bench)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        self.qadr = np.array(
            [m.jnt_qposadr[m.joint(j).id] for j in robot.joint_names], dtype=np.int64
        )
        self.root = m.body(robot.body_names[0]).id
        names = robot.body_names
        imu = bench.imu_body or robot.profile.imu_link or names[int(np.argmax(robot.masses))]
        if imu in robot.model.link_frames:
            b_imu, x_imu = robot.model.link_frames[imu]
        elif imu in names:
            b_imu, x_imu = names.index(imu), np.eye(4)
        else:
            raise OptionError("imu_body", f"'{imu}' is not a link (bodies: {', '.join(names)})")
        self.imu = m.body(names[b_imu]).id
        self.imu_rot = np.asarray(x_imu[:3, :3], dtype=float)  # the link in its body's frame
        self.pads = {
            f.name: np.array([m.geom(f"pad_{f.name}_{k}").id for k in range(1, 5)]) for f in feet
        }
        self.pad_foot = {
            int(g): (name, k) for name, ids in self.pads.items() for k, g in enumerate(ids)
        }
        self.sole_site = {f.name: m.site(f"sole_{f.name}").id for f in feet}
        self.floor = m.geom("floor").id if config.mount != "gantry" else -1
        self.standing = standing_feet(robot, sensors, config, bench)
        #: m, the support foot's sole plane in the support frame (its pads sit on it)
        self.sole_plane = support_sole_plane(robot, robot.support) if feet else 0.0
        self.geom_name = [m.geom(i).name for i in range(m.ngeom)]

    def _contacts(self):
        """(pad forces per foot [N], list of other geoms touching the floor)."""
        mj, m, d = self.mj, self.model, self.data
        pads = {name: np.zeros(4) for name in self.pads}
        others = []
        f6 = np.zeros(6)
        for i in range(d.ncon):
            c = d.contact[i]
            g = c.geom2 if c.geom1 == self.floor else c.geom1
            hit = self.pad_foot.get(int(g))
            if hit is not None and hit[0] in self.standing:
                mj.mj_contactForce(m, d, i, f6)
                pads[hit[0]][hit[1]] += f6[0]
            elif c.dist < 0:
                others.append(self.geom_name[g])
        return pads, others

    def run(self, target: np.ndarray) -> tuple[PoseResult | None, str]:
        """Settle at the servo targets; the result or None and why the pose was skipped."""
        mj, m, d, bench = self.mj, self.model, self.data, self.bench
        mj.mj_resetData(m, d)
        d.qpos[self.qadr] = target
        if not self.weld:
            d.qpos[0:3] = [0.0, 0.0, bench.pad_radius - self.sole_plane]
            d.qpos[3:7] = [1.0, 0.0, 0.0, 0.0]
        d.ctrl[:] = target
        steps_still = int(round(bench.still_time / bench.timestep))
        n_min = int(round(bench.min_settle / bench.timestep))
        n_max = int(round(bench.settle_time / bench.timestep))
        cos_topple = math.cos(math.radians(bench.topple_deg))
        still = 0
        check = 20  # contact/topple checks every few steps
        for step in range(1, n_max + 1):
            mj.mj_step(m, d)
            if np.max(np.abs(d.qvel)) < bench.vel_tol:
                still += 1
            else:
                still = 0
            if step % check == 0 or (step >= n_min and still >= steps_still):
                why = self._failure(cos_topple)
                if why:
                    return None, f"{why} after {step * bench.timestep:.2f} s"
            if step >= n_min and still >= steps_still:
                return self._read(step * bench.timestep), ""
        vmax = np.max(np.abs(d.qvel))
        return None, (
            f"did not settle within {bench.settle_time:g} s (largest velocity {vmax:.2g}, "
            f"tolerance {bench.vel_tol:g})"
        )

    def _failure(self, cos_topple: float) -> str:
        d = self.data
        rz = d.xmat[self.root].reshape(3, 3)[2, 2]
        if not self.weld and rz < cos_topple:
            tilt = math.degrees(math.acos(max(-1.0, min(1.0, rz))))
            return f"toppled: the support sole tilted by {tilt:.1f}°"
        if not np.all(np.isfinite(d.qpos)):
            return "the simulation diverged"
        _, others = self._contacts()
        if others:
            bodies = sorted(
                {
                    self.model.body(self.model.geom_bodyid[self.model.geom(g).id]).name
                    for g in others
                }
            )
            return f"toppled: {', '.join(bodies)} touched the floor"
        return ""

    def sample(self) -> PoseResult:
        """Advance ``sample_steps`` and read the sensors."""
        for _ in range(self.bench.sample_steps):
            self.mj.mj_step(self.model, self.data)
        return self._read(0.0)

    def _read(self, settle: float) -> PoseResult:
        mj, m, d = self.mj, self.model, self.data
        mj.mj_forward(m, d)
        pads, _ = self._contacts()
        rot = d.xmat[self.root].reshape(3, 3).copy()
        pos = d.xpos[self.root].copy()
        imu_r = d.xmat[self.imu].reshape(3, 3) @ self.imu_rot
        roll = math.atan2(imu_r[2, 1], imu_r[2, 2])
        pitch = -math.asin(max(-1.0, min(1.0, imu_r[2, 0])))
        foot_rot = {k: d.site_xmat[s].reshape(3, 3).copy() for k, s in self.sole_site.items()}
        foot_pos = {k: d.site_xpos[s].copy() for k, s in self.sole_site.items()}
        res = PoseResult(
            q=d.qpos[self.qadr].copy(),
            rot=rot,
            pos=pos,
            foot_rot=foot_rot,
            foot_pos=foot_pos,
            pads=pads,
            imu=np.array([roll, pitch]),
            fz=float(sum(p.sum() for p in pads.values())),
            com=d.subtree_com[self.root].copy(),
            settle=settle,
            tau=d.actuator_force[: self.robot.nq].copy(),
        )
        if self.weld and self.sensors is not None:
            res.cop_ft, res.force_ft = self.sole_ft()
        return res

    def sole_ft(self) -> tuple[np.ndarray, float]:
        """Ideal sole force/torque sensor at rest (qvel = qacc = 0): CoP (2,) [m] and F_z [N]."""
        mj, m, d = self.mj, self.model, self.data
        qpos = d.qpos.copy()
        d2 = mj.MjData(m)
        d2.qpos[:] = qpos
        d2.qvel[:] = 0.0
        d2.qacc[:] = 0.0
        mj.mj_inverse(m, d2)
        mj.mj_rnePostConstraint(m, d2)
        mj.mj_sensorAcc(m, d2)
        # the wrench the world exerts on the support body, at the sole centre, in the sole frame
        f = d2.sensor("ft_force").data
        t = d2.sensor("ft_torque").data
        # a vertical force f_z at (x, y, 0) has the moment (y f_z, −x f_z, 0)
        fz = f[2]
        return np.array([-t[1] / fz, t[0] / fz]), float(fz)
