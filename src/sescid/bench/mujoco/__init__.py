"""The physics bench: the "real" robot stands in MuJoCo and its sensors are read.

The kinematic bench (``bench.kinematic``) puts the CoP exactly at the CoM's ground projection
and the torques at rigid statics. This bench lets a physics engine decide instead: the real
robot (the model plus the unmodelled masses of ``ExperimentConfig``) is built in memory with
``mujoco.MjSpec`` from sescid's body tree (full double precision, no XML round trip; ``spec``),
stood on its support foot on a floor plane, held in each commanded pose by position servos of
finite stiffness, simulated until still (``sim``), and logged by the one raw-log writer
(``run``): the same columns as the kinematic bench, so ``sescid measure`` and everything
downstream run unchanged. The ``mujoco`` extra is needed.

Truth (per pose): commanded, target, actual (settled) and read-back angles, the servo sag, the
support sole's tilt and height, the gravity direction in the support-sole frame, the CoM in
the sole frame, the noise-free pad CoP (``cop_pads``), the flat-sole statics
``robot.cop(q_actual, r_true)`` (``cop_true``), the gravity-aware statics ``c_xy − c_z g_xy /
g_z`` (``cop_gravity``) and, with torque sensors, the servos' mean torques at rest.
"""

from sescid.bench.mujoco.run import pose_readings, run_mujoco_experiment
from sescid.bench.mujoco.sim import PoseResult, Simulation
from sescid.bench.mujoco.spec import MujocoBenchConfig, build_spec, servo_gains

__all__ = [
    "MujocoBenchConfig",
    "PoseResult",
    "Simulation",
    "build_spec",
    "pose_readings",
    "run_mujoco_experiment",
    "servo_gains",
]
