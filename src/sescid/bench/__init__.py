"""Benches: a "real" robot that differs from its model (unmodelled masses, backlash, sensor
errors) measured at planned poses, writing the raw log a real robot would.

``real_robot`` is the real robot and its sensors' errors (``ExperimentConfig``,
``TorqueConfig``); ``statics`` the joint torques that hold a pose; ``log`` the one raw-log
writer every bench and session adapter uses; ``kinematic`` is rigid statics (fast, exact
truth); ``mujoco`` stands the robot on a compliant floor with position servos in MuJoCo (the
``mujoco`` extra); ``truth`` is the typed truth record and its file; ``compare`` compares a fit
with that truth.
"""

from sescid.bench.compare import FRESH_POSES, FRESH_WITHIN_DEG, TruthComparison, compare_truth
from sescid.bench.kinematic import Experiment, run_experiment
from sescid.bench.log import RawLogWriter, Readings
from sescid.bench.mujoco import MujocoBenchConfig, run_mujoco_experiment
from sescid.bench.real_robot import (
    DEFAULT_EXTRA,
    NO_POSE_MEASURED,
    Approach,
    BenchMount,
    Engine,
    ExperimentConfig,
    ExtraMass,
    Registers,
    SensorErrors,
    TorqueConfig,
    approach_sides,
    check_limits,
    draw_errors,
    real_bodies,
    real_robot,
)
from sescid.bench.standing import standing_check, stands
from sescid.bench.statics import ExternalForce, holding_torques
from sescid.bench.truth import PhysicsTruth, PlacedMass, TorqueTruth, Truth, load_truth

__all__ = [
    "DEFAULT_EXTRA",
    "Approach",
    "BenchMount",
    "Engine",
    "Registers",
    "FRESH_POSES",
    "FRESH_WITHIN_DEG",
    "MujocoBenchConfig",
    "NO_POSE_MEASURED",
    "Experiment",
    "ExperimentConfig",
    "ExternalForce",
    "ExtraMass",
    "PhysicsTruth",
    "PlacedMass",
    "RawLogWriter",
    "Readings",
    "SensorErrors",
    "TorqueConfig",
    "TorqueTruth",
    "Truth",
    "TruthComparison",
    "approach_sides",
    "check_limits",
    "compare_truth",
    "draw_errors",
    "holding_torques",
    "load_truth",
    "real_bodies",
    "real_robot",
    "run_experiment",
    "run_mujoco_experiment",
    "standing_check",
    "stands",
]
