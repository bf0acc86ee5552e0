"""The guided session: next-best pose, command the robot, measure, update, stop when converged.

``loop`` runs it (``run_session``) with its records (``records``: options, steps, result,
observer), its candidates and design for the kinds the robot reports (``design``: the CoP, joint
torques or both; standing or held in a gantry) and its estimate (``estimate``); ``journal``
writes every pose to disk as it is done and resumes an interrupted session; ``adapters`` is the
small protocol a session drives, the replay of a recorded log and a user's Python class;
``bench_adapters`` the benches as robots (rigid statics, MuJoCo).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sescid.base.lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover - for type checkers; at run time: _EXPORTS
    from sescid.session.adapters import ReplayAdapter, RobotAdapter, load_adapter_class
    from sescid.session.bench_adapters import KinematicAdapter, MujocoAdapter
    from sescid.session.design import SESSION_KINDS, SessionDesign, session_mount
    from sescid.session.estimate import BatchEstimate, CopEstimate
    from sescid.session.journal import JOURNAL_NAME, Journal
    from sescid.session.loop import check_options, run_session
    from sescid.session.records import (
        SessionObserver,
        SessionOptions,
        SessionResult,
        SessionStep,
    )

__all__ = [
    "JOURNAL_NAME",
    "SESSION_KINDS",
    "BatchEstimate",
    "CopEstimate",
    "SessionDesign",
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

#: public name → the module that defines it, imported on first use (``base.lazy``)
_EXPORTS = {
    "BatchEstimate": "sescid.session.estimate",
    "CopEstimate": "sescid.session.estimate",
    "JOURNAL_NAME": "sescid.session.journal",
    "Journal": "sescid.session.journal",
    "KinematicAdapter": "sescid.session.bench_adapters",
    "MujocoAdapter": "sescid.session.bench_adapters",
    "ReplayAdapter": "sescid.session.adapters",
    "RobotAdapter": "sescid.session.adapters",
    "SESSION_KINDS": "sescid.session.design",
    "SessionDesign": "sescid.session.design",
    "SessionObserver": "sescid.session.records",
    "SessionOptions": "sescid.session.records",
    "SessionResult": "sescid.session.records",
    "SessionStep": "sescid.session.records",
    "check_options": "sescid.session.loop",
    "load_adapter_class": "sescid.session.adapters",
    "run_session": "sescid.session.loop",
    "session_mount": "sescid.session.design",
}
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
