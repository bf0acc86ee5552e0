"""The guided session: next-best pose, command the robot, measure, update, stop when converged.

``loop`` runs it (``run_session``) with its records (``records``: options, steps, result,
observer), its candidates and design for the kinds the robot reports (``design``: the CoP, joint
torques or both; standing or held in a gantry) and its estimate (``estimate``); ``journal``
writes every pose to disk as it is done and resumes an interrupted session; ``adapters`` is the
small protocol a session drives, the replay of a recorded log and a user's Python class, and
``samples`` checks what an adapter hands over;
``bench_adapters`` the benches as robots (rigid statics, MuJoCo).
"""

from sescid.session.adapters import ReplayAdapter, RobotAdapter, load_adapter_class
from sescid.session.bench_adapters import KinematicAdapter, MujocoAdapter
from sescid.session.design import SessionDesign, session_mount
from sescid.session.estimate import BatchEstimate, CopEstimate
from sescid.session.journal import JOURNAL_NAME, Journal
from sescid.session.loop import check_options, run_session
from sescid.session.records import (
    SessionKind,
    SessionObserver,
    SessionOptions,
    SessionResult,
    SessionStep,
)

__all__ = [
    "JOURNAL_NAME",
    "BatchEstimate",
    "CopEstimate",
    "SessionDesign",
    "SessionKind",
    "Journal",
    "KinematicAdapter",
    "MujocoAdapter",
    "ReplayAdapter",
    "RobotAdapter",
    "SessionObserver",
    "SessionOptions",
    "SessionResult",
    "SessionStep",
    "check_options",
    "load_adapter_class",
    "run_session",
    "session_mount",
]
