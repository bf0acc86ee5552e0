"""A raw log reduced in chunks (``sescid measure`` on a file): flat memory for any length.

The log is read chunk by chunk (the caller's reader: ``tables.iter_table`` of a file); each chunk
is parsed (``read_log``) and its poses reduced (``measure``) as soon as all their samples are
in: the samples of the pose that ends a chunk wait for the next one. The result is the
whole-log reduction's, pose for pose, wherever every pose's samples are consecutive in the log
(as a bench, a bag or a session writes them); a log that comes back to a pose after others is
reduced whole, in memory (``reduce.fsr`` of the caller's whole table). Whether the foot sensors
give the CoP is a property of the whole log (a log with torques whose feet carry no load
anywhere is a gantry's): decided by the first chunk with a loaded foot; chunks reduced on
torques alone before such a chunk are reduced again.

What differs from reading the whole file first: an error in the data is raised at the first
chunk that has one (a later chunk's error of another kind is not reached), and a foot
sensor's reversed sign is judged on the chunk's samples.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

from sescid.errors import DataError
from sescid.robot import Robot
from sescid.sensors.feet import PadWatch
from sescid.sensors.measured import Measured, concat_measured
from sescid.sensors.pads import SensorConfig
from sescid.sensors.raw import RawLog
from sescid.sensors.reduce import (
    LogPart,
    check_pose_ids,
    finish_measured,
    fsr,
    measure,
    pose_list_ids,
    read_log,
    usable,
    uses_feet,
)
from sescid.stance import support_column
from sescid.tables import SUPPORT_COLUMN, Table

#: raw-log fields with one row per sample
_ROWS = ("pose", "q", "gravity", "tau", "approach")
#: raw-log fields that map a foot to an array with one row per sample (or None)
_FEET = ("forces", "centroid", "cop", "cop_force")


class _Revisited(Exception):
    """A pose's samples are not consecutive: the log is reduced whole."""


class _Loaded(Exception):
    """A chunk has a loaded foot after chunks reduced on torques alone."""


def _take(log: RawLog, start: int, stop: int | None = None) -> RawLog:
    """Samples ``start:stop`` of a raw log (their file rows kept)."""
    sl = slice(start, stop)
    rows: dict[str, Any] = {
        f: None if getattr(log, f) is None else getattr(log, f)[sl] for f in _ROWS
    }
    feet: dict[str, Any] = {
        f: {k: None if v is None else v[sl] for k, v in getattr(log, f).items()} for f in _FEET
    }
    names = dataclasses.replace(log.rows, first_row=log.rows.first_row + start)
    return dataclasses.replace(log, **rows, **feet, rows=names)


def _join(a: RawLog, b: RawLog) -> RawLog:
    """Consecutive samples ``a`` then ``b`` of one log as one raw log."""

    def cat(x, y):
        return None if x is None or y is None else np.concatenate([x, y])

    rows: dict[str, Any] = {f: cat(getattr(a, f), getattr(b, f)) for f in _ROWS}
    feet: dict[str, Any] = {
        f: {k: cat(v, getattr(b, f).get(k)) for k, v in getattr(a, f).items()} for f in _FEET
    }
    return dataclasses.replace(a, **rows, **feet)


def _reduce(robot: Robot, chunks, config, min_samples, imu_link, feet: bool | None):
    """The reduction chunk by chunk, the pose ids in the log's order and the log's name.
    ``feet``: the whole log's answer when known (None: from the chunks, raising ``_Loaded`` if
    it changes)."""
    parts: list[Measured] = []
    where = "the log"
    seen: dict[str, None] = {}  # pose ids reduced, in the log's order
    carry: RawLog | None = None
    decided = feet
    pads = PadWatch(config) if config is not None else None  # judged over the whole log

    def reduce(log: RawLog) -> None:
        ids = dict.fromkeys(log.pose.tolist())
        if any(i in seen for i in ids):
            raise _Revisited
        seen.update(ids)
        parts.append(
            measure(robot, log, config, min_samples, LogPart(decided, finish=False, pads=pads))
        )

    for table in chunks:
        log = read_log(robot, table, config, imu_link)
        where = str(log.path)
        del table
        if decided is None:  # the first chunk: a False may change (torques, unloaded feet)
            decided = uses_feet(log, config)
        elif decided is False and feet is None and uses_feet(log, config):
            raise _Loaded
        if carry is not None:
            log = _join(carry, log)
        other = np.flatnonzero(log.pose != log.pose[-1]) if len(log.pose) else np.array([])
        start = int(other[-1]) + 1 if other.size else 0
        if start:
            reduce(_take(log, 0, start))
        carry = _take(log, start)
    if carry is not None and len(carry.pose):
        reduce(carry)
    if pads is not None:
        pads.check(where)
    return parts, list(seen), where


def fsr_chunks(
    robot: Robot,
    chunks: Callable[[], Iterable[Table]],
    config: SensorConfig | None,
    min_samples: int = 5,
    pose_list: Table | None = None,
    imu_link: str | None = None,
    *,
    whole: Callable[[], Table],
) -> tuple[Measured, list[str]]:
    """``reduce.fsr`` of a raw log read in chunks (module docstring): ``chunks()`` gives the
    log's tables in order (each call from the start), ``whole()`` the log as one table (for a
    log whose poses are not consecutive)."""
    try:
        try:
            parts, ids, where = _reduce(robot, chunks(), config, min_samples, imu_link, None)
        except _Loaded:
            parts, ids, where = _reduce(robot, chunks(), config, min_samples, imu_link, True)
    except _Revisited:
        return fsr(robot, whole(), config, min_samples, pose_list, imu_link)
    unmeasured: list[str] = []
    if pose_list is not None:
        unmeasured = check_pose_ids(np.array(ids), pose_list_ids(pose_list), where)
    return usable(finish_measured(concat_measured(parts)) if parts else None, where), unmeasured


def _rows(table: Table, keep: np.ndarray) -> Table:
    """The rows ``keep`` (indices) of a table; errors still name the file's own rows."""
    names = table.rows  # not table.where: the rows' names without the whole table's columns
    return Table(
        table.path,
        {k: v[keep] for k, v in table.columns.items()},
        {k: [v[i] for i in keep] for k, v in table.text.items()},
        label=lambda i: names(keep[i]),
    )


def _stance_rows(table: Table, stance: str) -> Table:
    """The samples of one stance (its ``support`` column stripped)."""
    column = support_column(table) or SUPPORT_COLUMN
    labels = np.array([v.strip() for v in table.text[column]])
    return _rows(table, np.flatnonzero(labels == stance))


def fsr_stances(
    robots: dict[str, Any],
    chunks: Callable[[], Iterable[Table]],
    config: SensorConfig | None,
    min_samples: int = 5,
    pose_list: Table | None = None,
    imu_link: str | None = None,
    *,
    whole: Callable[[], Table],
) -> tuple[Measured, list[str], np.ndarray]:
    """``fsr_chunks`` of a log of several stances (its ``support`` column): each stance's
    samples reduced with its robot (``robots``: stance → robot, in output order), so each pose's
    CoP, gravity and torques are in its stance's frame. Returns the poses of all stances, the
    pose list's unmeasured ids and each pose's stance (k,)."""
    parts: list[Measured] = []
    labels: list[np.ndarray] = []
    for stance, robot in robots.items():

        def part(stance: str = stance) -> Iterable[Table]:
            for table in chunks():
                sub = _stance_rows(table, stance)
                if sub.n:
                    yield sub

        def whole_part(stance: str = stance) -> Table:
            return _stance_rows(whole(), stance)

        try:
            res, _ = fsr_chunks(robot, part, config, min_samples, None, imu_link, whole=whole_part)
        except DataError as exc:
            raise DataError(f"{exc} (stance {stance})") from None
        parts.append(res)
        labels.append(np.full(len(res.pose), stance))
    res = concat_measured(parts)
    unmeasured: list[str] = []
    if pose_list is not None:
        ids = np.array([*res.pose.tolist(), *(p for p, _ in res.dropped)])
        first = next(iter(chunks()), None)
        where = str(first.path) if first is not None else "the log"
        unmeasured = check_pose_ids(ids, pose_list_ids(pose_list), where)
    return res, unmeasured, np.concatenate(labels)
