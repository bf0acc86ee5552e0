"""Sensors: raw samples of what a robot measures → one measurement per pose.

Foot pads (FSR boards: ``pads``), ankle force/torque sensors and force plates (``wrench``), the
IMU's gravity direction (``imu``), and the calibration of pad gains and offsets together with the
mass model (``calibration``, its raw-log sessions and sensor file in ``pad_logs``).
"""

from __future__ import annotations

from sescid.sensors.calibration import (
    KnownSensors,
    PadFoot,
    PadSession,
    SensorCalibration,
    SensorDirection,
    SensorParameter,
    SessionContribution,
    calibrate_sensors,
)
from sescid.sensors.imu import (
    IMU_COLUMNS,
    gravity_from_imu,
    gravity_in_link,
    read_imu,
    table_gravity,
)
from sescid.sensors.pad_logs import calibrated_sensor_document, pad_session, table_from_columns
from sescid.sensors.pads import (
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
from sescid.sensors.wrench import (
    Plate,
    cop_from_force_plate,
    cop_from_plate,
    cop_from_wrench,
    load_plate,
    plate_to_sole,
    rpy_matrix,
)

__all__ = [
    "IMU_COLUMNS",
    "REASONS",
    "KnownSensors",
    "Measured",
    "PadFoot",
    "PadSession",
    "Plate",
    "RawLog",
    "SensorCalibration",
    "SensorConfig",
    "SensorDirection",
    "SensorParameter",
    "SessionContribution",
    "calibrate_sensors",
    "calibrated_sensor_document",
    "cop_from_force_plate",
    "cop_from_plate",
    "cop_from_wrench",
    "fsr",
    "gravity_from_imu",
    "gravity_in_link",
    "load_plate",
    "load_sensors",
    "measure",
    "pad_session",
    "plate_to_sole",
    "pose_list_ids",
    "read_imu",
    "read_raw",
    "rpy_matrix",
    "table_from_columns",
    "table_gravity",
]
