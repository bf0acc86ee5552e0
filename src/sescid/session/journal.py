"""A session's journal: every commanded pose written to disk as it is done, so nothing is lost.

``OUT_DIR/journal.jsonl`` holds one JSON object per line: a header (format, robot, support,
the session's options and the adapter), then one record per commanded pose (its decision, its
status and reason and, when measured, the raw samples the adapter returned), flushed and synced
before the next pose is commanded; a last line marks the end. The folder is checked writable
before the first pose (``Journal.open`` writes the header there).

Resume: running a session again with the same output folder and the same options replays the
journaled poses (the decisions depend only on the options and the measurements, so they come
out the same) and continues with the robot from the first pose not journaled; a finished
session (its outputs written: ``finish``) replays to the same end without moving the robot. A
journal of other settings is refused in one line saying what to do.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sescid.errors import DataError
from sescid.estimation.result.records import json_ready

JOURNAL_FORMAT = "sescid-session-journal/1"
JOURNAL_NAME = "journal.jsonl"


@dataclass(frozen=True)
class JournalEntry:
    """One journaled pose: what was commanded and what the robot returned."""

    pose: str
    q: np.ndarray  #: (nq,) commanded, rad
    why: str  #: "" when it settled, else why it failed
    columns: dict[str, np.ndarray] | None  #: the adapter's samples (None: not read)
    line: int = 0  #: the journal's line of this record (0: not read from a file)


@dataclass
class Journal:
    """The append-only journal of one output folder."""

    path: Path
    header: dict
    entries: list[JournalEntry] = field(default_factory=list)
    finished: str = ""  #: the stop reason of a finished session ("" while open)
    created_folder: bool = False  #: the output folder was made for this journal

    @classmethod
    def open(
        cls,
        out_dir: str | Path,
        header: dict,
        *,
        restart: bool = False,
        defaults: dict | None = None,
    ) -> Journal:
        """The folder's journal: resumed when it holds this session's poses (same header), a
        new one otherwise; DataError when the folder is not writable or holds another session
        (``restart`` discards it instead). ``defaults``: the options' default values, which a
        journal written before an option existed is read as having (so it still resumes). A
        last line cut by a crash is cut off the file, so the next record starts on a line of
        its own."""
        folder = Path(out_dir)
        created = not folder.exists()
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise DataError(f"{folder}: cannot create the output folder ({exc.strerror})") from None
        path = folder / JOURNAL_NAME
        head = json_ready(header) | {"format": JOURNAL_FORMAT}
        if path.exists() and not restart:
            old, complete = cls._read(path)
            if old.entries or old.finished:  # else nothing was measured: start afresh
                was = old.header
                if defaults is not None and isinstance(was.get("options"), dict):
                    was = was | {"options": json_ready(defaults) | was["options"]}
                if was != head:
                    diff = sorted(k for k in head if was.get(k) != head.get(k))
                    raise DataError(
                        f"{path}: the folder holds a session with other settings "
                        f"({', '.join(diff)}): run with the same ones to resume it, or choose "
                        "another --out-dir (--force starts over)"
                    )
                if complete < path.stat().st_size:
                    _cut(path, complete)
                return old
        journal = cls(path, head)
        journal.created_folder = created
        journal._write(head, "w")
        return journal

    def discard_if_empty(self) -> None:
        """Remove a journal that holds no pose (a session that failed before measuring one),
        and its folder when the session created it and nothing else is in it."""
        if self.entries or self.finished or not self.path.exists():
            return
        try:
            self.path.unlink()
            if self.created_folder and not any(self.path.parent.iterdir()):
                self.path.parent.rmdir()
        except OSError:
            pass

    @classmethod
    def _read(cls, path: Path) -> tuple[Journal, int]:
        """The journal of a file and the byte length of its complete lines (a last line cut
        by a crash is left out: its pose is measured again)."""
        not_journal = f"{path}: not a session journal (--force starts over)"
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise DataError(f"{path}: cannot read the session journal ({exc.strerror})") from None
        lines = data.split(b"\n")
        complete = len(data) - len(lines[-1])  # bytes up to the last newline
        tail = lines.pop()  # b"" when the file ends with a newline
        records: list[tuple[int, Any]] = []
        for i, raw in enumerate(lines, start=1):
            try:
                records.append((i, json.loads(raw.decode("utf-8"))))
            except (UnicodeDecodeError, json.JSONDecodeError):
                if i == 1:
                    raise DataError(not_journal) from None
                raise DataError(
                    f"{path}: line {i} is not a journal record (a damaged journal; --force "
                    "starts over)"
                ) from None
        if not records:
            try:
                records.append((1, json.loads(tail.decode("utf-8"))))
            except (UnicodeDecodeError, json.JSONDecodeError):
                raise DataError(not_journal) from None
        head = records[0][1]
        if not isinstance(head, dict) or head.get("format") != JOURNAL_FORMAT:
            raise DataError(not_journal)
        journal = cls(path, head)
        for i, rec in records[1:]:
            if isinstance(rec, dict) and "end" in rec:
                journal.finished = str(rec["end"])
                continue
            journal.entries.append(_entry(path, i, rec))
        return journal, complete

    def append(self, entry: JournalEntry) -> None:
        """Write one pose's record (synced to disk before the session goes on)."""
        rec = {"pose": entry.pose, "q": json_ready(entry.q), "why": entry.why}
        if entry.columns is not None:
            rec["columns"] = json_ready(entry.columns)
        self._write(rec)
        self.entries.append(entry)

    def finish(self, stop_reason: str) -> None:
        """Mark the session finished (call it once its outputs are written)."""
        self._write({"end": stop_reason})
        self.finished = stop_reason

    def _write(self, rec: dict, mode: str = "a") -> None:
        """Write one record as a line (``mode`` "w": the header of a new file), synced."""
        try:
            with open(self.path, mode) as fh:
                fh.write(json.dumps(rec) + "\n")
                fh.flush()
                os.fsync(fh.fileno())
        except OSError as exc:
            raise DataError(
                f"{self.path}: cannot write the session journal ({exc.strerror})"
            ) from None


def _cut(path: Path, size: int) -> None:
    """Cut a crash's incomplete last line off the journal (synced)."""
    try:
        with open(path, "r+b") as fh:
            fh.truncate(size)
            fh.flush()
            os.fsync(fh.fileno())
    except OSError as exc:
        raise DataError(f"{path}: cannot repair the session journal ({exc.strerror})") from None


def _entry(path: Path, line: int, rec: Any) -> JournalEntry:
    """One pose record, checked: DataError naming the journal line for a damaged one."""
    where = f"{path}: line {line}"
    damaged = "a damaged journal; --force starts over"
    if not isinstance(rec, dict):
        raise DataError(f"{where}: not a pose record ({damaged})")
    missing = [k for k in ("pose", "q") if k not in rec]
    if missing:
        raise DataError(f"{where}: the pose record has no '{missing[0]}' ({damaged})")
    try:
        q = np.asarray(rec["q"], dtype=float)
    except (TypeError, ValueError):
        q = np.zeros(0)
    if q.ndim != 1 or q.size == 0 or not np.all(np.isfinite(q)):
        raise DataError(f"{where}: 'q' is not a list of joint angles ({damaged})")
    cols = rec.get("columns")
    if cols is not None and not (
        isinstance(cols, dict) and all(isinstance(v, list) for v in cols.values())
    ):
        raise DataError(f"{where}: 'columns' is not a table of samples ({damaged})")
    columns: dict[str, np.ndarray] | None = None
    if cols is not None:
        columns = {}
        for k, v in cols.items():
            arr = _column(v)
            if arr is None:
                raise DataError(f"{where}: column '{k}' is not a list of samples ({damaged})")
            columns[k] = arr
    return JournalEntry(str(rec["pose"]), q, str(rec.get("why", "")), columns, line)


def _column(v: list) -> np.ndarray | None:
    """A journaled column as an array (null → NaN; text stays text for the reader to name);
    None when it is not a flat list of numbers or texts."""
    if any(isinstance(x, list | dict) for x in v):
        return None
    arr = np.array([np.nan if x is None else x for x in v])
    if arr.dtype == object:
        try:
            return arr.astype(float)
        except (TypeError, ValueError):
            return arr.astype(str)
    return arr


class ResumingAdapter:
    """Serves the journaled poses, in order, then hands over to the live robot adapter."""

    def __init__(self, journal: Journal, live):
        self.journal = journal
        self.live = live
        self.resumed = len(journal.entries)  #: poses the journal held at the start
        self.done = 0  #: journaled poses served
        self._entry: JournalEntry | None = None
        self._stance: tuple[str, str] | None = None  #: the stance asked last (over stances)
        self._told: tuple[str, str] | None = None  #: the stance the live robot was told

    def change_stance(self, support: str, mount: str) -> None:
        """Remembered while journaled poses replay; the live robot is told when it takes over."""
        self._stance = (support, mount)
        if self.done >= self.resumed:
            self._tell()

    def _tell(self) -> None:
        if self._stance is not None and self._stance != self._told:
            self.live.change_stance(*self._stance)
            self._told = self._stance

    @property
    def replaying(self) -> bool:
        """True while the current pose comes from the journal."""
        return self._entry is not None

    def move(self, pose: str, q: np.ndarray) -> None:
        """The journaled pose (checked to be this command), else the live robot's move."""
        if self.done < self.resumed:
            e = self.journal.entries[self.done]
            q = np.asarray(q, dtype=float)
            if e.pose != pose or e.q.shape != q.shape or np.max(np.abs(e.q - q)) > 1e-9:
                raise DataError(
                    f"{self.journal.path}: resuming diverged at pose {pose} (the journal "
                    f"commanded pose {e.pose} there): another robot model or sensor file? "
                    "(--force starts over)"
                )
            self._entry = e
            self.done += 1
            return
        self._entry = None
        self._tell()
        self.live.move(pose, q)

    def wait_settled(self) -> str:
        """See ``RobotAdapter.wait_settled``."""
        return self._entry.why if self._entry is not None else self.live.wait_settled()

    def read(self, n: int) -> dict[str, np.ndarray]:
        """See ``RobotAdapter.read``."""
        if self._entry is not None:
            if self._entry.columns is None:
                raise DataError(f"{self.journal.path}: pose {self._entry.pose} has no samples")
            return self._entry.columns
        return self.live.read(n)

    def stop(self) -> None:
        """See ``RobotAdapter.stop``."""
        self.live.stop()
