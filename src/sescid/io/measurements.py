"""Measurement files → ``Measurements`` chunks: the columns every kind reads, one home.

A file (CSV or Parquet, streamed in chunks) holds one row per pose: the joint angles (``<joint>``
in rad, or ``<joint>_deg``), and what was measured there — ``cop_x``, ``cop_y`` [m] (optional
``cop_se_x``, ``cop_se_y``), ``tau_<joint>`` [N·m] for any subset of joints (optional
``tau_se_<joint>``), ``approach`` (±1), gravity (``grav_x/y/z``, or the IMU's roll and pitch on a
link), and for simulated data the noise-free ``cop_x_true``, ``cop_y_true`` (or ``true_tau_<joint>``
when only torques were simulated). Poses outside the
model's joint limits stop the read with an error naming the first row (degrees in a radian
column, or another robot), unless allowed or the data are simulated (then a warning).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sescid.errors import DataError
from sescid.estimation import Measurements, outside_limits
from sescid.estimation.data.checks import LimitViolation
from sescid.robot import Robot
from sescid.sensors.imu import table_gravity
from sescid.stance import data_stance, support_column
from sescid.tables import (
    Table,
    iter_table,
    read_ahead,
    read_approach,
    read_cop,
    read_cop_se,
    read_poses,
    read_torques,
    refuse_plan,
    refuse_raw_log,
)


@dataclass
class ReadReport:
    """What reading a file found beside the data: poses outside the limits, simulated data."""

    path: str
    n_poses: int = 0
    simulated: bool = False
    limits: list[tuple[int, LimitViolation]] = field(default_factory=list)
    #: the file row and column of the first violation ("row 7, column 'r_knee'")
    first_limit_at: str | None = None
    #: CoP cells left empty (CSV) or null (Parquet) in a cop_x/cop_y column the file has
    cop_missing: int = 0
    #: the file row and column of the first of them
    first_missing_at: str | None = None

    def missing_message(self) -> str | None:
        """One line about the CoP cells not measured, or None."""
        if not self.cop_missing:
            return None
        return (
            f"{self.path}: {self.cop_missing} CoP coordinate(s) not measured (empty or null "
            f"cells; first: {self.first_missing_at}): those poses are fitted on the coordinate "
            "they have"
        )

    def limit_message(self) -> str | None:
        """One line about the poses outside the joint limits, naming the file, or None."""
        if not self.limits:
            return None
        start, first = self.limits[0]
        n_bad = sum(v.n_poses for _, v in self.limits)
        row = first.row + start
        text = dataclasses.replace(first, row=row, n_poses=n_bad).message(
            self.n_poses, self.first_limit_at
        )
        return f"{self.path}: {text}"


def measurements_of(table: Table, robot: Robot, imu_link: str | None = None) -> Measurements:
    """One chunk of a measurement table as ``Measurements`` (not yet validated)."""
    refuse_plan(table)
    refuse_raw_log(table)
    q = read_poses(table, robot.joint_names, robot.profile.servo)
    has_cop = any(c in table.columns or c in table.text for c in ("cop_x", "cop_y"))
    cop = read_cop(table) if has_cop else None
    cop_se = read_cop_se(table)
    torques = read_torques(table, robot.joint_names)  # file rows and columns in the errors
    joints = torques.joints
    tau = torques.tau if joints else None
    tau_se = torques.se if joints else None
    approach = read_approach(table)
    truth = None
    if "cop_x_true" in table and "cop_y_true" in table:
        truth = np.column_stack([table.get("cop_x_true"), table.get("cop_y_true")])
    gravity = table_gravity(robot, table, q, imu_link)
    balance = _balance(table, robot, has_cop, gravity)
    if cop is None and not joints and balance is None:
        plan = any(f"{j}_deg" in table.names() for j in robot.joint_names)
        raise DataError(
            f"{table.path}: no measurement columns"
            + (" (joint angles only: a pose list, measured nowhere)" if plan else "")
            + ": give cop_x, cop_y (centre of pressure) and/or tau_<joint> (joint torques, N·m)"
        )
    if cop is not None and not joints:
        empty = np.flatnonzero(np.all(np.isnan(cop), axis=1))
        if empty.size:
            raise DataError(
                f"{table.path}: {table.where(empty[0])}: neither cop_x nor cop_y was "
                "measured (drop the row or fill one of them)"
            )
    return Measurements(
        q=q,
        cop=cop,
        cop_se=cop_se,
        balance=balance,
        tau=tau,
        tau_joints=joints,
        tau_se=tau_se,
        approach=approach,
        gravity=gravity,
        cop_true=truth,
        source=str(table.path),
        row_of=table.rows,  # not table.where: a chunk kept by its row names pins its columns
    )


def _balance(table: Table, robot: Robot, has_cop: bool, gravity) -> np.ndarray | None:
    """A line-support robot's balance rows: the ``balance`` column (the CoM's measured offset
    across the line, m), else 0 for every row (balanced poses); None for another support."""
    if robot.line is None:
        if "balance" in table.columns or "balance" in table.text:
            raise DataError(
                f"{table.path}: a 'balance' column needs a support line (a wheel axle, an "
                "edge): give its direction (--line, or load_robot(…, line=…))"
            )
        return None
    if has_cop:
        raise DataError(
            f"{table.path}: a robot balancing on a line has no centre of pressure under a "
            "sole: drop cop_x/cop_y (each row is a balanced pose) or give a sole support"
        )
    if gravity is None:
        raise DataError(
            f"{table.path}: balancing on a line needs the gravity direction of every pose: "
            "grav_x/y/z columns, or imu_roll/imu_pitch with the IMU's link (--imu-link)"
        )
    if "balance" in table.columns or "balance" in table.text:
        return table.get("balance")
    return np.zeros(table.n)


def read_measurements(
    path: str | Path,
    robot: Robot,
    *,
    imu_link: str | None = None,
    allow_outside_limits: bool = False,
    report: ReadReport | None = None,
    support: str | None = None,
) -> Iterator[Measurements]:
    """The file's chunks as ``Measurements``, read once, as they are parsed (module docstring).
    ``report`` collects the poses outside the limits and whether the data are simulated;
    ``support``: the stance of rows without a ``support`` column (None: the robot's own); each
    chunk carries its ``Stance``."""
    given = support  # FILE@FRAME: the one stance check, naming the file and frame
    stance, _ = data_stance(robot, support, where=f"{path}@{support}")
    rep = report if report is not None else ReadReport(str(path))
    at = None if given is None else f"{path}@{given}"
    for table in read_ahead(iter_table(path)):
        m = measurements_of(table, robot, imu_link)
        simulated = m.cop_true is not None or any(c.startswith("true_tau_") for c in table.names())
        rep.simulated = rep.simulated or simulated
        bad = outside_limits(robot, m.q)
        if bad is not None:
            if not rep.limits:
                rep.first_limit_at = m.cell(bad.row, _joint_column(table, bad.joint))
            rep.limits.append((rep.n_poses, bad))
        _count_missing(rep, table, m)
        rep.n_poses += m.n
        if bad is not None and not (allow_outside_limits or rep.simulated):
            raise DataError(
                f"{rep.limit_message()}; degrees in a radian column, or another "
                "robot? (--allow-outside-limits accepts them)"
            )
        yield from by_support(table, robot, dataclasses.replace(m, support=stance), at)


def by_support(
    table: Table, robot: Robot, m: Measurements, given: str | None = None
) -> Iterator[Measurements]:
    """The rows of a chunk grouped by their ``support`` column (its header in any case; each
    group in file order, the groups in order of first appearance); the chunk as it is (its
    ``support``) without the column. Each row's stance passes ``sescid.stance.data_stance``
    (a frame of the model that can measure the row's kinds): an error names the row. ``given``
    (``FILE@FRAME``) must agree with the column where both name a stance."""
    column = support_column(table)
    if column is None:
        if given is not None:  # what FILE@FRAME's stance can measure
            data_stance(robot, m.support, m.kinds, given)
        yield m
        return
    if column in table.columns:  # all numbers: no frame is named so
        raise DataError(
            f"{table.path}: {table.where(0)}, column '{column}': "
            f"'{table.columns[column][0]:g}' is not a frame of the model"
        )
    names = np.array([v.strip() for v in table.text[column]])
    for name in dict.fromkeys(names.tolist()):
        rows = np.flatnonzero(names == name)

        def where(first: int = int(rows[0])) -> str:  # made only for an error (a file scan)
            return f"{table.path}: {table.where(first)}, column '{column}'"

        if not name:
            raise DataError(f"{where()} is empty (name the stance of every row, or of none)")
        part = m.take(rows)
        stance, _ = data_stance(robot, name, part.kinds, where)
        said = m.stance_on(robot).label
        if given is not None and stance.label != said:
            raise DataError(
                f"{where()} says '{stance.label}', but {given} names the stance '{said}': give "
                "the file without @ (its column says each row's stance) or fix the column"
            )
        yield dataclasses.replace(part, support=stance)


def _count_missing(rep: ReadReport, table: Table, m: Measurements) -> None:
    """Add the chunk's empty or null CoP cells (in the cop_x/cop_y columns it has) to ``rep``."""
    if m.cop is None:
        return
    has = np.array([c in table.names() for c in ("cop_x", "cop_y")])
    miss = np.isnan(m.cop) & has
    count = int(np.count_nonzero(miss))
    if count and not rep.cop_missing:
        i, j = np.argwhere(miss)[0]
        rep.first_missing_at = m.cell(int(i), f"cop_{'xy'[int(j)]}")
    rep.cop_missing += count


def _joint_column(table: Table, joint: str) -> str:
    """The column a joint's angle was read from (``<j>``, ``<j>_deg`` or ``<j>_ticks``)."""
    for name in (joint, f"{joint}_deg", f"{joint}_ticks"):
        if name in table.names():
            return name
    return joint


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
