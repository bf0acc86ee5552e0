"""A physics-engine bench: the "real" robot stands in MuJoCo and its foot pads are read.

The kinematic bench (``experiment.virtual``) puts the CoP exactly at the CoM's ground projection.
This bench lets a physics engine decide instead: the real robot (the model plus the unmodelled
masses of ``ExperimentConfig``, ``virtual.real_bodies``) is built in memory with
``mujoco.MjSpec`` from sescid's body tree (full double precision, no XML round trip), stood on
its support foot on a floor plane, held in each commanded pose by position servos of finite
stiffness, simulated until still, and then logged like a real OP2: the same raw-log columns as
``run_experiment``, so ``sescid fsr`` and everything downstream run unchanged.

Model
    * Bodies, joint frames, axes, masses and CoMs come from ``real_bodies`` (the support
      body is the root; its frame is the support sole: origin at the sole centre, z up).
      Inertias are read from a URDF's ``<inertial>`` (merged per body by the parallel-axis
      rule; an unmodelled mass is a point mass); a body without one gets a sphere-like diagonal
      inertia ``0.4 m ρ²`` (``inertia_radius`` ρ). Statics does not depend on inertias.
    * Contact: each foot touches the floor only through its four FSR pads, spheres of radius
      ``pad_radius`` **centred on the sole plane** at the pad positions of the ``SensorConfig``.
      A sphere–plane contact force is vertical (plus friction) through the sphere's centre, so
      the pads' force-weighted centroid is exactly where the vertical line through the CoM
      meets the sole plane (friction forces at the common contact height have no tilting
      moment when they sum to zero, i.e. at rest). A pad's reading is the normal force of its
      contact (``mj_contactForce``), in mN. The other bodies carry the URDF's collision
      capsules (``planning.collision_capsules``), which collide with the floor only: a pose in
      which one of them (or the lifted foot's pads, in single support) touches the floor is
      skipped. Bodies never collide with each other (pose planning checks self-collision).
    * Servos: a position actuator per joint, torque ``kp (target − q) − kv q̇``, plus the
      joint's ``armature``; gains from ``robot.profile.servo_gains`` unless
      ``MujocoBenchConfig`` sets them. The target is the commanded angle plus the backlash offset
      δ ~ U(−b, b) of ``ExperimentConfig`` (as the kinematic bench); gravity then makes the
      joint **sag** below its target by τ/kp.

Procedure per pose: start at rest at the servo targets with the support sole level on the floor,
simulate until every joint and root velocity stays below ``vel_tol`` for ``still_time`` (at least
``min_settle``; at most ``settle_time``: else skipped as "did not settle"), then log ``samples``
samples ``sample_steps`` time steps apart. A pose is skipped when the support sole tilts by more
than ``topple_deg`` (it topples) or a body other than the feet's pads touches the floor.

Log columns (per sample)
    ``pose``, ``sample``; ``<joint>_ticks``: the profile servo's encoder reading of the settled
    angle,
    minus the part ``1 − readback_seen`` of δ that the encoder does not see (horn and bracket
    play; as the kinematic bench), with ``readback_jitter_ticks`` noise, rounded to ticks;
    ``r_fsr1..4``, ``l_fsr1..4``: pad forces in mN with the per-sensor bias and noise of
    ``ExperimentConfig`` (an unloaded pad reads 0), rounded and clipped to 0–65535 (and/or the
    centroid registers, as ``config.registers`` says); ``imu_roll``, ``imu_pitch`` (rad): the
    torso's roll and pitch (Z-Y-X Euler angles of ``imu_body`` relative to the world, as an
    ideal accelerometer at rest gives them) with ``imu_noise`` noise; ``grav_x``, ``grav_y``,
    ``grav_z``: the unit gravity direction in the support-sole frame (an IMU's reading turned
    through the model into the sole frame; ``imu_noise`` per component); ``fz_total_n``: the true
    total normal contact force (N), an ideal load cell under the floor.

Truth (per pose): commanded, target, actual (settled) and read-back angles, the servo sag
(actual − target), the support sole's tilt (rad) and height, the gravity direction in the
support-sole frame (``grav``, unit vector), the CoM in the sole frame, the noise-free pad CoP
(``cop_pads``), the flat-sole statics ``robot.cop(q_actual, r_true)`` (``cop_true``) and the
gravity-aware statics ``c_xy − c_z g_xy / g_z`` (``cop_gravity``).

Welded foot (``weld_foot=True``): the support body is fixed level to the world (no free joint).
Pads carry no contact force then; instead an ideal force/torque sensor at the sole centre is
read by inverse dynamics at the settled angles with zero velocity and acceleration
(``cop_ft`` in the truth, equal to the statics to ~1e-16 m), and the logged pad forces are that
wrench's normal force split over the pads by the bilinear weights of its CoP (whose centroid is
exactly that CoP), plus bias and noise.

Double support (``double_support=True``): the other foot's pads touch the floor too; the poses
must put both soles level at the same height (the start state places the robot at the model's
pose of the servo targets, so the other sole must be on z = 0 there to within ``pad_radius``).
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from sescid.bench.kinematic import (
    Experiment,
    ExperimentConfig,
    G,
    check_limits,
    pad_columns,
    pad_gains,
    real_bodies,
    real_robot,
    truth_record,
)
from sescid.errors import DataError, MissingExtraError, ModelError, OptionError, SescidError
from sescid.planning import collision_capsules
from sescid.robots.profile import ServoGains
from sescid.sensors.pads import SensorConfig
from sescid.sesc import tilted_cop


@dataclass(frozen=True)
class MujocoBenchConfig:
    """Physics-bench settings (SI units); servo gains None take the robot profile's.

    ``kp``, ``kv``, ``armature`` override ``robot.profile.servo_gains`` (the OP2's: MX-28 at
    the P gain its profile documents). Joint friction is left out, so the static equilibrium
    is unique (a real servo's friction leaves it anywhere within a band).
    """

    kp: float | None = None  #: N·m/rad, servo stiffness (None: the profile's)
    kv: float | None = None  #: N·m·s/rad, servo damping (None: the profile's)
    armature: float | None = None  #: kg·m², reflected rotor inertia per joint (None: profile's)
    timestep: float = 0.001  #: s
    settle_time: float = 10.0  #: s, give up (skip the pose) when not still by then
    min_settle: float = 0.3  #: s, simulate at least this long
    still_time: float = 0.2  #: s, velocities must stay below vel_tol this long
    #: rad/s (joints, root rotation) and m/s (root translation); the residual motion at this
    #: level moves the contact CoP by ~1–4 µm from statics (2e-4: ~10–40 µm)
    vel_tol: float = 2e-5
    sample_steps: int = 10  #: time steps between logged samples (10 ms: 100 Hz)
    topple_deg: float = 15.0  #: support-sole tilt beyond which the pose counts as toppled
    pad_radius: float = 0.003  #: m, radius of the spherical pad contact geoms
    friction: float = 1.0  #: sliding friction coefficient, pads on the floor
    contact_timeconst: float = 0.02  #: s, pad contact stiffness (MuJoCo solref; its default)
    contact_dampratio: float = 1.0  #: pad contact damping ratio (MuJoCo solref)
    inertia_radius: float = 0.02  #: m, fallback inertia 0.4 m ρ² for bodies without one
    #: link whose orientation the IMU reports; None: the profile's ``imu_link``, else the
    #: heaviest body
    imu_body: str | None = None
    imu_noise: float = 0.0  #: rad, per sample (std)
    weld_foot: bool = False  #: fix the support body level to the world (statics check)
    double_support: bool = False  #: both feet stand on the floor


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
    cop_ft: np.ndarray | None = None  #: (2,) welded mode: F/T CoP in the sole frame, m
    force_ft: float | None = None  #: welded mode: F/T normal force, N


def _mujoco():
    try:
        import mujoco
    except ImportError:  # pragma: no cover - depends on the environment
        raise MissingExtraError("the physics bench", "mujoco") from None
    return mujoco


def servo_gains(robot, bench: MujocoBenchConfig) -> ServoGains:
    """The bench's servo gains: the profile's, each overridden by ``bench`` when set."""
    base = robot.profile.servo_gains
    kp = bench.kp if bench.kp is not None else (base.kp if base else None)
    kv = bench.kv if bench.kv is not None else (base.kv if base else None)
    arm = bench.armature if bench.armature is not None else (base.armature if base else None)
    values: dict[str, float] = {}
    for name, v in (("kp", kp), ("kv", kv), ("armature", arm)):
        if v is None:
            raise OptionError(
                name, f"the profile of '{robot.name}' has no servo gains: give kp, kv, armature"
            )
        if not (math.isfinite(v) and (v > 0 if name == "kp" else v >= 0)):
            raise OptionError(name, f"must be a finite number {'>' if name == 'kp' else '≥'} 0")
        values[name] = float(v)
    return ServoGains(**values)


def _urdf_inertias(robot) -> dict[int, list[tuple[float, np.ndarray, np.ndarray]]]:
    """Per body: (mass, CoM in the body frame, inertia about that CoM in body axes) per link."""
    from sescid.model.urdf import load_urdf

    out: dict[int, list] = {}
    if robot.model.format != "urdf":
        return out
    try:
        urdf = load_urdf(robot.model.path)
    except SescidError:
        return out
    for link in urdf.robot.links:
        if link.name not in robot.model.link_frames or link.inertial is None:
            continue
        inertial = link.inertial
        if inertial.mass is None or not inertial.mass > 0 or inertial.inertia is None:
            continue
        b, x = robot.model.link_frames[link.name]
        o = np.eye(4) if inertial.origin is None else np.asarray(inertial.origin, dtype=float)
        t = x @ o
        inertia = np.asarray(inertial.inertia, dtype=float)
        out.setdefault(b, []).append(
            (float(inertial.mass), t[:3, 3].copy(), t[:3, :3] @ inertia @ t[:3, :3].T)
        )
    return out


def _body_inertia(parts, com: np.ndarray) -> np.ndarray:
    """Inertia (3, 3) about ``com`` of parts (mass, CoM, inertia about that CoM), parallel axes."""
    inertia = np.zeros((3, 3))
    for m, c, i_c in parts:
        d = c - com
        inertia += i_c + m * ((d @ d) * np.eye(3) - np.outer(d, d))
    return inertia


def _sole_body(robot, sole: str) -> tuple[int, np.ndarray]:
    if sole not in robot.model.link_frames:
        raise ModelError(f"sensor board on unknown link '{sole}' in {robot.model_path.name}")
    return robot.model.link_frames[sole]


def build_spec(robot, sensors: SensorConfig, config: ExperimentConfig, bench: MujocoBenchConfig):
    """The MuJoCo model spec of the real robot on a floor (see the module docstring)."""
    mujoco = _mujoco()
    gains = servo_gains(robot, bench)
    bodies, _ = real_bodies(robot, config)
    for b in bodies:
        if b.joint >= 0 and (b.multiplier != 1.0 or b.offset != 0.0):
            raise ModelError(
                f"joint '{b.joint_name}' mimics another joint: the physics bench does not "
                "support mimic joints"
            )
    parts = _urdf_inertias(robot)
    names = robot.body_names
    extra_total = config.extra_mass_fraction * robot.total_mass
    extra_parts: dict[int, list] = {}
    for e in config.extra:
        extra_parts.setdefault(names.index(e.body), []).append(
            (e.share * extra_total, np.asarray(e.offset, dtype=float), np.zeros((3, 3)))
        )

    spec = mujoco.MjSpec()
    spec.modelname = f"sescid_{robot.name}"
    spec.option.timestep = bench.timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.gravity = [0.0, 0.0, -G]
    floor = spec.worldbody.add_geom()
    floor.name = "floor"
    floor.type = mujoco.mjtGeom.mjGEOM_PLANE
    floor.size = [2.0, 2.0, 0.1]
    floor.contype = 0
    floor.conaffinity = 1
    floor.friction = [bench.friction, 0.005, 0.0001]

    support_feet = {f.name for f in sensors.feet if f.sole_frame == robot.support}
    if not support_feet:
        raise DataError(
            f"no foot sensor board sits on the support link '{robot.support}' "
            f"(boards: {', '.join(f.sole_frame for f in sensors.feet)})"
        )
    foot_body = {f.name: _sole_body(robot, f.sole_frame)[0] for f in sensors.feet}
    standing = {
        foot_body[f.name] for f in sensors.feet if bench.double_support or f.name in support_feet
    }

    caps = collision_capsules(robot)
    mj_bodies: list = []
    for i, b in enumerate(bodies):
        parent = spec.worldbody if b.parent < 0 else mj_bodies[b.parent]
        body = parent.add_body()
        body.name = b.name
        if b.parent >= 0:
            body.pos = b.trans_const.tolist()
            quat = np.zeros(4)
            mujoco.mju_mat2Quat(quat, np.ascontiguousarray(b.rot_const).ravel())
            body.quat = quat.tolist()
        mass = max(b.mass, 1e-9)
        body.mass = mass
        body.ipos = b.com.tolist()
        model_b = robot.model.bodies[i]
        own = parts.get(i) or [
            (model_b.mass, model_b.com, 0.4 * model_b.mass * bench.inertia_radius**2 * np.eye(3))
        ]
        inertia = _body_inertia(own + extra_parts.get(i, []), b.com)
        if not np.all(np.linalg.eigvalsh(inertia) > 1e-12):
            inertia = inertia + 0.4 * mass * bench.inertia_radius**2 * np.eye(3)
        body.fullinertia = [
            inertia[0, 0],
            inertia[1, 1],
            inertia[2, 2],
            inertia[0, 1],
            inertia[0, 2],
            inertia[1, 2],
        ]
        body.explicitinertial = True
        if b.parent < 0:
            if not bench.weld_foot:
                body.add_freejoint().name = "root"
            site = body.add_site()
            site.name = "sole_ft"
        else:
            j = body.add_joint()
            j.name = b.joint_name
            j.type = mujoco.mjtJoint.mjJNT_HINGE
            j.axis = (b.sign * b.axis).tolist()
            j.armature = gains.armature
        if i not in standing:
            for k in np.flatnonzero(caps.body == i):
                g = body.add_geom()
                g.name = f"cap_{b.name}_{k}"
                if np.linalg.norm(caps.p1[k] - caps.p0[k]) > 1e-9:
                    g.type = mujoco.mjtGeom.mjGEOM_CAPSULE
                    g.fromto = np.concatenate([caps.p0[k], caps.p1[k]]).tolist()
                else:
                    g.type = mujoco.mjtGeom.mjGEOM_SPHERE
                    g.pos = caps.p0[k].tolist()
                g.size = [float(caps.radius[k]), 0.0, 0.0]
                g.contype = 1
                g.conaffinity = 0
                g.mass = 0.0
        mj_bodies.append(body)

    for f in sensors.feet:
        b, x = _sole_body(robot, f.sole_frame)
        for k in range(4):
            p = x[:3, :3] @ np.array([f.sensors[k, 0], f.sensors[k, 1], 0.0]) + x[:3, 3]
            g = mj_bodies[b].add_geom()
            g.name = f"pad_{f.name}_{k + 1}"
            g.type = mujoco.mjtGeom.mjGEOM_SPHERE
            g.size = [bench.pad_radius, 0.0, 0.0]
            g.pos = p.tolist()
            g.contype = 1
            g.conaffinity = 0
            g.condim = 3
            g.friction = [bench.friction, 0.005, 0.0001]
            g.solref = [bench.contact_timeconst, bench.contact_dampratio]
            g.mass = 0.0
        site = mj_bodies[b].add_site()
        site.name = f"sole_{f.name}"
        site.pos = x[:3, 3].tolist()
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(x[:3, :3]).ravel())
        site.quat = quat.tolist()

    for j in robot.joint_names:
        a = spec.add_actuator()
        a.name = j
        a.target = j
        a.trntype = mujoco.mjtTrn.mjTRN_JOINT
        a.set_to_position(kp=gains.kp, kv=gains.kv)

    for kind, name in (("force", "ft_force"), ("torque", "ft_torque")):
        s = spec.add_sensor()
        s.name = name
        s.type = (
            mujoco.mjtSensor.mjSENS_FORCE if kind == "force" else mujoco.mjtSensor.mjSENS_TORQUE
        )
        s.objtype = mujoco.mjtObj.mjOBJ_SITE
        s.objname = "sole_ft"
    return spec


class _Bench:
    """A compiled model with index maps, simulating one pose at a time."""

    def __init__(self, robot, sensors, config, bench):
        mujoco = _mujoco()
        self.mj = mujoco
        self.robot, self.sensors, self.bench = robot, sensors, bench
        spec = build_spec(robot, sensors, config, bench)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        self.qadr = np.array(
            [m.jnt_qposadr[m.joint(j).id] for j in robot.joint_names], dtype=np.int64
        )
        self.root = m.body(robot.body_names[0]).id
        self.root_q = 0 if not bench.weld_foot else None  # free joint first in qpos
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
            f.name: np.array([m.geom(f"pad_{f.name}_{k}").id for k in range(1, 5)])
            for f in sensors.feet
        }
        self.pad_foot = {
            int(g): (name, k) for name, ids in self.pads.items() for k, g in enumerate(ids)
        }
        self.sole_site = {f.name: m.site(f"sole_{f.name}").id for f in sensors.feet}
        self.floor = m.geom("floor").id
        self.support_feet = {f.name for f in sensors.feet if f.sole_frame == robot.support}
        self.standing = {
            f.name for f in sensors.feet if bench.double_support or f.name in self.support_feet
        }
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
        if not bench.weld_foot:
            d.qpos[0:3] = [0.0, 0.0, bench.pad_radius]
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
        if not self.bench.weld_foot and rz < cos_topple:
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
        )
        if self.bench.weld_foot:
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


def run_mujoco_experiment(
    robot,
    q_cmd: np.ndarray,
    sensors: SensorConfig,
    samples: int = 100,
    seed: int | None = 0,
    config: ExperimentConfig | None = None,
    bench: MujocoBenchConfig | None = None,
    pose_ids: np.ndarray | None = None,
) -> Experiment:
    """Stand the real robot in each commanded pose (n, nq) [rad] in MuJoCo; log its sensors.

    Same raw-log columns as ``experiment.run_experiment`` (plus ``imu_roll``, ``imu_pitch``,
    ``fz_total_n``); poses that topple, touch the floor with another body or do not settle are
    listed in ``skipped`` with the reason and get no samples. See the module docstring.
    """
    config = config or ExperimentConfig()
    bench = bench or MujocoBenchConfig()
    q_cmd = np.asarray(q_cmd, dtype=float)
    if q_cmd.ndim != 2 or q_cmd.shape[1] != robot.nq:
        raise DataError(f"poses must be shaped (n, {robot.nq}), got {q_cmd.shape}")
    n = q_cmd.shape[0]
    if samples < 1:
        raise DataError(f"samples per pose must be ≥ 1, got {samples}")
    config.check()
    if not (bench.imu_noise >= 0 and math.isfinite(bench.imu_noise)):
        raise DataError(f"IMU noise must be a finite number ≥ 0, got {bench.imu_noise}")
    servo_gains(robot, bench)  # checks the gains
    for name, v in (
        ("timestep", bench.timestep),
        ("settle_time", bench.settle_time),
        ("vel_tol", bench.vel_tol),
        ("pad_radius", bench.pad_radius),
    ):
        if not (v > 0 and math.isfinite(v)):
            raise OptionError(name, f"must be a finite number > 0, got {v}")
    if bench.sample_steps < 1:
        raise OptionError("sample_steps", f"must be ≥ 1, got {bench.sample_steps}")
    check_limits(robot, q_cmd)
    pose_ids = np.array([str(i) for i in range(n)]) if pose_ids is None else np.asarray(pose_ids)
    sim = _Bench(robot, sensors, config, bench)
    r_true, mass_true, placed = real_robot(robot, config)
    rng = np.random.default_rng(seed)
    b = math.radians(config.backlash_deg)
    delta = rng.uniform(-b, b, size=q_cmd.shape)
    target = q_cmd + delta
    bias = {f.name: rng.normal(0.0, config.fsr_bias, size=4) for f in sensors.feet}
    gain = pad_gains(sensors, config, seed)
    support = next(f for f in sensors.feet if f.sole_frame == robot.support)

    kept, skipped, runs, timings = [], [], [], []
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
    if not kept:
        raise DataError(f"no pose can be measured: pose {skipped[0][0]}: {skipped[0][1]}")
    kept = np.array(kept)
    k = len(kept)
    m = k * samples
    pose_of = np.repeat(np.arange(k), samples)
    cols: dict[str, np.ndarray] = {
        "pose": pose_ids[kept][pose_of],
        "sample": np.tile(np.arange(samples), k),
    }
    q_act = np.array([r.q for r, _ in runs])
    q_samples = np.array([[s.q for s in reads] for _, reads in runs]).reshape(m, robot.nq)
    unseen = (1.0 - config.readback_seen) * delta[kept]
    q_read_s = q_samples - unseen[pose_of]
    servo = robot.profile.servo
    if servo is not None:
        exact = q_read_s * (servo.ticks_per_turn / (2 * math.pi)) + servo.zero_tick
        ticks = exact + rng.normal(0.0, config.readback_jitter_ticks, size=(m, robot.nq))
        ticks = np.clip(np.round(ticks), 0, servo.max_tick).astype(int)
        for j, name in enumerate(robot.joint_names):
            cols[f"{name}_ticks"] = ticks[:, j]
    else:
        for j, name in enumerate(robot.joint_names):
            cols[name] = q_read_s[:, j]

    weld = bench.weld_foot
    forces = {}
    for f in sensors.feet:
        if weld:
            fs = np.zeros((k, samples, 4))
            if f is support:
                uv = f.board_coordinates(np.array([r.cop_ft for r, _ in runs]))
                u, v = uv[:, 0], uv[:, 1]
                w = np.stack([(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v], axis=1)
                fz = np.array([r.force_ft for r, _ in runs])
                fs[:] = (w * fz[:, None])[:, None, :]
        else:
            fs = np.array([[s.pads[f.name] for s in reads] for _, reads in runs])
        forces[f.name] = fs.reshape(m, 4)
    for f in sensors.feet:
        true = forces[f.name]
        noisy = true / gain[f.name] + bias[f.name] + rng.normal(0.0, config.fsr_noise, size=(m, 4))
        counts = np.clip(np.round(noisy / sensors.force_unit), 0, sensors.saturation)
        counts = np.where(true > 0, counts, 0).astype(int)  # an unloaded FSR conducts nothing
        cols |= pad_columns(f, counts, config.registers, sensors)
    imu = np.array([[s.imu for s in reads] for _, reads in runs]).reshape(m, 2)
    imu = imu + rng.normal(0.0, bench.imu_noise, size=imu.shape)
    cols["imu_roll"] = imu[:, 0]
    cols["imu_pitch"] = imu[:, 1]
    # gravity direction in the support-sole frame per sample: Rᵀ (0, 0, −1), with IMU noise
    g_s = -np.array([[s.rot[2] for s in reads] for _, reads in runs]).reshape(m, 3)
    g_s = g_s + rng.normal(0.0, bench.imu_noise, size=g_s.shape)
    g_s /= np.linalg.norm(g_s, axis=1, keepdims=True)
    for a, axis in enumerate("xyz"):
        cols[f"grav_{axis}"] = g_s[:, a]
    fz_total = np.array([[s.fz for s in reads] for _, reads in runs]).reshape(m)
    if weld:
        fz_total = np.repeat([r.force_ft for r, _ in runs], samples)
    cols["fz_total_n"] = fz_total

    # truth, per pose, at the settled state
    rot = np.array([r.rot for r, _ in runs])  # sole → world
    pos = np.array([r.pos for r, _ in runs])
    grav = np.einsum("nji,j->ni", rot, np.array([0.0, 0.0, -1.0]))
    com_world = np.array([r.com for r, _ in runs])
    com_sole = np.einsum("nji,nj->ni", rot, com_world - pos)
    tilt = np.arccos(np.clip(rot[:, 2, 2], -1.0, 1.0))
    cop_flat = robot.cop(q_act, r_true)
    com_statics = robot.com(q_act, r_true)
    cop_gravity = tilted_cop(com_statics, grav[:, :2] / grav[:, 2:3])
    # noise-free pad CoP in the support frame (each loaded foot carried by the sim's pose)
    pad_cop = np.zeros((k, 2))
    pad_cop_biased = np.zeros((k, 2))
    fsum = np.zeros(k)
    fsum_b = np.zeros(k)
    for f in sensors.feet:
        fs = forces[f.name].reshape(k, samples, 4)[:, 0]
        fb = np.where(fs > 0, fs / gain[f.name] + bias[f.name], 0.0)
        rel_r = np.einsum("nji,njk->nik", rot, np.array([r.foot_rot[f.name] for r, _ in runs]))
        rel_o = np.einsum("nji,nj->ni", rot, np.array([r.foot_pos[f.name] for r, _ in runs]) - pos)
        pts = np.einsum("nij,kj->nki", rel_r[:, :2, :2], f.sensors) + rel_o[:, None, :2]
        pad_cop += np.einsum("nk,nki->ni", fs, pts)
        pad_cop_biased += np.einsum("nk,nki->ni", fb, pts)
        fsum += fs.sum(axis=1)
        fsum_b += fb.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        pad_cop /= fsum[:, None]
        pad_cop_biased /= fsum_b[:, None]
    q_read = q_act - unseen
    truth = truth_record(
        robot,
        config,
        sensors,
        seed,
        samples,
        mass_true,
        placed,
        r_true,
        bias,
        gain,
        units="m, kg, N, rad, s",
    )
    truth["engine"] = "mujoco"
    truth["settings"] |= {
        "bench": dataclasses.asdict(bench),
        "servo_gains": dataclasses.asdict(servo_gains(robot, bench)),
    }
    truth |= {
        "pose": pose_ids[kept].tolist(),
        "q_commanded": q_cmd[kept].tolist(),
        "q_target": target[kept].tolist(),
        "q_actual": q_act.tolist(),
        "q_readback": q_read.tolist(),
        "servo_sag": (q_act - target[kept]).tolist(),
        "foot_tilt": tilt.tolist(),
        "sole_height": pos[:, 2].tolist(),
        "grav": grav.tolist(),
        "com_sole": com_sole.tolist(),
        "cop_true": cop_flat.tolist(),
        "cop_gravity": cop_gravity.tolist(),
        "cop_pads": pad_cop.tolist(),
        "cop_expected": pad_cop_biased.tolist(),
        "settle_s": [r.settle for r, _ in runs],
        "wall_s": timings,
        "skipped": [{"pose": p, "reason": why} for p, why in skipped],
    }
    if weld:
        truth["cop_ft"] = [None if r.cop_ft is None else r.cop_ft.tolist() for r, _ in runs]
    return Experiment(columns=cols, truth=truth, skipped=skipped)
