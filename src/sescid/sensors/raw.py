"""A raw log (many samples per pose) read into SI arrays, every error naming row and column.

Columns: a ``pose`` id; joint read-backs (radians in columns named as the joints, or
``<joint>_deg`` degrees, or ``<joint>_ticks`` in the robot profile's servo ticks; one unit per
joint); per foot one source:

- the four forces ``<prefix>1..4`` in board counts (``force_unit_N`` each, 1 mN on the OP2), or
- the centroid registers ``<prefix>_x``, ``<prefix>_y`` (0–254, 255 = no load), or
- a ready CoP ``<cop>_cop_x``, ``<cop>_cop_y`` in metres in the foot's sole frame, with the foot's
  normal force ``<cop>_fz`` in N when known (what ``sescid bag`` writes for an ankle F/T sensor,
  a force plate or a CoP topic; ``sescid.sensors.wrench``);

joint torques ``tau_<joint>`` [N·m] and the pose's ``approach`` side (``sensors.torque``);
optional ``grav_x/y/z`` (support frame). A log with torques needs no foot-sensor columns (and
no sensor file).

Plausibility of a logged CoP (an F/T sensor or a plate): a loaded foot's CoP lies within its
pads' rectangle plus ``COP_SOLE_MARGIN_M``, and its normal force is positive (a reversed sensor
sign gives negative forces: refused in one line instead of unloaded feet).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sescid.errors import DataError
from sescid.robots import ServoEncoding
from sescid.sensors.pads import Foot, SensorConfig
from sescid.tables import (
    GRAVITY_COLUMNS,
    Table,
    column_with_missing,
    pose_ids,
    read_approach,
    read_gravity,
    read_joint_columns,
    read_torques,
)
from sescid.tables.rows import RowNames

#: a logged CoP farther than this from its sole origin is not in metres
COP_MAX_M = 2.0
#: m, a loaded foot's logged CoP may lie this far outside its pads' rectangle (the sole is
#: larger than the pads); beyond it the sensor, its frame or its units are wrong
COP_SOLE_MARGIN_M = 0.05


@dataclass(frozen=True)
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
    tau_joints: tuple[str, ...] = ()  #: joints with a torque column, model order
    tau: np.ndarray | None = None  #: (m, k) joint torques, N·m
    approach: np.ndarray | None = None  #: (m,) ±1 (NaN missing)
    #: the table's row names: sample 0 at ``rows.first_row`` (a part of a log moves it)
    rows: RowNames = RowNames()

    def where(self, i) -> str:
        """Sample ``i`` as an error names it: the file's row as a spreadsheet counts it (or the
        session's pose and sample); parts of a log keep it (``rows.first_row`` moves)."""
        return self.rows.where(i)

    @property
    def has_feet(self) -> bool:
        """True when some foot has a sensor source in the log."""
        return bool(self.forces or self.centroid or self.cop)


def table_from_columns(columns: dict[str, np.ndarray], name: str = "<bench>", label=None) -> Table:
    """A ``Table`` of in-memory columns (a bench's or a session's raw log, as ``read_table``
    gives a file: numbers as float, text as text); ``label(i)`` names data row i in errors."""
    num, text = {}, {}
    for k, v in columns.items():
        arr = np.asarray(v)
        if arr.dtype.kind in "biuf":
            num[k] = arr.astype(float)
        else:
            text[k] = [str(x) for x in arr]
    return Table(Path(name), num, text, label=label)


def read_raw(
    table: Table,
    joint_names: list[str],
    config: SensorConfig | None,
    servo: ServoEncoding | None = None,
) -> RawLog:
    """Parse a raw log (module docstring) into SI arrays; errors name the column.

    ``config`` None: no foot sensors (a torque-only log).
    """
    pose = pose_ids(table)
    q, units = read_joint_columns(table, joint_names, servo)
    names = set(table.names())
    forces: dict[str, np.ndarray] = {}
    centroid: dict[str, np.ndarray] = {}
    cop: dict[str, np.ndarray] = {}
    cop_force: dict[str, np.ndarray | None] = {}
    if config is not None:
        for foot in config.feet:
            _read_foot(table, foot, config, names, (forces, centroid, cop, cop_force))
    torques = read_torques(table, joint_names, allow_missing=True)
    tau = torques.tau if torques.joints else None
    attitude = any(c in names for c in (*GRAVITY_COLUMNS, "imu_roll", "imu_pitch"))
    if not forces and not centroid and not cop and tau is None and not attitude:
        if config is None:
            raise DataError(
                f"{table.path}: no joint-torque columns (tau_<joint>) and no foot-sensor "
                "layout to read foot-sensor columns (give a sensor file)"
            )
        want = ", ".join(
            f"{f.columns}1..4 or {f.columns}_x/_y or {f.cop_prefix}_cop_x/_y" for f in config.feet
        )
        raise DataError(f"{table.path}: no foot-sensor columns ({want}) and no tau_<joint>")
    if forces and centroid:
        raise DataError(
            f"{table.path}: one foot logs forces and the other only centroid registers: "
            "log the same kind for both feet"
        )
    gravity = read_gravity(table) if any(c in names for c in GRAVITY_COLUMNS) else None
    return RawLog(
        path=table.path,
        pose=pose,
        q=q,
        forces=forces,
        centroid=centroid,
        units=units,
        cop=cop,
        cop_force=cop_force,
        gravity=gravity,
        tau_joints=torques.joints,
        tau=tau,
        approach=read_approach(table, allow_missing=True),
        rows=table.rows,
    )


def _read_foot(table: Table, foot: Foot, config: SensorConfig, names: set[str], out) -> None:
    """One foot's source (forces, registers or a logged CoP) into the dicts ``out``."""
    forces, centroid, cop, cop_force = out
    fcols = [f"{foot.columns}{k}" for k in range(1, 5)]
    ccols = [f"{foot.columns}_x", f"{foot.columns}_y"]
    has_f = [c in names for c in fcols]
    has_c = [c in names for c in ccols]
    if _read_cop(table, foot, config, names, (cop, cop_force)):
        if any(has_f) or any(has_c):
            board = fcols[0] if any(has_f) else ccols[0]
            raise DataError(
                f"{table.path}: the {foot.name} foot logs both a CoP "
                f"('{foot.cop_prefix}_cop_x') and its sensor board ('{board}'): "
                "keep one source per foot"
            )
        return
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
                f"{table.path}: {table.where(i)}, column '{fcols[k]}': negative force count "
                f"{f[i, k]:g} (the board reports 0–{config.saturation} counts)"
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
                f"{table.path}: {table.where(i)}, column '{ccols[k]}': {c[i, k]:g} is not a "
                f"centroid register (integer 0–{config.centroid_max}, "
                f"{config.no_load} = no load)"
            )
        centroid[foot.name] = c


def _read_cop(table: Table, foot: Foot, config: SensorConfig, names: set[str], out) -> bool:
    """A foot's logged CoP (and normal force) into ``out``; False if it has none."""
    cop, cop_force = out
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
            f"{table.path}: {table.where(i)}, column '{pcols[k]}': {c[i, k]:g} is "
            f"{COP_MAX_M:g} m or more from the sole (CoP columns are in metres)"
        )
    fz = column_with_missing(table, zcol) if zcol in names else None
    if fz is not None:
        _check_normal_force(table, zcol, fz, config.min_foot_force)
        with np.errstate(invalid="ignore"):
            loaded = np.isfinite(c).all(axis=1) & (fz >= config.min_foot_force)
    else:
        loaded = np.isfinite(c).all(axis=1)
    _check_within_sole(table, foot, c, loaded, pcols)
    cop[foot.name] = c
    cop_force[foot.name] = fz
    return True


def _check_normal_force(table: Table, zcol: str, fz: np.ndarray, min_force: float) -> None:
    """A reversed sensor sign (most loaded samples pull) or an infinite force: one line."""
    inf = np.flatnonzero(np.isinf(fz))
    if inf.size:
        raise DataError(
            f"{table.path}: {table.where(inf[0])}, column '{zcol}': {fz[inf[0]]} is not a force"
        )
    why = reversed_force(fz, min_force)
    if why is not None:
        raise DataError(f"{table.path}: column '{zcol}': {why}")


def reversed_force(fz: np.ndarray, min_force: float) -> str | None:
    """Why a foot's normal forces (m,) N come from a sensor of reversed sign (most loaded
    samples pull on the floor), or None."""
    with np.errstate(invalid="ignore"):
        pushing = int(np.sum(fz >= min_force))
        pulling = int(np.sum(fz <= -min_force))
    if pulling <= pushing:
        return None
    med = float(np.nanmedian(fz))
    return (
        f"the normal force is negative in {pulling} of {pulling + pushing} loaded samples "
        f"(median {med:.4g} N): the force/torque sensor's sign is reversed (negate its force "
        "and torque: the floor pushes up on the foot)"
    )


def _check_within_sole(table, foot: Foot, c: np.ndarray, loaded: np.ndarray, cols) -> None:
    """DataError naming row and column of a loaded CoP beyond the pads' rectangle + margin."""
    centre, half = foot.half_extents()
    with np.errstate(invalid="ignore"):
        out = loaded[:, None] & (np.abs(c - centre) > half + COP_SOLE_MARGIN_M)
    bad = np.argwhere(out)
    if bad.size:
        i, k = bad[0]
        axis = "xy"[k]
        raise DataError(
            f"{table.path}: {table.where(i)}, column '{cols[k]}': {c[i, k]:g} m lies "
            f"{(abs(c[i, k] - centre[k]) - half[k]) * 1e3:.0f} mm outside the {foot.name} foot's "
            f"pads along {axis} (more than {COP_SOLE_MARGIN_M * 1e3:.0f} mm beyond the sole): "
            "a wrong sensor frame, sign or unit"
        )
