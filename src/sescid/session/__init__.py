"""The guided session: next-best pose, command the robot, measure, update, stop when converged.

``loop`` runs it (``run_session``); ``adapters`` is the small protocol a session drives and the
robots it ships with (MuJoCo bench, replay of a recorded log, a user's Python class).
"""

from __future__ import annotations

from sescid.session.adapters import MujocoAdapter, ReplayAdapter, RobotAdapter, load_adapter_class
from sescid.session.loop import (
    SessionObserver,
    SessionOptions,
    SessionResult,
    SessionStep,
    run_session,
)

__all__ = [
    "MujocoAdapter",
    "ReplayAdapter",
    "RobotAdapter",
    "SessionObserver",
    "SessionOptions",
    "SessionResult",
    "SessionStep",
    "load_adapter_class",
    "run_session",
]
