"""Does a pose stand? The planner's physics check (``sescid poses --check mujoco``).

Each pose is run on the MuJoCo bench (``bench.mujoco.run_mujoco_experiment``): the *model*
robot (no unmodelled mass, no backlash: the planner knows nothing else) released at rest in the
pose on its support foot's pads on a compliant floor, held by position servos, simulated until
still — to ``STILL_VEL``, looser than a measurement's (a pose that creeps by a few µm/s
stands), after at least ``MIN_SETTLE`` (a pose that topples has started to by then). A pose
stands unless the bench skips it (the sole tilts beyond ``topple_deg``, another body touches the
floor, or it does not settle within ``settle_time``).

Contacts: the support foot's pads of the profile's sensor layout, else pads at the corners of
the support sole (``Robot.sole``), which must then lie in the support frame's z = 0 plane (a sole
frame: the bench centres its pads on that plane). Servos: the profile's gains, else
``GENERIC_KV`` and ``GENERIC_ARMATURE`` scaled from the compliant model's stiffness
(``planning.compliance``: the OP2 profile's ratios).
"""

from __future__ import annotations

import dataclasses
import importlib.util
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sescid.bench.kinematic import ExperimentConfig
from sescid.errors import DataError, MissingExtraError, ModelError
from sescid.planning.compliance import compliance
from sescid.robot import Robot

GENERIC_KV = 1.0 / 320.0  #: s, servo damping / stiffness without profile gains (the OP2's)
GENERIC_ARMATURE = 3.4e-3 / 320.0  #: s², armature / stiffness without profile gains (the OP2's)
_SOLE_PLANE = 0.002  #: m, the derived sole must lie this close to the support frame's z = 0
STILL_VEL = 2e-4  #: rad/s, m/s: the check's velocity tolerance (the bench's default: 2e-5)
MIN_SETTLE = 1.0  #: s, simulated at least


@dataclass(frozen=True)
class Standing:
    """Which poses stand on the physics bench, and why the others did not."""

    mask: np.ndarray  #: (n,) True where the pose stands
    reasons: dict[int, str]  #: pose index → why it was skipped


def _sensors(robot: Robot):
    """The bench's foot pads: the profile's layout, else the support sole's corners."""
    from sescid.sensors.pads import Foot, SensorConfig, load_sensors

    if robot.profile.sensors_file is not None:
        return load_sensors(robot.profile.sensors_file)
    sole = robot.sole
    if sole is None:
        raise ModelError(f"{robot.model_path.name}: the physics check needs a support sole")
    corners = sole.corners @ robot.model.root_rotation.T + robot.model.root_origin
    if abs(robot.floor) > _SOLE_PLANE:
        raise ModelError(
            f"{robot.model_path.name}: the physics check stands the robot on pads in the support "
            f"frame's z = 0 plane, but the sole lies {robot.floor * 1e3:+.1f} mm from it: give "
            "--support a sole frame (z = 0 on the sole)"
        )
    pads = corners[[0, 1, 2, 3], :2]
    return SensorConfig(feet=(Foot("support", robot.support, "support_pad", pads),))


def _bench(robot: Robot):
    """The bench settings: the profile's servo gains, else scaled from the compliant model."""
    from sescid.bench.mujoco import MujocoBenchConfig

    bench = MujocoBenchConfig(vel_tol=STILL_VEL, min_settle=MIN_SETTLE)
    if robot.profile.servo_gains is not None:
        return bench
    kp = compliance(robot).kp
    return dataclasses.replace(bench, kp=kp, kv=GENERIC_KV * kp, armature=GENERIC_ARMATURE * kp)


def stands(robot: Robot, q: np.ndarray) -> Standing:
    """Run poses q (n, nq) [rad] on the MuJoCo bench; which stand (see the module docstring)."""
    if importlib.util.find_spec("mujoco") is None:
        raise MissingExtraError("the physics check (--check mujoco)", "mujoco")
    from sescid.bench.mujoco import run_mujoco_experiment

    q = np.asarray(q, dtype=float).reshape(-1, robot.nq)
    config = ExperimentConfig(extra_mass_fraction=0.0, extra=(), backlash_deg=0.0)
    ids = np.array([str(i) for i in range(len(q))])
    try:
        ex = run_mujoco_experiment(
            robot, q, _sensors(robot), samples=1, seed=0, config=config, bench=_bench(robot)
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


def standing_check(robot: Robot) -> Callable[[np.ndarray], np.ndarray]:
    """A ``planning.PlanOptions.check``: poses (k, nq) → (k,) True where they stand.

    MissingExtraError at once when MuJoCo is not installed; ModelError when the bench cannot
    stand this robot (no sole, or a support frame off the sole plane without sensor pads)."""
    if importlib.util.find_spec("mujoco") is None:
        raise MissingExtraError("the physics check (--check mujoco)", "mujoco")
    _sensors(robot)

    def check(q: np.ndarray) -> np.ndarray:
        return stands(robot, q).mask

    return check
