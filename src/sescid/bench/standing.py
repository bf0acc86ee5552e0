"""Does a pose stand? The planner's physics check (``sescid poses --check mujoco``).

Each pose is run on the MuJoCo bench (``bench.mujoco.run_mujoco_experiment``): the *model*
robot (no unmodelled mass, no backlash: the planner knows nothing else) released at rest in the
pose on its support foot's pads on a compliant floor, held by position servos, simulated until
still — to ``STILL_VEL``, looser than a measurement's (a pose that creeps by a few µm/s
stands), after at least ``MIN_SETTLE`` (a pose that topples has started to by then), at most
``SETTLE_TIME``. A pose
stands unless the bench skips it (the sole tilts beyond ``topple_deg``, another body touches the
floor, or it does not settle within ``settle_time``).

Contacts: the support foot's pads of the profile's sensor layout, else pads at the corners of
the support sole (``Robot.sole``), on its plane (z = 0 of a sole frame; below a foot frame, at
``Robot.floor``); on both feet (``double``) the free foot's pads too (the profile's, else its
sole's corners in its level link frame, ``free_pads``). Servos: the profile's gains, else
``GENERIC_KV`` and ``GENERIC_ARMATURE`` scaled from the compliant model's stiffness
(``planning.compliance``: the OP2 profile's ratios), the damping raised to ``SWAY_DAMPING`` of
the whole robot's sway where that is more. Pads: MuJoCo's default contact (they sink
about ``GENERIC_SINK``, as the generic model's), or, where the generic model stiffens a tall
robot's narrow sole, a direct stiffness that sinks them as far as the model's contacts.
"""

from __future__ import annotations

import dataclasses
import importlib.util
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sescid.base import G0
from sescid.bench.kinematic import ExperimentConfig
from sescid.errors import DataError, MissingExtraError, ModelError
from sescid.planning.feasibility.compliance import GENERIC_SINK, compliance
from sescid.robot import Robot

GENERIC_KV = 1.0 / 320.0  #: s, servo damping / stiffness without profile gains (the OP2's)
GENERIC_ARMATURE = 3.4e-3 / 320.0  #: s², armature / stiffness without profile gains (the OP2's)
#: the bench's pads with MuJoCo's direct contact stiffness k [1/s²] sink by about this times
#: g / k under the robot's weight (measured: 0.41–0.51 on the CMU humanoid, 10⁴–10⁵ 1/s²)
PAD_SINK_ACCEL = 0.45
#: generic servo damping at least this ratio for the whole robot swaying about its ankle on one
#: servo (inertia M h²): a tall robot's slow sway settles (statics do not depend on it)
SWAY_DAMPING = 0.5
STILL_VEL = 2e-4  #: rad/s, m/s: the check's velocity tolerance (the bench's default: 2e-5)
MIN_SETTLE = 1.0  #: s, simulated at least
#: s, simulated at most: a tall robot on stiff pads creeps to rest on MuJoCo's soft friction for
#: ~10–15 s (the bench's default gives up at 10 s)
SETTLE_TIME = 30.0


@dataclass(frozen=True)
class Standing:
    """Which poses stand on the physics bench, and why the others did not."""

    mask: np.ndarray  #: (n,) True where the pose stands
    reasons: dict[int, str]  #: pose index → why it was skipped


def _sensors(robot: Robot, double: bool = False):
    """The bench's foot pads: the profile's layout, else the support sole's corners (and, on
    both feet, the free sole's corners in its link's frame: ``free_pads``)."""
    from sescid.sensors.pads import Foot, SensorConfig, load_sensors

    if robot.profile.sensors_file is not None:
        config = load_sensors(robot.profile.sensors_file)
        free = robot.free_sole
        if not double or any(f.sole_frame == (free and free.link) for f in config.feet):
            return config
        raise ModelError(
            f"{robot.model_path.name}: the sensor layout has no board on the free foot "
            f"'{free.link if free else '?'}': the physics check on both feet needs one"
        )
    sole = robot.sole
    if sole is None:
        raise ModelError(f"{robot.model_path.name}: the physics check needs a support sole")
    corners = sole.corners @ robot.model.root_rotation.T + robot.model.root_origin
    pads = corners[[0, 1, 2, 3], :2]
    feet = [Foot("support", robot.support, "support_pad", pads)]
    if double:
        feet.append(Foot("free", *free_pads(robot)))
    return SensorConfig(feet=tuple(feet))


def free_pads(robot: Robot) -> tuple[str, str, np.ndarray]:
    """(sole link, column prefix, pads (4, 2) [m]) of the free foot for the physics bench on
    both feet: its sole's corners in its link's frame, which must be level at the zero pose
    (z up) with the sole in its x/y plane (ModelError otherwise)."""
    from sescid.model.sole import CONTACT_TOL

    sole = robot.free_sole
    if sole is None or min(sole.size) <= 0:
        raise ModelError(f"{robot.model_path.name}: the physics check on both feet needs the "
                         "free foot's sole")  # fmt: skip
    b, x = robot.model.link_frames[sole.link]
    rot, _ = robot.link_poses(np.zeros((1, robot.nq)), sole.link)
    local = (sole.corners - x[:3, 3]) @ x[:3, :3]  # corners in the link's frame
    if abs(rot[0, 2, 2] - 1.0) > 1e-9 or np.ptp(local[:, 2]) > CONTACT_TOL:
        raise ModelError(
            f"{robot.model_path.name}: the free foot's frame '{sole.link}' is not level at the "
            "zero pose: the physics check on both feet needs a level sole frame on it (a profile "
            "sensor layout)"
        )
    return sole.link, "free_pad", local[:, :2]


def _bench(robot: Robot, double: bool = False):
    """The bench settings: the profile's servo gains, else scaled from the compliant model."""
    from sescid.bench.mujoco import MujocoBenchConfig
    from sescid.planning.feasibility.ground import ground_checks

    exempt = tuple(ground_checks(robot).exempt)
    bench = MujocoBenchConfig(
        vel_tol=STILL_VEL,
        min_settle=MIN_SETTLE,
        settle_time=SETTLE_TIME,
        floor_exempt=exempt,
        double_support=double,
    )
    model = compliance(robot)
    if robot.profile.pad_stiffness is None:
        sink = model.weight / (len(model.contacts) * model.contact_stiffness)
        if sink < GENERIC_SINK * (1 - 1e-9):  # stiffened: a tall robot on a narrow foot
            bench = dataclasses.replace(bench, contact_stiffness=PAD_SINK_ACCEL * G0 / sink)
    if robot.profile.servo_gains is not None:
        return bench
    kp = model.kp
    h = max(float(robot.com(np.zeros(robot.nq))[0, 2]) - robot.floor, 0.0)
    sway = 2 * SWAY_DAMPING * np.sqrt(kp * robot.total_mass * h * h)
    kv = max(GENERIC_KV * kp, float(sway))
    return dataclasses.replace(bench, kp=kp, kv=kv, armature=GENERIC_ARMATURE * kp)


def stands(robot: Robot, q: np.ndarray, double: bool = False) -> Standing:
    """Run poses q (n, nq) [rad] on the MuJoCo bench (``double``: on both feet); which stand
    (see the module docstring)."""
    if importlib.util.find_spec("mujoco") is None:
        raise MissingExtraError("the physics check (--check mujoco)", "mujoco")
    from sescid.bench.mujoco import run_mujoco_experiment

    q = np.asarray(q, dtype=float).reshape(-1, robot.nq)
    config = ExperimentConfig(extra_mass_fraction=0.0, extra=(), backlash_deg=0.0)
    ids = np.array([str(i) for i in range(len(q))])
    try:
        ex = run_mujoco_experiment(
            robot, q, _sensors(robot, double), samples=1, seed=0, config=config,
            bench=_bench(robot, double),
        )  # fmt: skip
        skipped = ex.skipped
    except DataError as exc:  # no pose stood at all
        if "no pose can be measured" not in str(exc):
            raise
        skipped = [(i, "toppled, did not settle or touched the floor") for i in ids]
    reasons = {int(p): why for p, why in skipped}
    mask = np.ones(len(q), dtype=bool)
    mask[list(reasons)] = False
    return Standing(mask, reasons)


def standing_check(robot: Robot, double: bool = False) -> Callable[[np.ndarray], np.ndarray]:
    """A ``planning.PlanOptions.check``: poses (k, nq) → (k,) True where they stand (``double``:
    on both feet).

    MissingExtraError at once when MuJoCo is not installed; ModelError when the bench cannot
    stand this robot (no sole, or a support frame off the sole plane without sensor pads)."""
    if importlib.util.find_spec("mujoco") is None:
        raise MissingExtraError("the physics check (--check mujoco)", "mujoco")
    _sensors(robot, double)

    def check(q: np.ndarray) -> np.ndarray:
        return stands(robot, q, double).mask

    return check
