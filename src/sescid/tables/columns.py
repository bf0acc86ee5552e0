"""The named measurement columns of a data file, and their one reader (joints, CoP, torques).

Joint columns are named as the model's joints: ``<joint>`` in rad, ``<joint>_deg`` in degrees or
``<joint>_ticks`` in servo ticks (the robot profile's encoder); exactly one unit per joint.
``cop_x``, ``cop_y`` are metres in the support frame; ``cop_se_x``/``cop_se_y``
per-pose CoP standard errors in metres; ``tau_<joint>`` joint torques in N·m (any subset of
the joints) with optional ``tau_se_<joint>``; ``approach`` ±1 per pose; ``grav_x/y/z`` the
gravity direction. Every error names the file, row and column.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.base.constants import G0
from sescid.errors import DataError
from sescid.robots import ServoEncoding
from sescid.tables.table import Table, column_with_missing, pose_ids


def read_joint_columns(
    table: Table,
    joint_names: list[str],
    servo: ServoEncoding | None = None,
    allow_missing: bool = True,
) -> tuple[np.ndarray, dict[str, str]]:
    """Joint angles (m, nq) in rad from ``<j>`` (rad), ``<j>_deg`` or ``<j>_ticks`` columns.

    Exactly one unit per joint (a raw log), except that a pose list (``allow_missing=False``)
    may carry derived ``_deg``/``_ticks`` copies beside the radians, which are then used;
    ``_ticks`` needs the robot's ``servo`` encoding. With ``allow_missing`` empty cells become
    NaN, otherwise they are errors. Radians beyond ±2π,
    degrees beyond ±360 and ticks outside the encoder's range are errors.
    """
    names = set(table.names())
    cols, units = [], {}
    for j in joint_names:
        found = [
            (u, c)
            for u, c in (("rad", j), ("deg", f"{j}_deg"), ("ticks", f"{j}_ticks"))
            if c in names
        ]
        if not found:
            raise DataError(
                f"{table.path}: missing joint column '{j}' (in rad; or '{j}_deg' in degrees"
                + (f", '{j}_ticks' in {servo.name} ticks)" if servo else ")")
            )
        if len(found) > 1 and not allow_missing and found[0][0] == "rad":
            _check_copies(table, j, found, servo)
            found = found[:1]  # a pose list: radians plus derived copies for the operator
        if len(found) > 1:
            raise DataError(
                f"{table.path}: joint '{j}' is given in two units "
                f"({', '.join(c for _, c in found)}): keep one column per joint"
            )
        unit, name = found[0]
        v = column_with_missing(table, name) if allow_missing else table.get(name, "joint column")
        if unit == "rad":
            bad = np.flatnonzero(np.abs(v) > MAX_ANGLE_RAD)
            if bad.size:
                raise DataError(
                    f"{table.path}: {table.where(bad[0])}, "
                    f"column '{name}': {v[bad[0]]:g} looks like "
                    f"degrees or ticks; joint columns are in radians (use '{j}_deg' for degrees)"
                )
        elif unit == "deg":
            bad = np.flatnonzero(np.abs(v) > 360)
            if bad.size:
                raise DataError(
                    f"{table.path}: {table.where(bad[0])}, "
                    f"column '{name}': {v[bad[0]]:g} is not an "
                    "angle in degrees"
                )
            v = np.radians(v)
        else:
            if servo is None:
                raise DataError(
                    f"{table.path}: column '{name}' is in servo ticks, but this robot's profile "
                    "has no servo encoding; give the angle in rad or degrees"
                )
            bad = np.flatnonzero((v < 0) | (v > servo.max_tick))
            if bad.size:
                raise DataError(
                    f"{table.path}: {table.where(bad[0])}, "
                    f"column '{name}': {v[bad[0]]:g} is outside "
                    f"the {servo.name} range 0–{servo.max_tick} ticks"
                )
            v = servo.to_rad(v)
        cols.append(v)
        units[j] = unit
    return (np.column_stack(cols) if cols else np.zeros((table.n, 0))), units


#: degrees a pose list's ``<j>_deg`` copy may differ from its radians (printing round-off)
COPY_TOL_DEG = 1e-6


def _check_copies(table: Table, joint: str, found, servo: ServoEncoding | None) -> None:
    """DataError when a pose list's ``<j>_deg``/``<j>_ticks`` copy disagrees with its radians
    (an edited column: which one holds the pose?), naming the row and both columns."""
    rad = table.get(joint, "joint column")
    for unit, name in found[1:]:
        if unit == "deg":
            copy = table.get(name, "joint column")
            bad = np.flatnonzero(~(np.abs(np.degrees(rad) - copy) <= COPY_TOL_DEG))
            shown = "{:g}°"
        elif servo is not None:
            copy = table.get(name, "joint column")
            tick = float(np.abs(np.diff(servo.to_rad(np.array([0.0, 1.0])))[0]))  # rad per tick
            bad = np.flatnonzero(~(np.abs(servo.to_rad(copy) - rad) <= 0.5 * tick + 1e-9))
            shown = "{:g} ticks"
        else:
            continue
        if bad.size:
            i = int(bad[0])
            raise DataError(
                f"{table.path}: {table.where(i)}: columns '{joint}' ({rad[i]:g} rad = "
                f"{math.degrees(rad[i]):g}°) and '{name}' ({shown.format(copy[i])}) disagree: "
                "keep one column per joint (the radians are read)"
            )


def read_poses(
    table: Table, joint_names: list[str], servo: ServoEncoding | None = None
) -> np.ndarray:
    """Joint angles (n, nq) in rad; every cell present and finite (see ``read_joint_columns``)."""
    return read_joint_columns(table, joint_names, servo, allow_missing=False)[0]


#: m: a CoP coordinate beyond this is taken for a unit mistake (mm for m)
MAX_COP_M = 2.0
#: m: a CoP noise standard deviation beyond this is taken for a unit mistake (mm for m)
MAX_COP_NOISE_M = 0.1
#: rad: a joint angle beyond this is taken for degrees (or servo ticks)
MAX_ANGLE_RAD = 2 * math.pi


def read_cop(table: Table) -> np.ndarray:
    """Measured CoP (n, 2) in metres from ``cop_x``, ``cop_y``: a coordinate not measured (its
    column absent, or an empty cell) is nan; a row with neither is an error naming it."""
    cols = []
    for name in ("cop_x", "cop_y"):
        if name in table.columns or name in table.text:
            col = column_with_missing(table, name)
            inf = np.flatnonzero(np.isinf(col))
            if inf.size:
                raise DataError(
                    f"{table.path}: {table.where(inf[0])}, column '{name}': value "
                    f"{col[inf[0]]} is not finite"
                )
            cols.append(col)
        else:
            cols.append(np.full(table.n, np.nan))
    cop = np.column_stack(cols)
    big = np.argwhere(np.abs(cop) > MAX_COP_M)
    if big.size:
        i, j = big[0]
        raise DataError(
            f"{table.path}: {table.where(i)}, column 'cop_{'xy'[j]}': {cop[i, j]:g} m is not a "
            "plausible CoP (columns are in metres)"
        )
    return cop


def read_cop_se(table: Table) -> np.ndarray | None:
    """Per-pose CoP standard errors (n, 2) in m, if the table has them."""
    if "cop_se_x" in table or "cop_se_y" in table:
        return np.column_stack([table.get("cop_se_x"), table.get("cop_se_y")])
    return None


#: a planned pose list's CoP: the model's prediction at each pose, never a measurement (named
#: apart from ``cop_x``/``cop_y`` so that a plan cannot be fitted as if it were measured)
MODEL_COP_COLUMNS = ("cop_x_model", "cop_y_model")


def refuse_plan(table: Table) -> None:
    """DataError when a table is a planned pose list (``sescid poses``, a session's poses.csv):
    its CoP columns are the model's predictions, and a fit to them returns the model."""
    if MODEL_COP_COLUMNS[0] in table or MODEL_COP_COLUMNS[0] in table.text:
        raise DataError(
            f"{table.path}: a planned pose list ({', '.join(MODEL_COP_COLUMNS)} are the model's "
            "predictions, not measurements): measure the poses (sescid experiment or the "
            "robot's log, then sescid measure) and give the measured file"
        )


def refuse_raw_log(table: Table) -> None:
    """DataError when a table is a raw log (a ``sample`` column, or a pose id repeated on
    consecutive rows: one row per sample) given where one row per pose is read."""
    if "sample" in table.names():
        raise DataError(
            f"{table.path}: a raw log (a 'sample' column: one row per sample): reduce it to one "
            "row per pose with sescid measure, then give the measured file"
        )
    if "pose" not in table.names():
        return
    ids = pose_ids(table)
    same = np.flatnonzero(ids[1:] == ids[:-1])
    if same.size:
        i = int(same[0])
        raise DataError(
            f"{table.path}: a raw log ({table.where(i)} and {table.where(i + 1)} are both pose "
            f"'{ids[i]}': one row per sample): reduce it to one row per pose with sescid "
            "measure, then give the measured file"
        )


GRAVITY_COLUMNS = ("grav_x", "grav_y", "grav_z")


def read_gravity(table: Table) -> np.ndarray | None:
    """Unit gravity directions (n, 3), support frame, from ``grav_x/y/z``; None when absent."""
    has = [c in table for c in GRAVITY_COLUMNS]
    if not any(has):
        return None
    if not all(has):
        missing = GRAVITY_COLUMNS[has.index(False)]
        raise DataError(f"{table.path}: missing column '{missing}' (gravity direction)")
    g = np.column_stack([table.get(c) for c in GRAVITY_COLUMNS])
    norm = np.linalg.norm(g, axis=1)
    bad = np.flatnonzero(~np.isfinite(norm) | (g[:, 2] >= -0.5 * norm))
    if bad.size:
        i = int(bad[0])
        raise DataError(
            f"{table.path}: {table.where(i)}, columns grav_x/y/z: "
            f"gravity ({', '.join(f'{v:g}' for v in g[i])}) must be "
            "finite and point down through the sole (grav_z < 0, tilt < 60°)"
        )
    return g / norm[:, None]


#: joint torque columns: ``tau_<joint>`` N·m, optional ``tau_se_<joint>`` N·m (standard error)
TAU_PREFIX, TAU_SE_PREFIX = "tau_", "tau_se_"
#: the side each pose was reached from: +1 from below, −1 from above (joint torques' friction)
APPROACH_COLUMN = "approach"
#: the stance of each row (a frame of the model, or "double"): measurement files and raw logs
SUPPORT_COLUMN = "support"
#: N·m beyond which a torque is taken for a unit mistake (mN·m, N·mm)
MAX_TORQUE_NM = 1e4
#: m, a lever no humanoid's gravity torque exceeds: a holding torque beyond the whole robot's
#: weight this far from its joint is not in N·m (mN·m, N·mm)
TORQUE_REACH_M = 2.0


def torque_bound(mass: float) -> float:
    """N·m, the largest holding torque a robot of ``mass`` kg can need (``TORQUE_REACH_M``)."""
    return mass * G0 * TORQUE_REACH_M


@dataclass(frozen=True)
class Torques:
    """Joint torques read from a table: ``tau`` (n, k) N·m about each joint's axis (model sign)
    for ``joints`` (k, in the model's joint order), ``se`` (n, k) N·m or None."""

    joints: tuple[str, ...]
    tau: np.ndarray
    se: np.ndarray | None


def torque_joints(table: Table, joint_names: list[str]) -> list[str]:
    """Joints that have a ``tau_<joint>`` column, in joint order; a ``tau_`` column that names
    no joint of the model is a DataError naming the column."""
    known = set(joint_names)
    have = set()
    for name in table.names():
        if not name.startswith(TAU_PREFIX):
            continue
        rest = name[len(TAU_PREFIX) :]
        if rest in known:
            have.add(rest)
        elif not (name.startswith(TAU_SE_PREFIX) and name[len(TAU_SE_PREFIX) :] in known):
            raise DataError(
                f"{table.path}: column '{name}': '{rest}' is not a joint of the model "
                "(torque columns are tau_<joint>, joint names as in the model file)"
            )
    return [j for j in joint_names if j in have]


def read_torques(table: Table, joint_names: list[str], allow_missing: bool = False) -> Torques:
    """The ``tau_<joint>`` columns (any subset of the joints) and their ``tau_se_<joint>``.

    With ``allow_missing`` (a raw log) empty cells become NaN, otherwise they are errors.
    Torques beyond ±MAX_TORQUE_NM (or infinite) and negative or non-finite standard errors are
    errors naming the file, row and column; standard errors come for every torque column or
    for none.
    """
    joints = torque_joints(table, joint_names)
    cols = []
    for j in joints:
        name = f"{TAU_PREFIX}{j}"
        v = column_with_missing(table, name) if allow_missing else table.get(name, "column")
        big = np.flatnonzero(np.abs(v) > MAX_TORQUE_NM)
        if big.size:
            raise DataError(
                f"{table.path}: {table.where(big[0])}, column '{name}': {v[big[0]]:g} is not a "
                "plausible joint torque in N·m"
            )
        cols.append(v)
    n = table.n
    tau = np.column_stack(cols) if cols else np.zeros((n, 0))
    se_names = [c for c in table.names() if c.startswith(TAU_SE_PREFIX)]
    orphan = next((c for c in se_names if c[len(TAU_SE_PREFIX) :] not in joints), None)
    if orphan is not None:
        raise DataError(f"{table.path}: column '{orphan}' has no torque column beside it")
    if not se_names:
        return Torques(tuple(joints), tau, None)
    se = np.empty_like(tau)
    for k, j in enumerate(joints):
        name = f"{TAU_SE_PREFIX}{j}"
        if name not in se_names:
            raise DataError(
                f"{table.path}: missing column '{name}' (a standard error for every torque "
                "column, or none)"
            )
        v = column_with_missing(table, name) if allow_missing else table.get(name, "column")
        bad = np.flatnonzero(v < 0)
        if bad.size:
            raise DataError(
                f"{table.path}: {table.where(bad[0])}, column '{name}': {v[bad[0]]:g} is not "
                "a standard error (≥ 0 N·m)"
            )
        se[:, k] = v
    return Torques(tuple(joints), tau, se)


def read_approach(
    table: Table, name: str = APPROACH_COLUMN, allow_missing: bool = False
) -> np.ndarray | None:
    """The side each pose was reached from (n,): +1 from below, −1 from above; None without
    the column. Any other value is a DataError naming the row. With ``allow_missing`` (a raw
    log) empty cells are NaN and the column stays float; otherwise it is ±1 as int."""
    if name not in table.names():
        return None
    v = column_with_missing(table, name) if allow_missing else table.get(name)
    bad = np.flatnonzero(~np.isnan(v) & (v != 1) & (v != -1))
    if bad.size:
        raise DataError(
            f"{table.path}: {table.where(bad[0])}, column '{name}': {v[bad[0]]:g} is not +1 "
            "or -1 (the side the joints came from: +1 below, -1 above)"
        )
    return v if allow_missing else v.astype(int)
