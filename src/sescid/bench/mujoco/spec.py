"""The MuJoCo model of the real robot on a floor, built in memory with ``mujoco.MjSpec``.

Bodies, joint frames, axes, masses and CoMs come from ``real_bodies`` (the support body is the
root; its frame is the support sole: origin at the sole centre, z up). Inertias are read from a
URDF's ``<inertial>`` (merged per body by the parallel-axis rule; an unmodelled mass is a point
mass); a body without one gets a sphere-like diagonal inertia ``0.4 m ρ²`` (``inertia_radius``
ρ). Statics does not depend on inertias.

Contact: each foot touches the floor only through its four pads, spheres of radius
``pad_radius`` centred on the sole plane at the pad positions of the ``SensorConfig`` (the support
foot's sole plane lies at ``Robot.floor`` of its frame when the sole is derived); the other
bodies carry the model's collision capsules (``planning.collision_capsules``) and, for its
collision meshes, their convex hulls, which collide with the floor only (bodies in
``floor_exempt`` carry none). Servos: a position actuator per joint, torque
``kp (target − q) − kv q̇``, plus the joint's ``armature``. In a gantry (``mount="gantry"``)
the root is welded level and there is no floor (the robot hangs free).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.base import G0, option
from sescid.bench.kinematic import support_foot
from sescid.bench.real_robot import ExperimentConfig, extra_masses, real_bodies
from sescid.errors import ModelError, OptionError, SescidError
from sescid.model.mjcf_compile import mujoco_module
from sescid.planning import collision_capsules
from sescid.robot import Robot
from sescid.robots.profile import ServoGains
from sescid.sensors.pads import SensorConfig


@dataclass(frozen=True)
class MujocoBenchConfig:
    """Physics-bench settings (SI units); servo gains None take the robot profile's.

    ``kp``, ``kv``, ``armature`` override ``robot.profile.servo_gains`` (the OP2's: MX-28 at
    the P gain its profile documents). Joint friction is left out, so the static equilibrium
    is unique (a real servo's friction is the torque sensor model's band, ``TorqueConfig``).
    """

    kp: float | None = option(
        None,
        "mujoco: servo stiffness [N·m/rad] (default: the robot profile's servo gains).",
        low=0, low_open=True,
    )  # fmt: skip
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
    #: 1/s², pad contact stiffness given directly (MuJoCo's negative solref: reference
    #: acceleration per metre of penetration, critically damped); None: ``contact_timeconst``
    contact_stiffness: float | None = None
    inertia_radius: float = 0.02  #: m, fallback inertia 0.4 m ρ² for bodies without one
    #: link whose orientation the IMU reports; None: the profile's ``imu_link``, else the
    #: heaviest body
    imu_body: str | None = None
    imu_noise: float = 0.0  #: rad, per sample (std)
    weld_foot: bool = option(
        False, "mujoco: fix the support foot level to the world (pads read an ideal F/T sensor)."
    )
    double_support: bool = False  #: both feet stand on the floor
    #: bodies that carry no floor contact (the planner's exempt bodies: already below the floor
    #: at the zero pose, as a support foot's toes)
    floor_exempt: tuple[str, ...] = ()

    def check(self) -> None:
        """OptionError naming the first setting outside its range."""
        if not (self.imu_noise >= 0 and math.isfinite(self.imu_noise)):
            raise OptionError("imu_noise", f"must be a finite number ≥ 0, got {self.imu_noise}")
        for name in ("timestep", "settle_time", "vel_tol", "pad_radius"):
            v = getattr(self, name)
            if not (v > 0 and math.isfinite(v)):
                raise OptionError(name, f"must be a finite number > 0, got {v}")
        if self.sample_steps < 1:
            raise OptionError("sample_steps", f"must be ≥ 1, got {self.sample_steps}")


#: what needs MuJoCo here, for the missing extra's message
BENCH_NEEDS = "the physics bench"


def servo_gains(robot: Robot, bench: MujocoBenchConfig) -> ServoGains:
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


def _urdf_inertias(robot: Robot) -> dict[int, list[tuple[float, np.ndarray, np.ndarray]]]:
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


def sole_body(robot: Robot, sole: str) -> tuple[int, np.ndarray]:
    """(body index, link frame (4, 4) in it) of a sensor board's sole link."""
    if sole not in robot.model.link_frames:
        raise ModelError(f"sensor board on unknown link '{sole}' in {robot.model_path.name}")
    return robot.model.link_frames[sole]


def standing_feet(robot: Robot, sensors: SensorConfig | None, config, bench) -> set[str]:
    """Names of the feet that stand on the floor (their pads collide; no capsules)."""
    if sensors is None or config.mount == "gantry":
        return set()
    support = support_foot(robot, sensors).name
    return {f.name for f in sensors.feet if bench.double_support or f.name == support}


def _inertia_list(own, extra, b, model_b, bench) -> list[float]:
    """MuJoCo's ``fullinertia`` (xx, yy, zz, xy, xz, yz) of a body about its CoM: its own parts
    (the URDF's, else a sphere-like default) and the unmodelled point masses ``extra``."""
    own = own or [
        (model_b.mass, model_b.com, 0.4 * model_b.mass * bench.inertia_radius**2 * np.eye(3))
    ]
    inertia = _body_inertia(own + extra, b.com)
    if not np.all(np.linalg.eigvalsh(inertia) > 1e-12):
        inertia = inertia + 0.4 * max(b.mass, 1e-9) * bench.inertia_radius**2 * np.eye(3)
    return [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2],
            inertia[1, 2]]  # fmt: skip


def _add_bodies(mujoco, spec, robot: Robot, config, bench, standing_bodies: set[int]) -> list:
    """The body tree with its joints and (for bodies not standing) collision capsules."""
    bodies, _ = real_bodies(robot, config)
    parts = _urdf_inertias(robot)
    extra_total = config.extra_mass_fraction * robot.total_mass
    extra_parts: dict[int, list] = {}
    for e in extra_masses(robot, config):
        extra_parts.setdefault(robot.body_names.index(e.body), []).append(
            (e.share * extra_total, np.asarray(e.offset, dtype=float), np.zeros((3, 3)))
        )
    gains = servo_gains(robot, bench)
    weld = bench.weld_foot or config.mount == "gantry"
    caps = collision_capsules(robot)
    mj_bodies: list = []
    for i, b in enumerate(bodies):
        if b.joint >= 0 and (b.multiplier != 1.0 or b.offset != 0.0):
            raise ModelError(
                f"joint '{b.joint_name}' mimics another joint: the physics bench does not "
                "support mimic joints"
            )
        body = (spec.worldbody if b.parent < 0 else mj_bodies[b.parent]).add_body()
        body.name = b.name
        if b.parent >= 0:
            body.pos = b.trans_const.tolist()
            quat = np.zeros(4)
            mujoco.mju_mat2Quat(quat, np.ascontiguousarray(b.rot_const).ravel())
            body.quat = quat.tolist()
        body.mass = max(b.mass, 1e-9)
        body.ipos = b.com.tolist()
        body.fullinertia = _inertia_list(
            parts.get(i), extra_parts.get(i, []), b, robot.model.bodies[i], bench
        )
        body.explicitinertial = True
        if b.parent < 0:
            if not weld:
                body.add_freejoint().name = "root"
            body.add_site().name = "sole_ft"
        else:
            j = body.add_joint()
            j.name = b.joint_name
            j.type = mujoco.mjtJoint.mjJNT_HINGE
            j.axis = (b.sign * b.axis).tolist()
            j.armature = gains.armature
        if i not in standing_bodies and b.name not in bench.floor_exempt:
            _add_capsules(mujoco, body, caps, i, b.name)
            _add_meshes(mujoco, spec, body, robot, i, b.name)
        mj_bodies.append(body)
    return mj_bodies


def _add_meshes(mujoco, spec, body, robot: Robot, i: int, name: str) -> None:
    """Body ``i``'s collision meshes whose vertices are loaded, as MuJoCo meshes (their convex
    hulls: exactly the points the planner's floor check uses; they touch the floor only)."""
    from sescid.model.geometry import MESH

    shapes = [s for s in robot.shapes if s.body == i and s.role == "collision"]
    for k, shape in enumerate(s for s in shapes if s.kind == MESH and s.vertices is not None):
        mesh = spec.add_mesh()
        mesh.name = f"hull_{name}_{k}"
        mesh.uservert = np.ascontiguousarray(shape.vertices, dtype=np.float32).ravel().tolist()
        g = body.add_geom()
        g.name = f"mesh_{name}_{k}"
        g.type = mujoco.mjtGeom.mjGEOM_MESH
        g.meshname = mesh.name
        g.contype = 1
        g.conaffinity = 0
        g.mass = 0.0


def _add_capsules(mujoco, body, caps, i: int, name: str) -> None:
    """Body ``i``'s collision capsules but those covering a mesh (``_add_meshes``); they touch
    the floor only."""
    meshy = caps.from_mesh if caps.from_mesh is not None else np.zeros(len(caps.body), bool)
    for k in np.flatnonzero((caps.body == i) & ~meshy):
        g = body.add_geom()
        g.name = f"cap_{name}_{k}"
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


def support_sole_plane(robot: Robot, sole_frame: str) -> float:
    """Height [m] of the sole plane in the frame ``sole_frame``: the floor under the support
    frame derived from the foot's geometry (``Robot.floor``: a foot frame above its sole, as
    the G1's ankle frame) when it is the support; the free foot's derived sole below its
    frame (``Robot.free_sole``) when it is the free foot's; else 0 (a sole frame)."""
    if sole_frame == robot.support:
        if robot.sole is None or not robot.sole.derived:
            return 0.0
        return float(robot.floor)
    free = robot.free_sole
    if free is not None and free.derived and free.link == sole_frame:
        _, x = robot.model.link_frames[sole_frame]
        return float(np.mean((free.corners - x[:3, 3]) @ x[:3, 2]))
    return 0.0


def _add_pads(mujoco, robot: Robot, sensors: SensorConfig | None, bench, mj_bodies: list) -> None:
    """Each board's four pad spheres on its sole plane and a site at its sole frame."""
    for f in sensors.feet if sensors is not None else ():
        b, x = sole_body(robot, f.sole_frame)
        dz = support_sole_plane(robot, f.sole_frame)
        for k in range(4):
            p = x[:3, :3] @ np.array([f.sensors[k, 0], f.sensors[k, 1], dz]) + x[:3, 3]
            g = mj_bodies[b].add_geom()
            g.name = f"pad_{f.name}_{k + 1}"
            g.type = mujoco.mjtGeom.mjGEOM_SPHERE
            g.size = [bench.pad_radius, 0.0, 0.0]
            g.pos = p.tolist()
            g.contype = 1
            g.conaffinity = 0
            g.condim = 3
            g.friction = [bench.friction, 0.005, 0.0001]
            if bench.contact_stiffness is not None:
                k = float(bench.contact_stiffness)
                g.solref = [-k, -2.0 * math.sqrt(k)]
            else:
                g.solref = [bench.contact_timeconst, bench.contact_dampratio]
            g.mass = 0.0
        site = mj_bodies[b].add_site()
        site.name = f"sole_{f.name}"
        site.pos = x[:3, 3].tolist()
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(x[:3, :3]).ravel())
        site.quat = quat.tolist()


def build_spec(robot: Robot, sensors: SensorConfig | None, config: ExperimentConfig, bench):
    """The MuJoCo model spec of the real robot on a floor (module docstring)."""
    mujoco = mujoco_module(BENCH_NEEDS)
    spec = mujoco.MjSpec()
    spec.modelname = f"sescid_{robot.name}"
    spec.option.timestep = bench.timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.gravity = [0.0, 0.0, -G0]
    if config.mount != "gantry":
        floor = spec.worldbody.add_geom()
        floor.name = "floor"
        floor.type = mujoco.mjtGeom.mjGEOM_PLANE
        floor.size = [2.0, 2.0, 0.1]
        floor.contype = 0
        floor.conaffinity = 1
        floor.friction = [bench.friction, 0.005, 0.0001]
    standing = standing_feet(robot, sensors, config, bench)
    assert sensors is not None or not standing
    standing_bodies = {
        sole_body(robot, f.sole_frame)[0]
        for f in (sensors.feet if sensors else ())
        if f.name in standing
    }
    mj_bodies = _add_bodies(mujoco, spec, robot, config, bench, standing_bodies)
    _add_pads(mujoco, robot, sensors, bench, mj_bodies)
    for j in robot.joint_names:
        a = spec.add_actuator()
        a.name = j
        a.target = j
        a.trntype = mujoco.mjtTrn.mjTRN_JOINT
        a.set_to_position(kp=(g := servo_gains(robot, bench)).kp, kv=g.kv)
    for kind, name in (("force", "ft_force"), ("torque", "ft_torque")):
        s = spec.add_sensor()
        s.name = name
        s.type = (
            mujoco.mjtSensor.mjSENS_FORCE if kind == "force" else mujoco.mjtSensor.mjSENS_TORQUE
        )
        s.objtype = mujoco.mjtObj.mjOBJ_SITE
        s.objname = "sole_ft"
    return spec
