"""Benches: a "real" robot that differs from its model (unmodelled masses, backlash, sensor
errors) measured at planned poses, writing the raw log a real robot would.

``kinematic`` is rigid statics (fast, exact truth); ``mujoco`` stands the robot on a compliant
floor with position servos in MuJoCo (the ``mujoco`` extra); ``truth`` compares a fit with the
truth a bench wrote.
"""

from __future__ import annotations

from sescid.bench.kinematic import (
    DEFAULT_EXTRA,
    Experiment,
    ExperimentConfig,
    ExtraMass,
    check_limits,
    load_truth,
    real_robot,
    run_experiment,
)
from sescid.bench.truth import TruthComparison, compare_truth

__all__ = [
    "DEFAULT_EXTRA",
    "Experiment",
    "ExperimentConfig",
    "ExtraMass",
    "TruthComparison",
    "check_limits",
    "compare_truth",
    "load_truth",
    "real_robot",
    "run_experiment",
]
