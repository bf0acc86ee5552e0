"""Foot force sensors (OP2 FSR boards) → per-pose CoP in the support frame.

A raw log has many samples per pose: a ``pose`` id, joint read-backs (radians in columns named
as the joints, or ``<joint>_deg`` degrees, or ``<joint>_ticks`` in the robot profile's servo
ticks; one unit per joint), and per foot one source:

- the four forces ``<prefix>1..4`` in board counts (1 mN), or
- the centroid registers ``<prefix>_x``, ``<prefix>_y`` (0–254, 255 = no load), or
- a ready CoP ``<cop>_cop_x``, ``<cop>_cop_y`` in metres in the foot's sole frame, with the foot's
  normal force ``<cop>_fz`` in N when known (what ``sescid bag`` writes for an ankle F/T sensor,
  a force plate or a CoP topic; ``sescid.sensors.wrench``).

Prefixes and sensor positions come from a small JSON configuration (the robot profile's
``sensors_file``, for the OP2 ``robots/op2/op2_fsr.json``; the positions are a flagged
hypothesis a user corrects); the CoP prefix is the field ``cop_columns``, by default the board's
prefix without a trailing ``_fsr`` (``r_fsr`` → ``r``).

Per sample, a foot's CoP in its sole frame is the force-weighted centroid of its sensors,
``c = Σ F_k p_k / Σ F_k``, or, from the registers, the bilinear map of ``(X/254, Y/254)`` onto the
sensor rectangle (the same point when the board computes the linear centroid), or the logged CoP
itself. A CoP foot with ``_fz`` is loaded where ``fz ≥ min_foot_force``; without it, wherever its
CoP is given (a NaN CoP is an unloaded foot), and it then carries no force, like the registers.
Each loaded foot's CoP is carried into the support frame with the model's pose of its sole at the
pose's mean joint read-backs; two loaded feet combine weighted by their total forces. Samples are
rejected (with the reason counted) when a value is missing, a sensor is saturated, no foot
carries load, two feet are loaded but some source has no force to weight them, or the CoP/force
is an outlier by the median/MAD rule ``|v − median| > k · max(1.4826 MAD, floor)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sescid.base.columns import (
    GRAVITY_COLUMNS,
    Table,
    column_with_missing,
    pose_ids,
    read_gravity,
    read_joint_columns,
)
from sescid.base.files import read_json
from sescid.errors import DataError
from sescid.robots import RobotProfile, ServoEncoding

FSR_FORMAT = "sescid-fsr/1"
#: version 2 adds calibrated per-pad ``gains`` and ``offsets_N`` per foot (``sescid calibrate``)
FSR_FORMAT_2 = "sescid-fsr/2"
#: board corner (u, v) ∈ [0, 1]² of FSR1..FSR4 (X = 254 u, Y = 254 v)
CORNERS = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
#: rejection reasons, in the order they are tested (a sample counts under the first that applies)
REASONS = ("missing", "saturated", "no_load", "two_feet_no_force", "off_floor", "outlier")
#: a loaded foot whose sole the model puts this far off the support plane breaks CoP = CoM_xy
OFF_FLOOR_M = 0.010
OFF_FLOOR_TILT = math.radians(5.0)
#: a logged CoP farther than this from its sole origin is not in metres
COP_MAX_M = 2.0


# --- configuration ----------------------------------------------------------------------
@dataclass(frozen=True)
class Foot:
    """One sensor board: its sole frame (URDF link), column prefix and sensor centres."""

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
        w = np.stack([(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v], axis=-1)
        return w @ self.sensors

    def board_coordinates(self, c: np.ndarray) -> np.ndarray:
        """Inverse of ``centroid_point`` for a rectangular layout: (n, 2) points → (n, 2) (u, v)."""
        p = self.sensors
        ex, ey = p[1] - p[0], p[2] - p[0]
        d = np.asarray(c, dtype=float) - p[0]
        return np.stack([d @ ex / (ex @ ex), d @ ey / (ey @ ey)], axis=-1)


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
            f"no foot-sensor layout ships for robot '{profile.name}': give a sensor file "
            "(copy src/sescid/robots/op2/op2_fsr.json and adapt it)"
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


def load_sensors(
    path: str | Path | None = None, profile: RobotProfile | None = None
) -> SensorConfig:
    """Read a foot-sensor configuration (JSON ``sescid-fsr/1``); default: the profile's."""
    if path is None:
        if profile is None:
            raise DataError("give a foot-sensor file or a robot profile that ships one")
        path = default_sensors_path(profile)
    path = Path(path)
    data = read_json(path, (FSR_FORMAT, FSR_FORMAT_2), "a sensor configuration")
    calibrated = data.get("format") == FSR_FORMAT_2
    feet = []
    raw_feet = data.get("feet")
    if not isinstance(raw_feet, dict) or not raw_feet:
        raise DataError(f"{path}: 'feet' must map foot names to their boards")
    for name, f in raw_feet.items():
        where = f"{path}: feet.{name}"
        try:
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
            cop = f.get("cop_columns")
            if cop is not None and (not isinstance(cop, str) or not cop.strip()):
                raise DataError(f"{where}.cop_columns: expected a column prefix, got {cop!r}")
            gains = offsets = None
            if calibrated:
                gains = _vec(f["gains"], 4, f"{where}.gains")
                offsets = _vec(f["offsets_N"], 4, f"{where}.offsets_N")
                if np.any(gains <= 0):
                    raise DataError(f"{where}.gains: gains must be positive, got {gains.tolist()}")
            foot = Foot(
                str(name),
                str(f["sole_frame"]),
                str(f["columns"]),
                sensors,
                (cop or "").strip(),
                gains,
                offsets,
            )
        except KeyError as exc:
            raise DataError(f"{where}: missing field {exc}") from None
        except (TypeError, AttributeError):
            raise DataError(f"{where}: malformed entry") from None
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
        feet.append(foot)
    try:
        cfg = SensorConfig(
            feet=tuple(feet),
            force_unit=float(data.get("force_unit_N", 0.001)),
            saturation=int(data.get("saturation_count", 65535)),
            min_foot_force=float(data.get("min_foot_force_N", 1.972)),
            centroid_max=int(data.get("centroid_max", 254)),
            no_load=int(data.get("no_load_value", 255)),
            outlier_k=float(data.get("outlier_k", 4.0)),
            outlier_floor=float(data.get("outlier_floor_m", 0.0005)),
            outlier_floor_force=float(data.get("outlier_floor_N", 0.5)),
            source=str(path),
        )
    except (TypeError, ValueError) as exc:
        raise DataError(f"{path}: malformed number ({exc})") from None
    if not (cfg.force_unit > 0 and cfg.min_foot_force >= 0 and cfg.outlier_k > 0):
        raise DataError(f"{path}: force_unit_N, min_foot_force_N, outlier_k must be positive")
    return cfg


# --- raw log ----------------------------------------------------------------------------
@dataclass
class RawLog:
    """Samples (m rows) of a raw log, in SI units; NaN marks a missing value."""

    path: Path
    pose: np.ndarray  #: (m,) pose ids as text
    q: np.ndarray  #: (m, nq) joint read-backs, rad
    forces: dict[str, np.ndarray]  #: foot name → (m, 4) force counts
    centroid: dict[str, np.ndarray]  #: foot name → (m, 2) registers X, Y
    units: dict[str, str]  #: joint → "rad" | "deg" | "ticks"
    cop: dict[str, np.ndarray] = field(default_factory=dict)  #: foot → (m, 2) CoP, sole frame, m
    #: foot → (m,) normal force N (``<cop>_fz``), or None when the log has none
    cop_force: dict[str, np.ndarray | None] = field(default_factory=dict)
    gravity: np.ndarray | None = None  #: (m, 3) gravity direction, support frame (grav_x/y/z)


def read_raw(
    table: Table,
    joint_names: list[str],
    config: SensorConfig,
    servo: ServoEncoding | None = None,
) -> RawLog:
    """Parse a raw FSR log (see the module docstring) into SI arrays; errors name the column."""
    pose = pose_ids(table)
    q, units = read_joint_columns(table, joint_names, servo)
    names = set(table.names())
    forces, centroid = {}, {}
    cop: dict[str, np.ndarray] = {}
    cop_force: dict[str, np.ndarray | None] = {}
    for foot in config.feet:
        fcols = [f"{foot.columns}{k}" for k in range(1, 5)]
        ccols = [f"{foot.columns}_x", f"{foot.columns}_y"]
        has_f = [c in names for c in fcols]
        has_c = [c in names for c in ccols]
        if _read_cop(table, foot, names, cop, cop_force):
            if any(has_f) or any(has_c):
                board = fcols[0] if any(has_f) else ccols[0]
                raise DataError(
                    f"{table.path}: the {foot.name} foot logs both a CoP "
                    f"('{foot.cop_prefix}_cop_x') and its sensor board ('{board}'): "
                    "keep one source per foot"
                )
            continue
        if any(has_f) and not all(has_f):
            missing = fcols[has_f.index(False)]
            raise DataError(f"{table.path}: missing column '{missing}' ({foot.name} foot forces)")
        if any(has_c) and not all(has_c):
            missing = ccols[has_c.index(False)]
            raise DataError(f"{table.path}: missing column '{missing}' ({foot.name} centroid)")
        if all(has_f):
            f = np.column_stack([column_with_missing(table, c) for c in fcols])
            bad = np.argwhere(f < 0)
            if bad.size:
                i, k = bad[0]
                raise DataError(
                    f"{table.path}: row {i + 2}, column '{fcols[k]}': negative force count "
                    f"{f[i, k]:g} (the board reports 0–{config.saturation} mN)"
                )
            forces[foot.name] = f
        elif all(has_c):
            c = np.column_stack([column_with_missing(table, col) for col in ccols])
            ok = np.isnan(c) | (
                (c >= 0) & (c <= max(config.centroid_max, config.no_load)) & (c == np.round(c))
            )
            bad = np.argwhere(~ok)
            if bad.size:
                i, k = bad[0]
                raise DataError(
                    f"{table.path}: row {i + 2}, column '{ccols[k]}': {c[i, k]:g} is not a "
                    f"centroid register (integer 0–{config.centroid_max}, "
                    f"{config.no_load} = no load)"
                )
            centroid[foot.name] = c
    if not forces and not centroid and not cop:
        want = ", ".join(
            f"{f.columns}1..4 or {f.columns}_x/_y or {f.cop_prefix}_cop_x/_y" for f in config.feet
        )
        raise DataError(f"{table.path}: no foot-sensor columns ({want})")
    if forces and centroid:
        raise DataError(
            f"{table.path}: one foot logs forces and the other only centroid registers: "
            "log the same kind for both feet"
        )
    gravity = read_gravity(table) if any(c in names for c in GRAVITY_COLUMNS) else None
    return RawLog(table.path, pose, q, forces, centroid, units, cop, cop_force, gravity)


def _read_cop(table: Table, foot: Foot, names: set[str], cop: dict, cop_force: dict) -> bool:
    """A foot's logged CoP (and normal force) into ``cop``/``cop_force``; False if it has none."""
    pcols = [f"{foot.cop_prefix}_cop_x", f"{foot.cop_prefix}_cop_y"]
    zcol = f"{foot.cop_prefix}_fz"
    has_p = [c in names for c in pcols]
    if not any(has_p):
        if zcol in names:
            raise DataError(
                f"{table.path}: column '{zcol}' without '{pcols[0]}', '{pcols[1]}' "
                f"({foot.name} foot CoP)"
            )
        return False
    if not all(has_p):
        missing = pcols[has_p.index(False)]
        raise DataError(f"{table.path}: missing column '{missing}' ({foot.name} foot CoP)")
    c = np.column_stack([column_with_missing(table, col) for col in pcols])
    bad = np.argwhere(np.abs(c) > COP_MAX_M)
    if bad.size:
        i, k = bad[0]
        raise DataError(
            f"{table.path}: row {i + 2}, column '{pcols[k]}': {c[i, k]:g} is {COP_MAX_M:g} m or "
            "more from the sole (CoP columns are in metres)"
        )
    cop[foot.name] = c
    cop_force[foot.name] = column_with_missing(table, zcol) if zcol in names else None
    return True


# --- per-pose CoP -------------------------------------------------------------------------
@dataclass
class Measured:
    """Per-pose results of ``measure`` (k kept poses); lengths in m, forces in N."""

    pose: np.ndarray  #: (k,) pose ids (text)
    q: np.ndarray  #: (k, nq) mean joint read-backs, rad
    cop: np.ndarray  #: (k, 2) mean CoP in the support frame, m
    cop_se: np.ndarray  #: (k, 2) standard error of that mean, m
    force: np.ndarray  #: (k,) mean total vertical force, N
    n_used: np.ndarray  #: (k,) samples averaged
    rejected: np.ndarray  #: (k, len(REASONS)) samples rejected, per reason
    dropped: list[tuple[str, str]] = field(default_factory=list)  #: (pose, why) without a CoP
    #: "forces" (every source has a force), "centroid" (registers) or "cop" (a logged CoP
    #: without its force)
    mode: str = "forces"
    gravity: np.ndarray | None = None  #: (k, 3) mean gravity direction (unit), support frame

    @property
    def n_rejected(self) -> np.ndarray:
        """(k,) samples rejected per pose, all reasons."""
        return self.rejected.sum(axis=1)

    def reasons(self) -> list[str]:
        """Per pose, e.g. 'no_load=3 outlier=1' (or 'none')."""
        out = []
        for row in self.rejected:
            parts = [f"{r}={int(c)}" for r, c in zip(REASONS, row, strict=True) if c]
            out.append(" ".join(parts) if parts else "none")
        return out

    def columns(self, joint_names: list[str]) -> dict[str, np.ndarray]:
        """Output table: pose, joints (rad), cop_x/y, cop_se_x/y (m), counts, reasons, force_n."""
        cols: dict[str, np.ndarray] = {"pose": self.pose}
        cols |= {j: self.q[:, i] for i, j in enumerate(joint_names)}
        cols |= {
            "cop_x": self.cop[:, 0],
            "cop_y": self.cop[:, 1],
            "cop_se_x": self.cop_se[:, 0],
            "cop_se_y": self.cop_se[:, 1],
            "n_used": self.n_used.astype(int),
            "n_rejected": self.n_rejected.astype(int),
            "reject_reasons": np.array(self.reasons()),
        }
        if self.mode == "forces":  # the registers carry no force
            cols["force_n"] = self.force
        if self.gravity is not None:
            cols |= {f"grav_{a}": self.gravity[:, i] for i, a in enumerate("xyz")}
        return cols


def _group_median(v: np.ndarray, g: np.ndarray, k: int) -> np.ndarray:
    """Median of v within each group g ∈ [0, k) (NaN for empty groups), vectorised."""
    order = np.lexsort((v, g))
    vs = v[order]
    counts = np.bincount(g, minlength=k)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    has = counts > 0
    med = np.full(k, np.nan)
    lo = starts[has] + (counts[has] - 1) // 2
    hi = starts[has] + counts[has] // 2
    med[has] = 0.5 * (vs[lo] + vs[hi])
    return med


def _outliers(values: np.ndarray, g: np.ndarray, k: int, kk: float, floor: float) -> np.ndarray:
    """Boolean (m,): |v − median| > kk · max(1.4826 MAD, floor) within each group."""
    med = _group_median(values, g, k)
    dev = np.abs(values - med[g])
    scale = np.maximum(1.4826 * _group_median(dev, g, k), floor)
    return dev > kk * scale[g]


def measure(
    robot,
    log: RawLog,
    config: SensorConfig,
    min_samples: int = 5,
) -> Measured:
    """Per-pose mean CoP (support frame, m), its standard error and the rejections.

    Poses left with fewer than ``min_samples`` usable samples get no CoP: they are listed in
    ``dropped`` with the reason. The foot poses come from ``robot.link_poses`` at each pose's
    mean joint read-backs.
    """
    if min_samples < 2:
        raise DataError(f"min_samples must be ≥ 2 (a standard error needs 2), got {min_samples}")
    ids, first, g = np.unique(log.pose, return_index=True, return_inverse=True)
    order = np.argsort(first)  # keep the log's order of poses
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    ids, g = ids[order], rank[g]
    k, m = len(ids), len(g)
    status = np.full(m, -1)  # -1 usable, else index into REASONS

    def reject(mask, reason):
        status[(status < 0) & mask] = REASONS.index(reason)

    # mean joint read-backs over the samples where every joint is present
    q_ok = np.all(np.isfinite(log.q), axis=1)
    cnt_q = np.bincount(g[q_ok], minlength=k)
    q_sum = np.stack(
        [np.bincount(g[q_ok], log.q[q_ok, j], minlength=k) for j in range(log.q.shape[1])], axis=1
    )
    with np.errstate(invalid="ignore", divide="ignore"):
        q_mean = q_sum / cnt_q[:, None]
    reject(~q_ok, "missing")

    feet = [
        f
        for f in config.feet
        if f.name in log.forces or f.name in log.centroid or f.name in log.cop
    ]
    if log.centroid:
        mode = "centroid"
    elif any(log.cop_force.get(f.name) is None for f in feet if f.name in log.cop):
        mode = "cop"
    else:
        mode = "forces"
    local, force, loaded = [], [], []
    for foot in feet:
        if foot.name in log.forces:
            arr = log.forces[foot.name]
            reject(~np.all(np.isfinite(arr), axis=1), "missing")
            reject(np.any(arr >= config.saturation, axis=1), "saturated")
            f = np.nan_to_num(arr) * config.force_unit
            on = f.sum(axis=1) >= config.min_foot_force  # on the raw readings
            f = np.where(on[:, None], foot.pad_forces(f), 0.0)
            total = f.sum(axis=1)
            with np.errstate(invalid="ignore", divide="ignore"):
                c = (f @ foot.sensors) / np.where(on, total, 1.0)[:, None]
        elif foot.name in log.centroid:
            arr = log.centroid[foot.name]
            reject(~np.all(np.isfinite(arr), axis=1), "missing")
            on = np.all(arr != config.no_load, axis=1) & np.all(np.isfinite(arr), axis=1)
            uv = np.clip(np.nan_to_num(arr) / config.centroid_max, 0.0, 1.0)
            c = foot.centroid_point(uv[:, 0], uv[:, 1])
            total = on.astype(float)
        else:  # a logged CoP, already in the sole frame
            arr = log.cop[foot.name]
            given = np.all(np.isfinite(arr), axis=1)
            fz = log.cop_force.get(foot.name)
            if fz is None:  # no force: loaded wherever the CoP is given
                on = given
                total = on.astype(float)
            else:
                with np.errstate(invalid="ignore"):
                    reject(np.isnan(fz) | (~given & (fz > config.min_foot_force)), "missing")
                    on = given & (fz >= config.min_foot_force)
                total = np.nan_to_num(fz)
            c = np.where(on[:, None], arr, 0.0)
        # without a force for every source, one loaded foot only (weight 1)
        force.append(np.where(on, total, 0.0) if mode == "forces" else on.astype(float))
        local.append(c)
        loaded.append(on)
    loaded = np.stack(loaded, axis=1)  # (m, feet)
    force = np.stack(force, axis=1)
    reject(~loaded.any(axis=1), "no_load")
    if mode != "forces":
        reject(loaded.sum(axis=1) > 1, "two_feet_no_force")

    # carry each foot's CoP into the support frame at the pose's mean read-backs
    good_q = np.isfinite(q_mean).all(axis=1)
    cop = np.zeros((m, 2))
    for fi, foot in enumerate(feet):
        rot = np.tile(np.eye(3), (k, 1, 1))
        org = np.zeros((k, 3))
        if good_q.any():
            rot[good_q], org[good_q] = robot.link_poses(q_mean[good_q], foot.sole_frame)
        tilt = np.arccos(np.clip(rot[:, 2, 2], -1.0, 1.0))
        off = (np.abs(org[:, 2]) > OFF_FLOOR_M) | (tilt > OFF_FLOOR_TILT)
        reject(loaded[:, fi] & off[g], "off_floor")
        p = org[g, :2] + np.einsum("nij,nj->ni", rot[g, :2, :2], local[fi])
        cop += force[:, fi : fi + 1] * p
    total = force.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cop /= np.where(total > 0, total, 1.0)[:, None]
    force_n = total if mode == "forces" else np.full(m, np.nan)

    # robust outlier rule per pose, on CoP x, CoP y and the total force
    ok = status < 0
    if ok.any():
        out = np.zeros(m, dtype=bool)
        gi = g[ok]
        for axis in range(2):
            out[ok] |= _outliers(cop[ok, axis], gi, k, config.outlier_k, config.outlier_floor)
        if mode == "forces":
            out[ok] |= _outliers(force_n[ok], gi, k, config.outlier_k, config.outlier_floor_force)
        reject(out, "outlier")

    ok = status < 0
    n_used = np.bincount(g[ok], minlength=k)
    rejected = np.zeros((k, len(REASONS)), dtype=int)
    bad = ~ok
    np.add.at(rejected, (g[bad], status[bad]), 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.stack([np.bincount(g[ok], cop[ok, a], minlength=k) for a in range(2)], 1)
        mean = mean.astype(float) / n_used[:, None]
        dev = cop - mean[g]
        ss = np.stack([np.bincount(g[ok], dev[ok, a] ** 2, minlength=k) for a in range(2)], 1)
        var = ss / np.maximum(n_used - 1, 1)[:, None]
        fmean = np.bincount(g[ok], np.nan_to_num(force_n[ok]), minlength=k) / n_used
    if mode == "centroid":
        # quantisation: one register count along each support-frame axis (conservative)
        boards = [f for f in feet if f.name in log.centroid]
        step = (
            np.array([np.abs(f.sensors[[1, 2]] - f.sensors[0]).max(axis=0) for f in boards]).max(
                axis=0
            )
            / config.centroid_max
        )
        var = var + step**2 / 12
    if mode != "forces":
        fmean = np.full(k, np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        se = np.maximum(np.sqrt(var / n_used[:, None]), 1e-7)

    grav = None
    if log.gravity is not None:  # mean direction over the usable samples, renormalised
        og = ok & np.all(np.isfinite(log.gravity), axis=1)
        g_sum = np.stack([np.bincount(g[og], log.gravity[og, a], minlength=k) for a in range(3)], 1)
        with np.errstate(invalid="ignore", divide="ignore"):
            grav = g_sum / np.linalg.norm(g_sum, axis=1, keepdims=True)
    keep = (n_used >= min_samples) & good_q
    dropped = []
    for i in np.flatnonzero(~keep):
        why = [f"{r}={int(c)}" for r, c in zip(REASONS, rejected[i], strict=True) if c]
        dropped.append(
            (
                str(ids[i]),
                f"{int(n_used[i])} usable of {int(n_used[i] + rejected[i].sum())} samples "
                f"(need {min_samples}; rejected: {', '.join(why) or 'none'})",
            )
        )
    return Measured(
        pose=ids[keep],
        q=q_mean[keep],
        cop=mean[keep],
        cop_se=se[keep],
        force=fmean[keep],
        n_used=n_used[keep],
        rejected=rejected[keep],
        dropped=dropped,
        mode=mode,
        gravity=None if grav is None else grav[keep],
    )


def check_pose_ids(measured_ids: np.ndarray, list_ids: np.ndarray, where: str) -> list[str]:
    """Error on ids measured but absent from the pose list; return the list's unmeasured ids."""
    known = set(list_ids.tolist())
    unknown = [p for p in dict.fromkeys(measured_ids.tolist()) if p not in known]
    if unknown:
        more = f" (and {len(unknown) - 1} more)" if len(unknown) > 1 else ""
        raise DataError(f"{where}: pose id '{unknown[0]}'{more} is not in the pose list")
    seen = set(measured_ids.tolist())
    return [p for p in list_ids.tolist() if p not in seen]


def pose_list_ids(table: Table) -> np.ndarray:
    """Pose ids of a pose list: its ``pose`` column, else the row numbers 0, 1, …"""
    if "pose" in table.columns or "pose" in table.text:
        ids = pose_ids(table)
        dup = [p for p in dict.fromkeys(ids.tolist()) if (ids == p).sum() > 1]
        if dup:
            raise DataError(f"{table.path}: pose id '{dup[0]}' appears twice")
        return ids
    return np.array([str(i) for i in range(table.n)])


def imu_gravity_samples(robot, table: Table, q: np.ndarray, link: str | None) -> np.ndarray | None:
    """Per-sample gravity (m, 3) from the IMU columns at the read-backs (NaN where q is)."""
    from sescid.sensors.imu import gravity_from_imu, imu_link, read_imu

    rp = read_imu(table)
    name = imu_link(robot, link)
    if rp is None or name is None:
        return None
    out = np.full((q.shape[0], 3), np.nan)
    ok = np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(rp), axis=1)
    if np.any(ok):
        out[ok] = gravity_from_imu(robot, q[ok], rp[ok, 0], rp[ok, 1], name)
    return out


def fsr(
    robot,
    log_table: Table,
    config: SensorConfig,
    min_samples: int = 5,
    pose_list: Table | None = None,
    imu_link: str | None = None,
) -> tuple[Measured, list[str]]:
    """Reduce a raw log table per pose; with a ``pose_list`` table, check the ids against it.

    Without ``grav_x/y/z`` columns, ``imu_roll``/``imu_pitch`` of the IMU on ``imu_link`` (or
    the profile's) give the gravity direction per sample (``experiment.imu``).
    Returns the result and the pose-list ids that were not measured.
    """
    log = read_raw(log_table, robot.joint_names, config, robot.profile.servo)
    if log.gravity is None:
        log.gravity = imu_gravity_samples(robot, log_table, log.q, imu_link)
    unmeasured: list[str] = []
    if pose_list is not None:
        unmeasured = check_pose_ids(log.pose, pose_list_ids(pose_list), str(log_table.path))
    res = measure(robot, log, config, min_samples)
    if len(res.pose) == 0:
        reasons = "; ".join(f"pose {p}: {w}" for p, w in res.dropped[:3])
        raise DataError(f"{log_table.path}: no pose has a usable CoP ({reasons})")
    return res, unmeasured
