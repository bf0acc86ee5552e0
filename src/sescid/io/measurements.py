"""Measurement files → ``Measurements`` chunks: the columns every kind reads, one home.

A file (CSV or Parquet, streamed in chunks) holds one row per pose: the joint angles (``<joint>``
in rad, or ``<joint>_deg``), and what was measured there — ``cop_x``, ``cop_y`` [m] (optional
``cop_se_x``, ``cop_se_y``), ``tau_<joint>`` [N·m] for any subset of joints (optional
``tau_se_<joint>``), ``approach`` (±1), gravity (``grav_x/y/z``, or the IMU's roll and pitch on a
link), and for simulated data the noise-free ``cop_x_true``, ``cop_y_true``. Poses outside the
model's joint limits stop the read with an error naming the first row (degrees in a radian
column, or another robot), unless allowed or the data are simulated (then a warning).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sescid.base.columns import Table, read_cop, read_poses
from sescid.errors import DataError
from sescid.estimation import Measurements, outside_limits
from sescid.estimation.checks import LimitViolation
from sescid.io.tables import iter_table, read_ahead
from sescid.robot import Robot
from sescid.sensors.imu import table_gravity

TORQUE_PREFIX = "tau_"
TORQUE_SE_PREFIX = "tau_se_"


@dataclass
class ReadReport:
    """What reading a file found beside the data: poses outside the limits, simulated data."""

    path: str
    n_poses: int = 0
    simulated: bool = False
    limits: list[tuple[int, LimitViolation]] = field(default_factory=list)

    def limit_message(self) -> str | None:
        """One line about the poses outside the joint limits, or None."""
        if not self.limits:
            return None
        start, first = self.limits[0]
        n_bad = sum(v.n_poses for _, v in self.limits)
        row = first.row + start
        return dataclasses.replace(first, row=row, n_poses=n_bad).message(self.n_poses)


def torque_joints(table: Table, robot: Robot) -> tuple[str, ...]:
    """The joints with a ``tau_<joint>`` column, in the robot's joint order; DataError for a
    torque column of a joint the robot does not have."""
    names = [c for c in table.names() if c.startswith(TORQUE_PREFIX)]
    names = [c for c in names if not c.startswith(TORQUE_SE_PREFIX)]
    joints = {c[len(TORQUE_PREFIX) :] for c in names}
    unknown = sorted(joints - set(robot.joint_names))
    if unknown:
        raise DataError(
            f"{table.path}: column 'tau_{unknown[0]}': the robot has no joint '{unknown[0]}'"
        )
    return tuple(j for j in robot.joint_names if j in joints)


def measurements_of(table: Table, robot: Robot, imu_link: str | None = None) -> Measurements:
    """One chunk of a measurement table as ``Measurements`` (not yet validated)."""
    q = read_poses(table, robot.joint_names, robot.profile.servo)
    cop = read_cop(table) if ("cop_x" in table or "cop_y" in table) else None
    cop_se = None
    if "cop_se_x" in table or "cop_se_y" in table:
        cop_se = np.column_stack([table.get("cop_se_x"), table.get("cop_se_y")])
    joints = torque_joints(table, robot)
    tau = tau_se = None
    if joints:
        tau = np.column_stack([table.get(TORQUE_PREFIX + j) for j in joints])
        se_cols = [TORQUE_SE_PREFIX + j for j in joints]
        if any(c in table for c in se_cols):
            tau_se = np.column_stack([table.get(c) for c in se_cols])
    approach = table.get("approach") if "approach" in table else None
    truth = None
    if "cop_x_true" in table and "cop_y_true" in table:
        truth = np.column_stack([table.get("cop_x_true"), table.get("cop_y_true")])
    if cop is None and not joints:
        raise DataError(
            f"{table.path}: no measurement columns: give cop_x, cop_y (centre of pressure) "
            "and/or tau_<joint> (joint torques, N·m)"
        )
    return Measurements(
        q=q,
        cop=cop,
        cop_se=cop_se,
        tau=tau,
        tau_joints=joints,
        tau_se=tau_se,
        approach=approach,
        gravity=table_gravity(robot, table, q, imu_link),
        cop_true=truth,
        source=str(table.path),
    )


def read_measurements(
    path: str | Path,
    robot: Robot,
    *,
    imu_link: str | None = None,
    allow_outside_limits: bool = False,
    report: ReadReport | None = None,
) -> Iterator[Measurements]:
    """The file's chunks as ``Measurements``, read once, as they are parsed (module docstring).
    ``report`` collects the poses outside the limits and whether the data are simulated."""
    rep = report if report is not None else ReadReport(str(path))
    for table in read_ahead(iter_table(path)):
        m = measurements_of(table, robot, imu_link)
        rep.simulated = rep.simulated or m.cop_true is not None
        bad = outside_limits(robot, m.q)
        if bad is not None:
            rep.limits.append((rep.n_poses, bad))
        rep.n_poses += m.n
        if bad is not None and not (allow_outside_limits or rep.simulated):
            raise DataError(
                f"{path}: {rep.limit_message()}; degrees in a radian column, or another "
                "robot? (--allow-outside-limits accepts them)"
            )
        yield m


def rows_estimate(path: str | Path) -> int | None:
    """Rough row count of a data file for a progress line (file bytes / bytes of a row)."""
    try:
        p = Path(path)
        with p.open("rb") as fh:
            head = fh.read(1 << 16)
        lines = head.count(b"\n")
        return int(p.stat().st_size / (len(head) / lines)) if lines > 1 else None
    except OSError:
        return None
