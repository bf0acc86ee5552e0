"""Experiments: the paper's §3 simulation study, bench pose planning, the virtual bench (a
"real" robot with unmodelled mass, backlash and sensor errors), foot sensors → CoP (FSR
boards in ``sensors``; ankle force/torque sensors and force plates in ``wrench``) and the guided
session (``session``: next-best pose until converged, through the ``adapters`` protocol).
"""

from __future__ import annotations

from .adapters import MujocoAdapter, ReplayAdapter, RobotAdapter, load_adapter_class
from .calibration import calibrated_sensor_document, pad_session, table_from_columns
from .imu import IMU_COLUMNS, gravity_from_imu, gravity_in_link, read_imu, table_gravity
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
from .session import SessionObserver, SessionOptions, SessionResult, SessionStep, run_session
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
    "IMU_COLUMNS",
    "REASONS",
    "Experiment",
    "ExperimentConfig",
    "ExtraMass",
    "Measured",
    "MujocoAdapter",
    "PaperStudy",
    "Plate",
    "PosePlan",
    "RawLog",
    "ReplayAdapter",
    "RobotAdapter",
    "SensorConfig",
    "SessionObserver",
    "SessionOptions",
    "SessionResult",
    "SessionStep",
    "candidates",
    "check_limits",
    "cop_from_force_plate",
    "cop_from_plate",
    "cop_from_wrench",
    "calibrated_sensor_document",
    "fsr",
    "gravity_from_imu",
    "gravity_in_link",
    "load_adapter_class",
    "load_plate",
    "load_sensors",
    "load_truth",
    "measure",
    "pad_session",
    "paper_study",
    "plan_poses",
    "plate_to_sole",
    "pose_list_ids",
    "read_imu",
    "read_raw",
    "real_robot",
    "rpy_matrix",
    "run_experiment",
    "run_session",
    "table_from_columns",
    "table_gravity",
]
