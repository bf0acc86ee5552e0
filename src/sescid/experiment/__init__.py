"""Experiments: the paper's §3 simulation study, bench pose planning, the virtual bench (a
"real" robot with unmodelled mass, backlash and sensor errors) and foot sensors → CoP (FSR
boards in ``sensors``; ankle force/torque sensors and force plates in ``wrench``).
"""

from __future__ import annotations

from .calibration import calibrated_sensor_document, pad_session, table_from_columns
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
from .wrench import (
    Plate,
    cop_from_force_plate,
    cop_from_plate,
    cop_from_wrench,
    load_plate,
    plate_to_sole,
    rpy_matrix,
)

__all__ = [
    "DEFAULT_EXTRA",
    "REASONS",
    "Experiment",
    "ExperimentConfig",
    "ExtraMass",
    "Measured",
    "PaperStudy",
    "Plate",
    "PosePlan",
    "RawLog",
    "SensorConfig",
    "candidates",
    "check_limits",
    "cop_from_force_plate",
    "cop_from_plate",
    "cop_from_wrench",
    "calibrated_sensor_document",
    "fsr",
    "load_plate",
    "load_sensors",
    "load_truth",
    "measure",
    "pad_session",
    "paper_study",
    "plan_poses",
    "plate_to_sole",
    "pose_list_ids",
    "read_raw",
    "real_robot",
    "rpy_matrix",
    "run_experiment",
    "table_from_columns",
]
