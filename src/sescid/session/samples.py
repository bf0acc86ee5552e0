"""What a session's adapter hands over, checked: a pose's sample columns, the raw-log table they
make (errors naming the source, the pose and the sample), the adapter's own exceptions as one
error naming the pose, and what the journal keeps for a resume."""

from __future__ import annotations

import contextlib

import numpy as np

from sescid.base.text import listed
from sescid.errors import DataError, SescidError
from sescid.robot import Robot
from sescid.sensors import RawLog, SensorConfig, read_log, table_from_columns
from sescid.session.journal import Journal
from sescid.tables import Table


def raw_table(cols: dict[str, np.ndarray], source: str = "session raw log") -> Table:
    """In-memory raw-log table (as ``read_table`` gives it: numbers as float, text as text);
    errors name ``source`` (the adapter or the journal), the pose and the sample."""
    pose, sample = cols.get("pose"), cols.get("sample")

    def label(i: int) -> str:
        k = sample[i] if sample is not None else i
        return f"pose {pose[i]}, sample {k}" if pose is not None else f"sample {k}"

    return table_from_columns(cols, source, label)


def raw_log(
    robot: Robot, cols: dict[str, np.ndarray], sensors: SensorConfig, source: str
) -> RawLog:
    """The raw log of these columns as ``sescid measure`` reads it (IMU gravity included)."""
    return read_log(robot, raw_table(cols, source), sensors)


def pose_columns(where: str, cols, names: list[str] | None) -> dict[str, np.ndarray]:
    """A pose's columns from the adapter as arrays of one value per sample, all of one length
    ≥ 1 and, after the first pose (``names``), the same columns; a DataError naming ``where``
    (the source and the pose) otherwise."""
    if not cols:
        raise DataError(f"{where}: read() returned no columns")
    arrays = {str(c): np.asarray(v) for c, v in cols.items()}
    bad = next((c for c, v in arrays.items() if v.ndim != 1), None)
    if bad is not None:
        raise DataError(f"{where}: column '{bad}' is not one value per sample")
    lengths = {c: len(v) for c, v in arrays.items()}
    if len(set(lengths.values())) != 1:
        values = list(lengths.values())
        common = max(set(values), key=values.count)
        odd = [f"'{c}' has {k}" for c, k in lengths.items() if k != common]
        raise DataError(
            f"{where}: the columns differ in length ({listed(odd, first=4)}; "
            f"the others {common} samples)"
        )
    if names is not None and set(arrays) != set(names):
        gone = sorted(set(names) - set(arrays))
        new = sorted(set(arrays) - set(names))
        raise DataError(
            f"{where}: the columns changed since the first pose (missing {gone or 'none'}, "
            f"new {new or 'none'})"
        )
    if next(iter(lengths.values())) == 0:
        raise DataError(f"{where}: read() returned no samples")
    return arrays


@contextlib.contextmanager
def adapter_call(bot, pose: str, journal: Journal | None, what: str = ""):
    """An adapter's own exception (a servo error, a bug in the user's class) as one
    DataError naming the pose; the journal keeps the poses measured before it."""
    try:
        yield
    except (SescidError, KeyboardInterrupt):
        raise
    except Exception as exc:
        live = getattr(bot, "live", bot)
        name = type(live).__name__
        at = f"at pose {pose}" if pose else f"in {what}()"
        raise DataError(
            f"the robot adapter {name} failed {at}: {type(exc).__name__}: {exc}{_kept(journal)}"
        ) from None


@contextlib.contextmanager
def kept_on_error(journal: Journal | None):
    """A pose's data error, saying what the journal keeps for a resume."""
    try:
        yield
    except DataError as exc:
        kept = _kept(journal)
        if not kept:
            raise
        raise DataError(f"{exc}{kept}") from None


def _kept(journal: Journal | None) -> str:
    """'; JOURNAL keeps the N poses …' when the journal holds poses to resume from."""
    n = 0 if journal is None else len(journal.entries)
    if not n:
        return ""
    assert journal is not None
    return (
        f"; {journal.path} keeps the {n} poses journaled before it: run the same command "
        "again to resume"
    )


def read_samples(cols, n: int) -> dict[str, np.ndarray]:
    """The adapter's ``read`` result as columns (DataError when it is not a mapping)."""
    if not hasattr(cols, "items"):
        raise DataError(f"read({n}) returned {type(cols).__name__}, not columns by name")
    return dict(cols)


def samples_source(bot, journal: Journal | None) -> str:
    """Where a pose's samples come from, for the reader's errors: the journal (a resumed
    pose) or the adapter."""
    if journal is not None and getattr(bot, "replaying", False):
        return str(journal.path)
    live = getattr(bot, "live", bot)
    return f"adapter {type(live).__name__}"
