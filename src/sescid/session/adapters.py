"""Robot adapters for a guided session: the small protocol a session drives, and three of them.

A session talks to a robot through four calls (``RobotAdapter``):

``move(pose, q)``
    command the joint angles ``q`` (nq,) [rad, the model's joint order and servo convention]
    for the pose id ``pose`` (a string); returns at once or when the motion is done.
``wait_settled() -> str``
    block until the robot is still; ``""`` when it settled, else why the pose failed
    ("toppled …", "did not settle …"): the session skips the pose and logs the reason.
``read(n) -> dict[str, ndarray]``
    ``n`` samples of the raw-log columns of ``sescid fsr`` (joint read-backs as ``<joint>``,
    ``<joint>_deg`` or ``<joint>_ticks``; foot forces ``r_fsr1..4``/``l_fsr1..4``, centroid
    registers or a logged CoP per foot; optional ``grav_x/y/z``), each of length ``n``, without
    the ``pose`` and ``sample`` columns (the session adds them). Every call returns the same
    column names.
``stop()``
    release the robot (end of the session, or an error).

The session checks joint limits and static stability of the model before every ``move``.

Adapters here: ``MujocoAdapter`` (the physics bench, one MjModel/MjData kept across poses),
``ReplayAdapter`` (a recorded raw log: replays a session's measurements, so the session makes
the same decisions), and ``load_adapter_class`` for a user's class (``module:Class`` or
``path/to/file.py:Class``, constructed as ``Class(robot)``).
"""

from __future__ import annotations

import importlib
import importlib.util
import math
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from sescid.base.columns import Table, pose_ids, read_poses
from sescid.bench.kinematic import ExperimentConfig, real_robot
from sescid.errors import DataError, OptionError
from sescid.sensors.pads import SensorConfig

#: rad, a replayed command must equal the recorded one to this
REPLAY_TOL = 1e-9


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


class MujocoAdapter:
    """The MuJoCo physics bench as a robot: the "real" OP2 of ``ExperimentConfig`` in MuJoCo.

    ``move`` sets the servo targets (the command plus the pose's backlash offset δ ~ U(−b, b));
    ``wait_settled`` starts at rest at the targets and simulates until still
    (``mujoco_bench._Bench.run``: toppled, floor contact and not settled are failures); ``read``
    logs samples as ``run_mujoco_experiment`` does (read-back ticks missing the unseen part of
    δ, pad forces in mN with bias and noise, gravity direction). ``truth`` keeps per measured
    pose the actual angles and the true CoP ``robot.cop(q_actual, r_true)``.
    """

    def __init__(
        self,
        robot,
        sensors: SensorConfig,
        config: ExperimentConfig | None = None,
        bench=None,
        seed: int | None = 0,
    ):
        from sescid.bench.mujoco import MujocoBenchConfig, _Bench

        self.robot = robot
        self.sensors = sensors
        self.config = config or ExperimentConfig()
        self.bench = bench or MujocoBenchConfig()
        if self.bench.weld_foot:
            raise OptionError("weld_foot", "a session stands the robot on its foot (no weld)")
        self.sim = _Bench(robot, sensors, self.config, self.bench)
        self.rng = np.random.default_rng(seed)
        self.bias = {
            f.name: self.rng.normal(0.0, self.config.fsr_bias, size=4) for f in sensors.feet
        }
        self.r_true, self.mass_true, _ = real_robot(robot, self.config)
        self.truth: dict[str, dict[str, Any]] = {}
        self._pose = ""
        self._delta = np.zeros(robot.nq)
        self._target = np.zeros(robot.nq)
        self._settled = False

    def move(self, pose: str, q: np.ndarray) -> None:
        """See ``RobotAdapter.move``."""
        b = math.radians(self.config.backlash_deg)
        self._pose = pose
        self._delta = self.rng.uniform(-b, b, size=self.robot.nq)
        self._target = np.asarray(q, dtype=float) + self._delta
        self._settled = False

    def wait_settled(self) -> str:
        """See ``RobotAdapter.wait_settled``."""
        res, why = self.sim.run(self._target)
        self._settled = res is not None
        if res is not None:
            self.truth[self._pose] = {
                "q_actual": res.q,
                "cop_true": self.robot.cop(res.q[None], self.r_true)[0],
                "com_world": res.com,
            }
        return why

    def read(self, n: int) -> dict[str, np.ndarray]:
        """See ``RobotAdapter.read``."""
        if not self._settled:
            raise DataError(f"pose {self._pose}: read before the robot settled")
        cfg, robot, rng = self.config, self.robot, self.rng
        reads = [self.sim.sample() for _ in range(n)]
        cols: dict[str, np.ndarray] = {}
        q = np.array([r.q for r in reads]) - (1.0 - cfg.readback_seen) * self._delta
        servo = robot.profile.servo
        if servo is not None:
            exact = q * (servo.ticks_per_turn / (2 * math.pi)) + servo.zero_tick
            ticks = exact + rng.normal(0.0, cfg.readback_jitter_ticks, size=q.shape)
            ticks = np.clip(np.round(ticks), 0, servo.max_tick)
            cols |= {f"{j}_ticks": ticks[:, k] for k, j in enumerate(robot.joint_names)}
        else:
            cols |= {j: q[:, k] for k, j in enumerate(robot.joint_names)}
        s = self.sensors
        for f in s.feet:
            true = np.array([r.pads[f.name] for r in reads])
            noisy = true + self.bias[f.name] + rng.normal(0.0, cfg.fsr_noise, size=true.shape)
            counts = np.clip(np.round(noisy / s.force_unit), 0, s.saturation)
            counts = np.where(true > 0, counts, 0.0)  # an unloaded FSR conducts nothing
            cols |= {f"{f.columns}{k + 1}": counts[:, k] for k in range(4)}
        g = -np.array([r.rot[2] for r in reads])  # gravity direction in the sole frame
        cols |= {f"grav_{a}": g[:, i] for i, a in enumerate("xyz")}
        return cols

    def stop(self) -> None:
        """See ``RobotAdapter.stop``."""
        self._settled = False


class ReplayAdapter:
    """Replays a recorded raw log: each pose id gets its recorded samples.

    ``poses`` (the recorded session's pose list, optional) makes every command checked against
    the recorded one: a session that would command something else raises ``DataError`` (its
    decisions diverged). A pose id absent from the log is reported as failed, with the recorded
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
        skip = {"pose", "sample"}
        self.columns = {k: v for k, v in raw.columns.items() if k not in skip}
        self.text = {k: np.asarray(v) for k, v in raw.text.items() if k not in skip}
        self.commanded: dict[str, np.ndarray] = {}
        if poses is not None:
            q = read_poses(poses, joint_names, servo)
            pids = pose_ids(poses) if "pose" in poses.names() else np.arange(len(q)).astype(str)
            self.commanded = {str(p): q[i] for i, p in enumerate(pids)}
        self.reasons = dict(reasons or {})  #: pose → why it failed when recorded
        self._pose = ""

    def move(self, pose: str, q: np.ndarray) -> None:
        """See ``RobotAdapter.move``."""
        rec = self.commanded.get(pose)
        if rec is not None:
            dev = float(np.max(np.abs(rec - np.asarray(q, dtype=float))))
            if dev > REPLAY_TOL:
                raise DataError(
                    f"{self.path}: replay diverged at pose {pose}: the session commands a pose "
                    f"that differs from the recorded one by up to {math.degrees(dev):.3g}° "
                    "(different options or robot?)"
                )
        elif self.commanded:
            raise DataError(f"{self.path}: replay diverged: pose {pose} was never recorded")
        self._pose = pose

    def wait_settled(self) -> str:
        """See ``RobotAdapter.wait_settled``."""
        if self._pose not in self.rows:
            return self.reasons.get(self._pose, "not in the recorded log (it failed when recorded)")
        return ""

    def read(self, n: int) -> dict[str, np.ndarray]:
        """See ``RobotAdapter.read``."""
        rows = self.rows[self._pose]
        out: dict[str, np.ndarray] = {k: v[rows] for k, v in self.columns.items()}
        out |= {k: v[rows] for k, v in self.text.items()}
        return out

    def stop(self) -> None:
        """See ``RobotAdapter.stop``."""
        self._pose = ""


def load_adapter_class(spec: str) -> type:
    """The class named by ``module:Class`` or ``path/to/file.py:Class``."""
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
    except ImportError as exc:
        raise OptionError("adapter", f"cannot import '{where}': {exc}") from None
    cls = getattr(module, name, None)
    if not isinstance(cls, type):
        raise OptionError("adapter", f"'{where}' has no class '{name}'")
    missing = [
        m for m in ("move", "wait_settled", "read", "stop") if not callable(getattr(cls, m, None))
    ]
    if missing:
        raise OptionError("adapter", f"{spec} lacks {', '.join(missing)} (see RobotAdapter)")
    return cls
