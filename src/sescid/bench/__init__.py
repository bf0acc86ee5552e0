"""Benches: a "real" robot that differs from its model (unmodelled masses, backlash, sensor
errors) measured at planned poses, writing the raw log a real robot would.

``real_robot`` is the real robot and its sensors' errors (``ExperimentConfig``,
``TorqueConfig``); ``statics`` the joint torques that hold a pose; ``log`` the one raw-log
writer every bench and session adapter uses; ``kinematic`` is rigid statics (fast, exact
truth); ``mujoco`` stands the robot on a compliant floor with position servos in MuJoCo (the
``mujoco`` extra); ``truth`` is the typed truth record and its file; ``compare`` compares a fit
with that truth.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sescid.base.lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover - for type checkers; at run time: _EXPORTS
    from sescid.bench.compare import FRESH_POSES, FRESH_WITHIN_DEG, TruthComparison, compare_truth
    from sescid.bench.kinematic import Experiment, run_experiment
    from sescid.bench.log import RawLogWriter, Readings
    from sescid.bench.real_robot import (
        DEFAULT_EXTRA,
        NO_POSE_MEASURED,
        ExperimentConfig,
        ExtraMass,
        SensorErrors,
        TorqueConfig,
        approach_sides,
        check_limits,
        draw_errors,
        real_bodies,
        real_robot,
    )
    from sescid.bench.statics import ExternalForce, holding_torques
    from sescid.bench.truth import PhysicsTruth, PlacedMass, TorqueTruth, Truth, load_truth

__all__ = [
    "DEFAULT_EXTRA",
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

#: public name → the module that defines it, imported on first use (``base.lazy``)
_EXPORTS = {
    "real_robot": "sescid.bench.real_robot",
    "MujocoBenchConfig": "sescid.bench.mujoco",
    "run_mujoco_experiment": "sescid.bench.mujoco",
    "standing_check": "sescid.bench.standing",
    "stands": "sescid.bench.standing",
    "DEFAULT_EXTRA": "sescid.bench.real_robot",
    "Experiment": "sescid.bench.kinematic",
    "ExperimentConfig": "sescid.bench.real_robot",
    "ExternalForce": "sescid.bench.statics",
    "ExtraMass": "sescid.bench.real_robot",
    "FRESH_POSES": "sescid.bench.compare",
    "FRESH_WITHIN_DEG": "sescid.bench.compare",
    "NO_POSE_MEASURED": "sescid.bench.real_robot",
    "PhysicsTruth": "sescid.bench.truth",
    "PlacedMass": "sescid.bench.truth",
    "RawLogWriter": "sescid.bench.log",
    "Readings": "sescid.bench.log",
    "SensorErrors": "sescid.bench.real_robot",
    "TorqueConfig": "sescid.bench.real_robot",
    "TorqueTruth": "sescid.bench.truth",
    "Truth": "sescid.bench.truth",
    "TruthComparison": "sescid.bench.compare",
    "approach_sides": "sescid.bench.real_robot",
    "check_limits": "sescid.bench.real_robot",
    "compare_truth": "sescid.bench.compare",
    "draw_errors": "sescid.bench.real_robot",
    "holding_torques": "sescid.bench.statics",
    "load_truth": "sescid.bench.truth",
    "real_bodies": "sescid.bench.real_robot",
    "run_experiment": "sescid.bench.kinematic",
}
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
