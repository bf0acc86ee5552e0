"""Sensors: raw samples of what a robot measures → one measurement per pose.

Foot pads (the sensor layout and file: ``pads``; per-sample foot CoPs: ``feet``), ankle
force/torque sensors and force plates (``wrench``), joint torques (``torque``), the IMU's
gravity direction (``imu``); a raw log read into SI arrays (``raw``) and reduced per pose
(``reduce``: ``sescid measure``, alias ``fsr``) with per-pose statistics (``stats``); the
calibration of pad gains and offsets together with the mass model (``calibration``). A weighed
total mass is checked by ``sescid.estimation.check_total_mass``.
"""

from sescid.sensors.calibration import (
    CalibrationOptions,
    KnownSensors,
    PadFoot,
    PadSession,
    PadSessionOptions,
    SensorCalibration,
    SensorDirection,
    SensorParameter,
    SessionContribution,
    calibrate_sensors,
    calibrated_sensor_document,
    pad_session,
)
from sescid.sensors.feet import REASONS
from sescid.sensors.imu import (
    IMU_COLUMNS,
    gravity_from_imu,
    gravity_in_link,
    read_imu,
    table_gravity,
)
from sescid.sensors.measured import concat_measured
from sescid.sensors.pads import (
    Foot,
    SensorConfig,
    check_sensors,
    default_sensors_path,
    load_sensors,
)
from sescid.sensors.raw import RawLog, read_raw, table_from_columns
from sescid.sensors.reduce import (
    SESSION_POSE,
    LogPart,
    Measured,
    fsr,
    measure,
    pose_list_ids,
    read_log,
)
from sescid.sensors.stream import fsr_chunks, fsr_stances
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
    "CalibrationOptions",
    "Foot",
    "KnownSensors",
    "Measured",
    "PadFoot",
    "PadSession",
    "PadSessionOptions",
    "Plate",
    "RawLog",
    "SensorCalibration",
    "SensorConfig",
    "SensorDirection",
    "SensorParameter",
    "SessionContribution",
    "calibrate_sensors",
    "calibrated_sensor_document",
    "check_sensors",
    "cop_from_force_plate",
    "cop_from_plate",
    "cop_from_wrench",
    "default_sensors_path",
    "concat_measured",
    "fsr",
    "fsr_chunks",
    "fsr_stances",
    "gravity_from_imu",
    "gravity_in_link",
    "load_plate",
    "load_sensors",
    "measure",
    "LogPart",
    "SESSION_POSE",
    "pad_session",
    "plate_to_sole",
    "pose_list_ids",
    "read_imu",
    "read_log",
    "read_raw",
    "rpy_matrix",
    "table_from_columns",
    "table_gravity",
]
