"""The foot-sensor layout: boards of four pads under each sole, read from the sensor file.

A sensor file (JSON, ``sescid-fsr/1``; ``sescid-fsr/2`` adds calibrated per-pad ``gains`` and
``offsets_N``, written by ``sescid calibrate``) names, per foot, its sole frame (a link of the
model), its column prefix and its four pad centres in the sole frame (metres; the robot
profile's ``sensors_file``, for the OP2 ``robots/op2/op2_fsr.json``, a flagged hypothesis a user
corrects). A foot's logged CoP columns take the prefix ``cop_columns``, by default the board's
prefix without a trailing ``_fsr`` (``r_fsr`` → ``r``).

A pad reads ``y = F / g + o`` (N): ``Foot.pad_forces`` inverts it with the calibrated gains and
offsets. ``check_sensors`` checks a layout against a robot (sole frames are links of its model,
offsets and gains physically plausible) with errors that name the sensor file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sescid.base import G0
from sescid.base.files import read_json
from sescid.errors import DataError
from sescid.robot import Robot
from sescid.robots import RobotProfile

FSR_FORMAT = "sescid-fsr/1"
#: version 2 adds calibrated per-pad ``gains`` and ``offsets_N`` per foot (``sescid calibrate``)
FSR_FORMAT_2 = "sescid-fsr/2"
#: board corner (u, v) ∈ [0, 1]² of FSR1..FSR4 (X = 254 u, Y = 254 v)
CORNERS = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
#: a calibrated gain outside this range is a broken pad or a wrong file, not a calibration
GAIN_RANGE = (0.2, 5.0)
#: a calibrated pad offset beyond this share of the robot's weight is not an offset
OFFSET_WEIGHT_SHARE = 0.25


@dataclass(frozen=True)
class Foot:
    """One sensor board: its sole frame (model link), column prefix and sensor centres."""

    name: str
    sole_frame: str
    columns: str  #: column prefix, e.g. "r_fsr" → r_fsr1..r_fsr4, r_fsr_x, r_fsr_y
    sensors: np.ndarray  #: (4, 2) sensor centres FSR1..FSR4 in the sole frame, m
    #: prefix of a logged CoP, e.g. "r" → r_cop_x, r_cop_y, r_fz; default ``columns`` without
    #: a trailing "_fsr"
    cop_prefix: str = ""
    #: (4,) calibrated gains g_k and offsets o_k (N) of the model reading = F / g + o;
    #: None: uncalibrated (g = 1, o = 0)
    gains: np.ndarray | None = None
    offsets: np.ndarray | None = None

    def __post_init__(self) -> None:
        if not self.cop_prefix:
            object.__setattr__(self, "cop_prefix", default_cop_prefix(self.columns))

    def pad_forces(self, readings: np.ndarray) -> np.ndarray:
        """Forces F = g (y − o) (m, 4) N from readings y (m, 4) N (identity if uncalibrated)."""
        out = np.asarray(readings, dtype=float)
        if self.offsets is not None:
            out = out - self.offsets
        if self.gains is not None:
            out = out * self.gains
        return out

    def centroid_point(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Point (n, 2) [m] of board coordinates u = X/254, v = Y/254 (bilinear in the sensors)."""
        return bilinear_weights(u, v) @ self.sensors

    def board_coordinates(self, c: np.ndarray) -> np.ndarray:
        """Inverse of ``centroid_point`` for a rectangular layout: (n, 2) points → (n, 2) (u, v)."""
        p = self.sensors
        ex, ey = p[1] - p[0], p[2] - p[0]
        d = np.asarray(c, dtype=float) - p[0]
        return np.stack([d @ ex / (ex @ ex), d @ ey / (ey @ ey)], axis=-1)

    def half_extents(self) -> tuple[np.ndarray, np.ndarray]:
        """Centre (2,) and half-extents (2,) [m] of the pads' bounding box in the sole frame."""
        lo, hi = self.sensors.min(axis=0), self.sensors.max(axis=0)
        return 0.5 * (lo + hi), 0.5 * (hi - lo)


def bilinear_weights(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(n, 4) weights of FSR1..FSR4 at board coordinates (u, v) ∈ [0, 1]² (they sum to 1)."""
    u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    return np.stack([(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v], axis=-1)


@dataclass(frozen=True)
class SensorConfig:
    """Foot-sensor configuration (units: N, m)."""

    feet: tuple[Foot, ...]
    force_unit: float = 0.001  #: N per force count
    saturation: int = 65535  #: force count at which a sensor is saturated
    min_foot_force: float = 1.972  #: N; below this a foot carries no load
    centroid_max: int = 254
    no_load: int = 255
    outlier_k: float = 4.0
    outlier_floor: float = 0.0005  #: m, smallest robust CoP scale of the outlier rule
    outlier_floor_force: float = 0.5  #: N, the same for the total force
    source: str = ""

    def foot(self, name: str) -> Foot:
        """The board named ``name``."""
        return next(f for f in self.feet if f.name == name)


def default_cop_prefix(columns: str) -> str:
    """The CoP column prefix of a board prefix: a trailing ``_fsr`` removed (``r_fsr`` → ``r``)."""
    return columns[: -len("_fsr")] if columns.endswith("_fsr") and len(columns) > 4 else columns


def default_sensors_path(profile: RobotProfile) -> Path:
    """The foot-sensor layout shipped in a robot's profile."""
    if profile.sensors_file is None:
        raise DataError(
            f"no foot-sensor layout ships for robot '{profile.name}': write one for its foot "
            "pads and give it with --sensors FILE (docs/sensors.md#a-layout-for-your-robot), or "
            "measure joint torques instead (--torques all)"
        )
    return profile.sensors_file


def _vec(raw, n: int, where: str) -> np.ndarray:
    try:
        arr = np.asarray(raw, dtype=float)
    except (TypeError, ValueError):
        raise DataError(f"{where}: expected {n} numbers, got {raw!r}") from None
    if arr.shape != (n,) or not np.all(np.isfinite(arr)):
        raise DataError(f"{where}: expected {n} finite numbers, got {raw!r}")
    return arr


def _board_sensors(f: dict, where: str) -> np.ndarray:
    """(4, 2) pad centres of one board entry: ``sensors_m`` or the board's centre/axes/span."""
    if f.get("sensors_m") is not None:
        sensors = np.array([_vec(p, 2, f"{where}.sensors_m") for p in f["sensors_m"]])
        if sensors.shape != (4, 2):
            raise DataError(f"{where}.sensors_m: expected 4 points [x, y] (FSR1..FSR4)")
    else:
        centre = _vec(f["sole_centre_m"], 2, f"{where}.sole_centre_m")
        ax = _vec(f["board_x_axis"], 2, f"{where}.board_x_axis")
        ay = _vec(f["board_y_axis"], 2, f"{where}.board_y_axis")
        span = _vec(f["board_span_m"], 2, f"{where}.board_span_m")
        if abs(np.linalg.norm(ax) - 1) > 1e-9 or abs(np.linalg.norm(ay) - 1) > 1e-9:
            raise DataError(f"{where}: board axes must be unit vectors")
        if abs(ax @ ay) > 1e-9:
            raise DataError(f"{where}: board axes must be perpendicular")
        if not np.all((span > 0) & (span < 1.0)):
            raise DataError(f"{where}.board_span_m: spans must be in (0, 1) m")
        sensors = centre + (CORNERS[:, :1] - 0.5) * span[0] * ax
        sensors = sensors + (CORNERS[:, 1:] - 0.5) * span[1] * ay
    ex, ey = sensors[1] - sensors[0], sensors[2] - sensors[0]
    if (
        abs(ex @ ey) > 1e-9 * (ex @ ex + ey @ ey)
        or np.linalg.norm(sensors[3] - sensors[0] - ex - ey) > 1e-9
    ):
        raise DataError(f"{where}: sensors FSR1..FSR4 must form a rectangle (1-2 / 3-4 rows)")
    if min(np.linalg.norm(ex), np.linalg.norm(ey)) < 1e-3:
        raise DataError(
            f"{where}: sensors FSR1..FSR4 must be ≥ 1 mm apart (a CoP needs an area; "
            "positions are in metres)"
        )
    return sensors


def _foot(name: str, f, where: str, calibrated: bool) -> Foot:
    """One ``feet`` entry of a sensor file."""
    try:
        sensors = _board_sensors(f, where)
        cop = f.get("cop_columns")
        if cop is not None and (not isinstance(cop, str) or not cop.strip()):
            raise DataError(f"{where}.cop_columns: expected a column prefix, got {cop!r}")
        gains = offsets = None
        if calibrated:
            gains = _vec(f["gains"], 4, f"{where}.gains")
            offsets = _vec(f["offsets_N"], 4, f"{where}.offsets_N")
            lo, hi = GAIN_RANGE
            if np.any((gains < lo) | (gains > hi)):
                raise DataError(
                    f"{where}.gains: {gains.tolist()}: a pad gain must lie in [{lo:g}, {hi:g}] "
                    "(a pad further off is broken, not calibrated)"
                )
        for key in ("sole_frame", "columns"):
            if not isinstance(f[key], str) or not f[key].strip():
                raise DataError(f"{where}.{key}: expected a name, got {f[key]!r}")
        return Foot(
            str(name), f["sole_frame"], f["columns"], sensors, (cop or "").strip(), gains, offsets
        )
    except KeyError as exc:
        raise DataError(f"{where}: missing field {exc}") from None
    except (TypeError, AttributeError):
        raise DataError(f"{where}: malformed entry") from None


def _number(data: dict, key: str, default: float, path: Path, whole: bool = False) -> float:
    """A finite number field of the sensor file (a whole number when ``whole``)."""
    raw = data.get(key, default)
    try:
        value = float(raw)
    except (TypeError, ValueError):
        raise DataError(f"{path}: {key}: expected a number, got {raw!r}") from None
    if not math.isfinite(value) or isinstance(raw, bool):
        raise DataError(f"{path}: {key}: expected a finite number, got {raw!r}")
    if whole and value != round(value):
        raise DataError(f"{path}: {key}: expected a whole number, got {raw!r}")
    return value


def load_sensors(
    path: str | Path | None = None, profile: RobotProfile | None = None
) -> SensorConfig:
    """Read a foot-sensor configuration (JSON ``sescid-fsr/1`` or ``/2``); default: the
    profile's. Every error names the file and the field."""
    if path is None:
        if profile is None:
            raise DataError("give a foot-sensor file or a robot profile that ships one")
        path = default_sensors_path(profile)
    path = Path(path)
    data = read_json(path, (FSR_FORMAT, FSR_FORMAT_2), "a sensor configuration")
    calibrated = data.get("format") == FSR_FORMAT_2
    raw_feet = data.get("feet")
    if not isinstance(raw_feet, dict) or not raw_feet:
        raise DataError(f"{path}: 'feet' must map foot names to their boards")
    feet = tuple(
        _foot(str(n), f, f"{path}: feet.{n}", calibrated)
        if isinstance(f, dict)
        else _malformed(f"{path}: feet.{n}")
        for n, f in raw_feet.items()
    )
    cfg = SensorConfig(
        feet=feet,
        force_unit=_number(data, "force_unit_N", 0.001, path),
        saturation=int(_number(data, "saturation_count", 65535, path, whole=True)),
        min_foot_force=_number(data, "min_foot_force_N", 1.972, path),
        centroid_max=int(_number(data, "centroid_max", 254, path, whole=True)),
        no_load=int(_number(data, "no_load_value", 255, path, whole=True)),
        outlier_k=_number(data, "outlier_k", 4.0, path),
        outlier_floor=_number(data, "outlier_floor_m", 0.0005, path),
        outlier_floor_force=_number(data, "outlier_floor_N", 0.5, path),
        source=str(path),
    )
    if not (cfg.force_unit > 0 and cfg.min_foot_force >= 0 and cfg.outlier_k > 0):
        raise DataError(f"{path}: force_unit_N, min_foot_force_N, outlier_k must be positive")
    if not (cfg.saturation >= 1 and cfg.centroid_max >= 1):
        raise DataError(f"{path}: saturation_count and centroid_max must be ≥ 1")
    return cfg


def _malformed(where: str) -> Foot:
    raise DataError(f"{where}: malformed entry (expected an object)")


def check_sensors(robot: Robot, config: SensorConfig) -> None:
    """DataError naming the sensor file unless its layout fits ``robot``: every sole frame is a
    link of the model, and calibrated offsets stay below a quarter of the robot's weight."""
    where = config.source or "the sensor configuration"
    links = robot.model.link_frames
    weight = robot.total_mass * G0
    for f in config.feet:
        if f.sole_frame not in links:
            raise DataError(
                f"{where}: feet.{f.name}.sole_frame: '{f.sole_frame}' is not a link of "
                f"{robot.model_path.name}"
            )
        if f.offsets is not None and np.any(np.abs(f.offsets) > OFFSET_WEIGHT_SHARE * weight):
            worst = float(np.max(np.abs(f.offsets)))
            raise DataError(
                f"{where}: feet.{f.name}.offsets_N: {worst:g} N is more than "
                f"{OFFSET_WEIGHT_SHARE:.0%} of the robot's weight ({weight:.3g} N): "
                "not a pad offset (offsets are in N)"
            )
