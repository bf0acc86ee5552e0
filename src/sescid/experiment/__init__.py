"""Experiments: the paper's §3 simulation study, bench pose planning, the virtual bench (a
"real" robot with unmodelled mass, backlash and sensor errors) and foot sensors → CoP.
"""

from __future__ import annotations

from .planning import PosePlan, candidates, plan_poses
from .sensors import (
    REASONS,
    Measured,
    RawLog,
    SensorConfig,
    fsr,
    load_sensors,
    measure,
    pose_list_ids,
    read_raw,
)
from .study import PaperStudy, paper_study
from .virtual import (
    DEFAULT_EXTRA,
    Experiment,
    ExperimentConfig,
    ExtraMass,
    check_limits,
    load_truth,
    real_robot,
    run_experiment,
)

__all__ = [
    "DEFAULT_EXTRA",
    "REASONS",
    "Experiment",
    "ExperimentConfig",
    "ExtraMass",
    "Measured",
    "PaperStudy",
    "PosePlan",
    "RawLog",
    "SensorConfig",
    "candidates",
    "check_limits",
    "fsr",
    "load_sensors",
    "load_truth",
    "measure",
    "paper_study",
    "plan_poses",
    "pose_list_ids",
    "read_raw",
    "real_robot",
    "run_experiment",
]
