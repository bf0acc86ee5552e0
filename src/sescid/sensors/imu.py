"""Gravity direction in the support frame from an IMU's roll and pitch on a named link.

An IMU at rest reports its link's roll φ and pitch θ relative to the world (Z-Y-X Euler angles,
yaw unobservable and irrelevant): with ``R_world←link = Rz(ψ) Ry(θ) Rx(φ)`` the world's down
direction in the link frame is

    g_link = R_link←world (0, 0, −1) = (sin θ, −cos θ sin φ, −cos θ cos φ).

The model carries it to the support frame at the pose's joint angles:
``g = R_support←link(q) · g_link`` (``Robot.link_poses``). The MuJoCo bench logs ``imu_roll``,
``imu_pitch`` in this convention (``experiment.mujoco_bench``). Columns: ``imu_roll``,
``imu_pitch`` (rad); the link is named by the caller (``--imu-link``) or the robot profile
(``RobotProfile.imu_link``). Logged ``grav_x/y/z`` columns take precedence.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from sescid.errors import DataError, OptionError
from sescid.robot import Robot
from sescid.tables import GRAVITY_COLUMNS, Table, read_gravity

#: raw-log / data columns of an IMU's roll and pitch (rad)
IMU_COLUMNS = ("imu_roll", "imu_pitch")


def gravity_in_link(roll: ArrayLike, pitch: ArrayLike) -> np.ndarray:
    """Unit gravity direction (n, 3) in the IMU link's frame from roll, pitch (n,) [rad]."""
    r = np.asarray(roll, dtype=float).reshape(-1)
    p = np.asarray(pitch, dtype=float).reshape(-1)
    return np.stack([np.sin(p), -np.cos(p) * np.sin(r), -np.cos(p) * np.cos(r)], axis=1)


def imu_link(robot: Robot, link: str | None = None) -> str | None:
    """The IMU's link: ``link`` if given (checked), else the profile's; None when unknown."""
    name = link if link is not None else robot.profile.imu_link
    if name is not None and name not in robot.model.link_frames:
        raise OptionError(
            "imu_link", f"'{name}' is not a link of {robot.model_path.name} (the IMU's link)"
        )
    return name


def gravity_from_imu(robot: Robot, q: ArrayLike, roll: ArrayLike, pitch: ArrayLike, link: str):
    """Gravity directions (n, 3) in the support frame from IMU roll/pitch (n,) on ``link``.

    ``q`` (n, nq) [rad] are the joint angles at which the IMU was read.
    """
    rot, _ = robot.link_poses(q, link)
    g_link = gravity_in_link(roll, pitch)
    if g_link.shape[0] != rot.shape[0]:
        raise DataError(f"IMU: {g_link.shape[0]} roll/pitch values for {rot.shape[0]} poses")
    return np.einsum("nij,nj->ni", rot, g_link)


def read_imu(table: Table) -> np.ndarray | None:
    """IMU roll and pitch (n, 2) [rad] from ``imu_roll``, ``imu_pitch``; None when absent."""
    have = [c in table for c in IMU_COLUMNS]
    if not any(have):
        return None
    if not all(have):
        missing = IMU_COLUMNS[have.index(False)]
        raise DataError(f"{table.path}: missing column '{missing}' (IMU roll/pitch)")
    out = np.column_stack([np.asarray(table.get(c), dtype=float) for c in IMU_COLUMNS])
    bad = np.argwhere(~(np.abs(out) < np.pi / 2))
    if bad.size:
        i, k = bad[0]
        raise DataError(
            f"{table.path}: {table.where(i)}, column '{IMU_COLUMNS[k]}': {out[i, k]:g} is not an "
            "angle in radians below 90° (degrees?)"
        )
    return out


def table_gravity(robot: Robot, table: Table, q: np.ndarray, link: str | None = None):
    """Gravity (n, 3) of a data table: ``grav_x/y/z``, else the IMU columns through the model.

    ``q`` (n, nq) [rad]: the table's poses. None when the table has neither; DataError for IMU
    columns without a known IMU link (``link`` or the profile's), OptionError for a ``link``
    given to a table without IMU columns.
    """
    if any(c in table for c in GRAVITY_COLUMNS):
        table_imu_link(robot, table, link)
        return read_gravity(table)
    return imu_gravity_samples(robot, table, q, link)


def imu_gravity_samples(
    robot: Robot, table: Table, q: np.ndarray, link: str | None
) -> np.ndarray | None:
    """Per-sample gravity (m, 3) from the IMU columns at the read-backs (NaN where q or the
    IMU is); None without IMU columns (see ``table_imu_link`` for the errors)."""
    name = table_imu_link(robot, table, link)
    rp = read_imu(table)
    if rp is None or name is None:
        return None
    out = np.full((q.shape[0], 3), np.nan)
    ok = np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(rp), axis=1)
    if np.any(ok):
        out[ok] = gravity_from_imu(robot, q[ok], rp[ok, 0], rp[ok, 1], name)
    return out


def table_imu_link(robot: Robot, table: Table, link: str | None = None) -> str | None:
    """The IMU link for a table's ``imu_roll``/``imu_pitch`` columns (None without them);
    DataError when the table has them and no IMU link is known (its gravity would be lost),
    OptionError when ``link`` is given to a table without them (it would do nothing)."""
    has = any(c in table.names() for c in IMU_COLUMNS)
    name = imu_link(robot, link)
    if has and name is None:
        raise DataError(
            f"{table.path}: columns {', '.join(IMU_COLUMNS)}, but {robot.name}'s profile names "
            "no IMU link: give the link that carries the IMU (imu_link / --imu-link)"
        )
    if not has and link is not None:
        raise OptionError(
            "imu_link", f"'{link}': {table.path} has no {', '.join(IMU_COLUMNS)} columns"
        )
    return name if has else None
