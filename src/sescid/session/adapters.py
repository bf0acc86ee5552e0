"""Robot adapters for a guided session: the small protocol a session drives, and three of them.

A session talks to a robot through four calls (``RobotAdapter``):

``move(pose, q)``
    command the joint angles ``q`` (nq,) [rad, the model's joint order and servo convention]
    for the pose id ``pose`` (a string); returns at once or when the motion is done.
``wait_settled() -> str``
    block until the robot is still; ``""`` when it settled, else why the pose failed
    ("toppled …", "did not settle …"): the session skips the pose and logs the reason.
``read(n) -> dict[str, ndarray]``
    ``n`` samples of the raw-log columns of ``sescid measure`` (joint read-backs as ``<joint>``,
    ``<joint>_deg`` or ``<joint>_ticks``; foot forces ``r_fsr1..4``/``l_fsr1..4``, centroid
    registers or a logged CoP per foot; optional ``grav_x/y/z``, ``tau_<joint>``, ``approach``),
    each of length ``n``, without
    the ``pose`` and ``sample`` columns (the session adds them). Every call returns the same
    column names.
``stop()``
    release the robot (end of the session, or an error).
``change_stance(support, mount)`` (a session over stances only)
    put the robot in another stance before the next ``move``: standing on the sole ``support``
    (``mount`` "stand"), on both feet ("double", ``support`` the reference foot) or held in a
    gantry by the link ``support`` ("gantry"); returns when it is done (an operator's prompt,
    a fixture). The session asks for it when the change is worth its cost.

The session checks joint limits and static stability of the model before every ``move``.

Adapters: ``ReplayAdapter`` (a recorded raw log: replays a session's measurements, so the
session makes the same decisions) and ``load_adapter_class`` for a user's class
(``module:Class`` or ``path/to/file.py:Class``, constructed as ``Class(robot)``) here; the
benches as robots (``KinematicAdapter``, ``MujocoAdapter``) in ``session.bench_adapters``.
"""

from __future__ import annotations

import importlib
import importlib.util
import math
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np

from sescid.errors import DataError, OptionError
from sescid.tables import Table, pose_ids, read_joint_columns, read_poses

#: rad, a replayed command must equal the recorded one to this
REPLAY_TOL = 1e-9
#: rad, without the recorded pose list a recorded pose matches a command when its mean
#: read-backs lie this close to it in every joint (joint play, servo sag, ticks)
REPLAY_MATCH = math.radians(3.0)


@runtime_checkable
class RobotAdapter(Protocol):
    """What a guided session needs from a robot (module docstring)."""

    def move(self, pose: str, q: np.ndarray) -> None:
        """Command the joints to q (nq,) [rad] for pose id ``pose``."""

    def wait_settled(self) -> str:
        """Wait until the robot is still; "" when settled, else why not (fell, timed out)."""

    def read(self, n: int) -> dict[str, np.ndarray]:
        """``n`` samples as raw-log columns (joint read-backs, foot sensors)."""

    def stop(self) -> None:
        """Release the robot (end of session)."""


class ReplayAdapter:
    """Replays a recorded raw log: each commanded pose gets the samples recorded for it.

    With ``poses`` (the recorded session's pose list) every command is checked against the
    recorded one: a session that would command something else raises ``DataError`` (its
    decisions diverged). Without it, a recorded pose serves a command only when its mean
    read-backs lie within ``REPLAY_MATCH`` of the command in every joint — the pose with the
    command's id, else the nearest recorded pose by joint values; a pose id recorded at other
    joint values is refused (an experiment log is not a session's recording: its poses are
    unrelated). A command no recorded pose matches is reported as failed, with the recorded
    reason when ``reasons`` (pose → why, from the session's ``session.json``) has it.
    """

    def __init__(
        self,
        raw: Table,
        joint_names: list[str],
        poses: Table | None = None,
        servo=None,
        reasons: dict[str, str] | None = None,
    ):
        ids = pose_ids(raw)
        self.path = raw.path
        self.rows: dict[str, np.ndarray] = {}
        for p in dict.fromkeys(ids.tolist()):
            self.rows[p] = np.flatnonzero(ids == p)
        skip = {"pose", "sample", "support"}
        self.support = {}  #: pose → its recorded stance (the raw log's support column)
        if "support" in raw.text:
            sup = np.asarray(raw.text["support"])
            self.support = {p: str(sup[r[0]]) for p, r in self.rows.items()}
        self._stance = ""
        self.columns = {k: v for k, v in raw.columns.items() if k not in skip}
        self.text = {k: np.asarray(v) for k, v in raw.text.items() if k not in skip}
        q, _ = read_joint_columns(raw, joint_names, servo)
        with np.errstate(invalid="ignore"):
            self.readback = {p: np.nanmean(q[r], axis=0) for p, r in self.rows.items()}
        self.commanded: dict[str, np.ndarray] = {}
        if poses is not None:
            qc = read_poses(poses, joint_names, servo)
            pids = pose_ids(poses) if "pose" in poses.names() else np.arange(len(qc)).astype(str)
            self.commanded = {str(p): qc[i] for i, p in enumerate(pids)}
        self.reasons = dict(reasons or {})  #: pose → why it failed when recorded
        self._pose = ""
        self._served = ""  #: the recorded pose that serves the current command

    def change_stance(self, support: str, mount: str) -> None:
        """See the module docstring: the recorded poses of that stance serve from now on."""
        self._stance = "double" if mount == "double" else support

    def move(self, pose: str, q: np.ndarray) -> None:
        """See ``RobotAdapter.move``."""
        q = np.asarray(q, dtype=float)
        self._pose = pose
        had = self.support.get(pose)
        if had is not None and self._stance and had != self._stance:
            raise DataError(f"{self.path}: replay diverged at pose {pose}: recorded in stance "
                            f"{had}, commanded in {self._stance}")  # fmt: skip
        rec = self.commanded.get(pose)
        if rec is not None:
            dev = float(np.max(np.abs(rec - q)))
            if dev > REPLAY_TOL:
                raise DataError(
                    f"{self.path}: replay diverged at pose {pose}: the session commands a pose "
                    f"that differs from the recorded one by up to {math.degrees(dev):.3g}° "
                    "(different options or robot?)"
                )
            self._served = pose if pose in self.rows else ""
            return
        if self.commanded:
            raise DataError(f"{self.path}: replay diverged: pose {pose} was never recorded")
        self._served = self._match(pose, q)

    def _match(self, pose: str, q: np.ndarray) -> str:
        """The recorded pose whose read-backs match the command (module rule), or ''."""
        dev = {p: float(np.max(np.abs(r - q))) for p, r in self.readback.items()}
        if pose in dev:
            if not dev[pose] <= REPLAY_MATCH:
                raise DataError(
                    f"{self.path}: pose {pose} was recorded at joint values up to "
                    f"{math.degrees(dev[pose]):.1f}° from the session's command: this log is "
                    "not this session's recording (replay a session folder with its poses.csv)"
                )
            return pose
        near = [p for p, d in dev.items() if d <= REPLAY_MATCH]
        return min(near, key=lambda p: dev[p]) if near else ""

    def wait_settled(self) -> str:
        """See ``RobotAdapter.wait_settled``."""
        if not self._served:
            return self.reasons.get(self._pose, "not in the recorded log (it failed when recorded)")
        return ""

    def read(self, n: int) -> dict[str, np.ndarray]:
        """See ``RobotAdapter.read``."""
        rows = self.rows[self._served]
        out: dict[str, np.ndarray] = {k: v[rows] for k, v in self.columns.items()}
        out |= {k: v[rows] for k, v in self.text.items()}
        return out

    def stop(self) -> None:
        """See ``RobotAdapter.stop``."""
        self._pose = self._served = ""


def load_adapter_class(spec: str) -> type:
    """The class named by ``module:Class`` or ``path/to/file.py:Class``; one-line errors for a
    missing file or class and for a module that does not import (syntax errors included)."""
    where, sep, name = spec.rpartition(":")
    if not sep or not where or not name:
        raise OptionError("adapter", f"'{spec}': expected module:Class or file.py:Class")
    try:
        if where.endswith(".py"):
            path = Path(where)
            if not path.is_file():
                raise OptionError("adapter", f"{where}: no such file")
            mod_spec = importlib.util.spec_from_file_location(path.stem, path)
            assert mod_spec is not None and mod_spec.loader is not None
            module = importlib.util.module_from_spec(mod_spec)
            mod_spec.loader.exec_module(module)
        else:
            module = importlib.import_module(where)
    except SyntaxError as exc:
        raise OptionError(
            "adapter", f"{exc.filename or where}, line {exc.lineno}: {exc.msg} (SyntaxError)"
        ) from None
    except OptionError:
        raise
    except Exception as exc:  # the user's module failed at import: one line naming it
        raise OptionError(
            "adapter", f"cannot import '{where}': {exc.__class__.__name__}: {exc}"
        ) from None
    cls = getattr(module, name, None)
    if not isinstance(cls, type):
        raise OptionError("adapter", f"'{where}' has no class '{name}'")
    missing = [
        m for m in ("move", "wait_settled", "read", "stop") if not callable(getattr(cls, m, None))
    ]
    if missing:
        raise OptionError("adapter", f"{spec} lacks {', '.join(missing)} (see RobotAdapter)")
    return cls
