"""What a guided session is given and gives: options, one record per pose, the result, the
observer hooks (a terminal printer, the live view)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from sescid.base import SEED_HELP, check_ranges, option, option_like
from sescid.errors import check_choice
from sescid.estimation.result.fit import Fit
from sescid.kinds import DesignKind, parse_kinds
from sescid.planning import (
    DEFAULT_STANCE_COST,
    Candidates,
    Mount,
    PlanOptions,
    Quantity,
)
from sescid.sensors import Measured
from sescid.simulation import PAPER_NOISE

#: m, prior scale of a body's SESC components, for the per-body uncertainty shown (0..1 scale)
BODY_PRIOR_SCALE = 0.005
#: what a session chooses its poses for: a design's kinds, or "auto" (what the robot reports)
SessionKind = Literal["auto", DesignKind]
#: how a session with joint torques fits (``identify``'s method)
TorqueMethod = Literal["ls", "map"]


@dataclass(frozen=True)
class SessionOptions:
    """How a guided session plans, measures and stops (SI units, radians)."""

    budget: int = option(60, "Poses commanded at most (failed ones count).", low=1)
    samples: int = option(100, "Samples read per pose.", low=2)
    min_samples: int = option(5, "Usable samples per pose.", low=2)  #: as ``sescid measure``
    n_candidates: int = option(
        5000, "Stable, collision-free candidate poses.", low=1, flag="--candidates"
    )
    seed: int = option(0, SEED_HELP, low=0)  #: candidate sampling
    near: float = option(
        0.8,
        "Take the nearest candidate whose information gain is ≥ NEAR × the best.",
        low=0, high=1, low_open=True,
    )  # fmt: skip
    window: int = option(10, "Convergence: poses looked back.", low=1)
    tol: float = option(
        0.10,
        "Convergence: the predicted CoP std fell by less than this (relative) over the window.",
        low=0, high=1, low_open=True, high_open=True,
    )  # fmt: skip
    min_measured: int | None = None  #: at least this many measured poses (None: the rank's min)
    target_std: float | None = option(
        None, "Also stop when the predicted CoP std reaches this [m].", low=0, low_open=True
    )
    limits: np.ndarray | None = None  #: (nq, 2) sampling limits, rad (None: the robot's)
    half_extents: np.ndarray | None = None  #: (2,) CoP stability box, m (None: the profile's)
    #: decided at the first measured pose; planned for the CoP before it, joint torques when
    #: the robot is held in a gantry
    kinds: SessionKind = option(
        "auto",
        "What the next pose is chosen for: auto (what the robot reports: a loaded foot sensor "
        "gives the CoP, tau_<joint> columns the joint torques), cop, tau or both.",
    )
    cop_noise: float = option(
        PAPER_NOISE, "CoP noise per pose the design weighs CoP rows by [m].",
        low=0, low_open=True, what="a positive noise level",
    )  # fmt: skip
    tau_noise: float = option_like(PlanOptions, "tau_noise")
    mount: Mount | None = option(
        None,
        "stand: on the support foot; gantry: the support link held level, the robot hanging "
        "free (joint torques only). Default: gantry when the robot's mass splits at the "
        "support.",
    )
    hang_height: float | None = option_like(PlanOptions, "hang_height")
    allow_missing_meshes: bool = option_like(PlanOptions, "allow_missing_meshes")
    total_mass: float | None = option(
        None,
        "The robot's weighed mass [kg]: the scale of joint torques (default: the model's, "
        "with a warning in the fit).",
    )
    #: how a session with joint torques fits: "map" (the CAD prior, as ``identify --method
    #: map``) or "ls"; a CoP session fits least squares (the online estimator)
    torque_method: TorqueMethod = "map"
    #: stances to choose poses from (``planning.parse_stances``: sole frames, "double",
    #: "gantry:<link>"), two or more; empty: the support alone (``session.stances``)
    stances: tuple[str, ...] = ()
    stance_cost: float = option(
        DEFAULT_STANCE_COST,
        "Poses a stance change costs: asked for when the other stance's best information gain "
        "exceeds 1 + this times the current one's.",
        low=0,
    )

    def __post_init__(self) -> None:
        check_ranges(self)
        if self.kinds != "auto":
            parse_kinds(self.kinds, "kinds", SessionKind)
        if self.mount is not None:
            check_choice("mount", self.mount, Mount)
        check_choice("torque_method", self.torque_method, TorqueMethod)


@dataclass
class SessionStep:
    """One commanded pose: the decision, and what was measured (or why not)."""

    pose: str  #: id, "0", "1", … in command order
    candidate: int  #: index in the candidate pool
    q: np.ndarray  #: (nq,) commanded, rad
    gain: float  #: log det rise expected from this pose
    distance: float  #: rad, joint-space distance from the previous pose
    status: Literal["measured", "skipped"]
    reason: str = ""  #: why skipped
    q_measured: np.ndarray | None = None  #: (nq,) mean read-backs, rad
    cop: np.ndarray | None = None  #: (2,) measured CoP, m
    cop_se: np.ndarray | None = None  #: (2,) its standard error, m
    cop_predicted: np.ndarray | None = None  #: (2,) predicted before this pose was added, m
    #: predicted RMS std after this pose, m: of the CoP (a CoP session), else of the CoM x/y
    #: (``quantity``)
    cop_std: float = math.inf
    rank: int = 0
    converged: bool = False
    body_std: np.ndarray | None = None  #: (N,) per-body SESC std after this pose, m
    quantity: Quantity = "CoP"  #: what ``cop_std`` is the std of
    tau: np.ndarray | None = None  #: (J,) measured joint torques, N·m (sessions with torques)
    stance: str = ""  #: the pose's stance (``Stance.label``; "" without stances)


@dataclass
class SessionResult:
    """What a session did and found; ``raw`` and ``poses`` are the files' columns."""

    steps: list[SessionStep]
    stop_reason: str
    fit: Fit
    measured: Measured
    raw: dict[str, np.ndarray]  #: the raw log (pose, sample, the adapter's columns)
    poses: np.ndarray  #: (k, nq) commanded poses, rad, in command order
    pose_ids: np.ndarray  #: (k,) their ids
    candidates: Candidates
    options: SessionOptions
    body_names: list[str] = field(default_factory=list)
    #: (candidate, why) chosen but found unsafe before commanding (not counted in the budget)
    rejected: list[tuple[int, str]] = field(default_factory=list)
    #: over stances: the pooled body parameters θ [kg, kg·m] and their standard deviations
    #: (``session.stances.PooledEstimate``); None in one stance
    pooled: tuple[np.ndarray, np.ndarray] | None = None
    stances: tuple = ()  #: the session's stances (``planning.Stance``; empty in one stance)

    @property
    def n_measured(self) -> int:
        """Poses measured (not skipped)."""
        return sum(s.status == "measured" for s in self.steps)

    @property
    def cop_std(self) -> float:
        """Predicted RMS std at the end, m: of the CoP, or of the CoM x/y (``quantity``)."""
        done = [s.cop_std for s in self.steps if s.status == "measured"]
        return done[-1] if done else math.inf

    @property
    def quantity(self) -> Quantity:
        """What ``cop_std`` is the std of: "CoP" or "CoM x/y" (a session with torques)."""
        done = [s.quantity for s in self.steps if s.status == "measured"]
        return done[-1] if done else "CoP"

    @property
    def kinds(self) -> tuple[str, ...]:
        """The measurement kinds the session used ("cop", "tau")."""
        return tuple(k.kind for k in self.fit.kinds)


class SessionObserver:
    """Hooks a session calls (all optional to override): a terminal printer, a live view."""

    def planned(self, step_no: int, pose: str, q: np.ndarray, q_current: np.ndarray) -> None:
        """The next pose was chosen (before it is commanded)."""

    def finished_pose(self, step: SessionStep, steps: list[SessionStep]) -> None:
        """A pose was measured or skipped."""

    def stance(self, step_no: int, label: str, describe: str) -> None:
        """The session asks for a stance change before pose ``step_no`` (over stances)."""

    def stopped(self, result: SessionResult) -> None:
        """The session ended."""
