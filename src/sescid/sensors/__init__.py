"""Sensors: raw samples of what a robot measures → one measurement per pose.

Foot pads (the sensor layout and file: ``pads``; per-sample foot CoPs: ``feet``), ankle
force/torque sensors and force plates (``wrench``), joint torques (``torque``), the IMU's
gravity direction (``imu``); a raw log read into SI arrays (``raw``) and reduced per pose
(``reduce``: ``sescid measure``, alias ``fsr``) with per-pose statistics (``stats``); the
calibration of pad gains and offsets together with the mass model (``calibration``); physical
plausibility of user-given numbers (``checks``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sescid.base.lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover - for type checkers; at run time: _EXPORTS
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
    from sescid.sensors.checks import check_total_mass
    from sescid.sensors.feet import REASONS
    from sescid.sensors.imu import (
        IMU_COLUMNS,
        gravity_from_imu,
        gravity_in_link,
        read_imu,
        table_gravity,
    )
    from sescid.sensors.pads import (
        Foot,
        SensorConfig,
        check_sensors,
        default_sensors_path,
        load_sensors,
    )
    from sescid.sensors.raw import RawLog, read_raw, table_from_columns
    from sescid.sensors.reduce import Measured, fsr, measure, pose_list_ids, read_log
    from sescid.sensors.stream import fsr_chunks
    from sescid.sensors.torque import APPROACH_COLUMN, TAU_PREFIX, TAU_SE_PREFIX
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
    "APPROACH_COLUMN",
    "IMU_COLUMNS",
    "REASONS",
    "TAU_PREFIX",
    "TAU_SE_PREFIX",
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
    "check_total_mass",
    "cop_from_force_plate",
    "cop_from_plate",
    "cop_from_wrench",
    "default_sensors_path",
    "fsr",
    "fsr_chunks",
    "gravity_from_imu",
    "gravity_in_link",
    "load_plate",
    "load_sensors",
    "measure",
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

#: public name → the module that defines it, imported on first use (``base.lazy``)
_EXPORTS = {
    "APPROACH_COLUMN": "sescid.sensors.torque",
    "CalibrationOptions": "sescid.sensors.calibration",
    "Foot": "sescid.sensors.pads",
    "IMU_COLUMNS": "sescid.sensors.imu",
    "KnownSensors": "sescid.sensors.calibration",
    "Measured": "sescid.sensors.reduce",
    "PadFoot": "sescid.sensors.calibration",
    "PadSession": "sescid.sensors.calibration",
    "PadSessionOptions": "sescid.sensors.calibration",
    "Plate": "sescid.sensors.wrench",
    "REASONS": "sescid.sensors.feet",
    "RawLog": "sescid.sensors.raw",
    "SensorCalibration": "sescid.sensors.calibration",
    "SensorConfig": "sescid.sensors.pads",
    "SensorDirection": "sescid.sensors.calibration",
    "SensorParameter": "sescid.sensors.calibration",
    "SessionContribution": "sescid.sensors.calibration",
    "TAU_PREFIX": "sescid.sensors.torque",
    "TAU_SE_PREFIX": "sescid.sensors.torque",
    "calibrate_sensors": "sescid.sensors.calibration",
    "calibrated_sensor_document": "sescid.sensors.calibration",
    "check_sensors": "sescid.sensors.pads",
    "check_total_mass": "sescid.sensors.checks",
    "cop_from_force_plate": "sescid.sensors.wrench",
    "cop_from_plate": "sescid.sensors.wrench",
    "cop_from_wrench": "sescid.sensors.wrench",
    "default_sensors_path": "sescid.sensors.pads",
    "fsr": "sescid.sensors.reduce",
    "fsr_chunks": "sescid.sensors.stream",
    "gravity_from_imu": "sescid.sensors.imu",
    "gravity_in_link": "sescid.sensors.imu",
    "load_plate": "sescid.sensors.wrench",
    "load_sensors": "sescid.sensors.pads",
    "measure": "sescid.sensors.reduce",
    "pad_session": "sescid.sensors.calibration",
    "plate_to_sole": "sescid.sensors.wrench",
    "pose_list_ids": "sescid.sensors.reduce",
    "read_imu": "sescid.sensors.imu",
    "read_log": "sescid.sensors.reduce",
    "read_raw": "sescid.sensors.raw",
    "rpy_matrix": "sescid.sensors.wrench",
    "table_from_columns": "sescid.sensors.raw",
    "table_gravity": "sescid.sensors.imu",
}
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
