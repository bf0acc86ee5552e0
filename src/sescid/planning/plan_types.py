"""What a pose plan is given and gives: ``PlanOptions``, the plan family (``Plan``: one stance,
``PosePlan``; several, ``StancePlan``), the default pool and the plan's notes."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from sescid.base import check_ranges, option
from sescid.errors import OptionError
from sescid.kinds import COP, DesignKind, Kinds
from sescid.planning.design.doptimal import Selection
from sescid.planning.design.kinds import DEFAULT_TAU_NOISE, BlockRows
from sescid.planning.feasibility.candidates import Candidates, Mount
from sescid.planning.feasibility.compliance import Compliance
from sescid.planning.feasibility.limits import UNLIMITED_RANGE
from sescid.planning.feasibility.stability import DEFAULT_CLEARANCE
from sescid.robot import Robot
from sescid.simulation import PAPER_NOISE
from sescid.stance import Stance

#: (k, nq) poses [rad] → (k,) True where the pose stands (a physics bench, ``bench.standing``)
PoseCheck = Callable[[np.ndarray], np.ndarray]
#: (stance, the robot rooted at its frame) → that stance's ``PoseCheck``, or None (none there)
StanceCheck = Callable[[Stance, Robot], PoseCheck | None]


#: how a plan chooses its poses from the candidates: D-optimally, or at random (a reference)
Select = Literal["d-optimal", "random"]
#: what a design's expected error is the error of: the CoP (a CoP design on a standing robot),
#: else the CoM's x and y (designs with torque rows, a held robot)
Quantity = Literal["CoP", "CoM x/y"]


@dataclass(frozen=True)
class PlanOptions:
    """How ``plan_poses`` samples, checks and scores (SI units, radians)."""

    n_candidates: int | None = option(
        None,
        "Stable, collision-free candidate poses to choose from [default, d-optimal: 20000 for "
        "uniform draws (op2), 5000 with the adjusted sampler; random: --count (a random subset "
        "of random candidates is random)].",
        low=1, high=10_000_000, flag="--candidates",
    )  # fmt: skip
    #: further candidates on which the expected error is computed
    n_test: int = option(
        2_000, "Held-out poses for the error.", low=1, high=10_000_000, flag="--test-poses"
    )
    sigma: float = option(
        PAPER_NOISE, "CoP noise σ for the expected error [m].", low=0, low_open=True,
        flag="--noise",
    )  # fmt: skip
    limits: np.ndarray | None = None  #: (nq, 2) rad; None: ``sampling_limits(robot)``
    half_extents: np.ndarray | None = None  #: (2,) m CoP box; None: ``cop_half_extents``
    clearance: float = option(
        DEFAULT_CLEARANCE,
        "The free foot (all its geometry) above the floor by at least this [m]; on a gantry, "
        "every body.",
        low=0, flag="--foot-clearance",
    )  # fmt: skip
    random_draws: int = option(50, "Random sets drawn for the random-choice error.", low=1)
    rigid: bool = option(
        False,
        "Stability: the CoP box only, no compliant-robot margin (servo sag, sole tilt, "
        "backlash from the robot profile).",
    )
    allow_missing_meshes: bool = option(
        False,
        "Plan even when mesh files the model names are not found or cannot be read: their "
        "bodies are then kept off the floor and apart by their origins and frames only.",
    )
    #: a stance's physics check (a bench): keeps only chosen poses it passes
    check: StanceCheck | None = None
    check_name: str = ""  #: what ``check`` is, for the notes
    max_check_rounds: int = 20  #: choose again at most this often after failed checks
    #: as users spell it (``plan_poses`` parses it: ``sescid.kinds.parse_kinds``)
    kinds: DesignKind = option(
        "cop",
        "What the robot measures at each pose, for the D-optimal choice: cop (a foot sensor), "
        "tau (joint torques, an unknown offset per joint) or both.",
    )
    tau_noise: float = option(
        DEFAULT_TAU_NOISE,
        "Joint-torque noise σ per pose for the design and its expected error [N·m].",
        low=0, low_open=True,
    )  # fmt: skip
    tau_joints: tuple[str, ...] | None = None  #: joints whose torque is measured (None: all)
    mount: Mount | None = option(
        None,
        "stand: on the support foot (balance checked); gantry: the support link (a torso, "
        "pelvis) held level, the robot hanging free (joint limits, floor, self-collision only; "
        "--kinds tau); double: on both feet, the other foot's sole flat on the floor (CoP of "
        "the whole robot in the support foot's frame; --kinds cop). Default: gantry when the "
        "robot's mass splits at the support (a trunk), else stand.",
    )
    hang_height: float | None = option(
        None,
        "Gantry: height of the held link's frame above the floor [m] (default: its height "
        "when the robot stands at the zero pose + 50 mm).",
        low=0, low_open=True, what="a finite height > 0 m",
    )  # fmt: skip

    def __post_init__(self) -> None:
        check_ranges(self)


@dataclass(kw_only=True)
class Plan:
    """K chosen poses in visiting order and what the choice is expected to achieve: the fields
    every plan has (one stance: ``PosePlan``; several: ``StancePlan``)."""

    q: np.ndarray  #: (K, nq) rad, in visiting order
    cop: np.ndarray  #: (K, 2) model CoP [m] in its stance's frame (CPU-independent; nan: held)
    kinds: Kinds = (COP,)  #: the kinds the design counts
    rank: int  #: dimension p of the identifiable subspace the design spans
    logdet: float  #: log det of the chosen poses' information on it
    selection: Selection
    notes: list[str] = field(default_factory=list)
    n_checked: int = 0  #: poses the physics check ran
    n_check_failed: int = 0  #: of which did not stand (replaced)


@dataclass(kw_only=True)
class PosePlan(Plan):
    """A plan in one stance (its candidates, the expected error of least squares)."""

    method: Select
    #: m, expected noise-free error of least squares on these poses: of the CoP (a CoP design),
    #: else of the CoM x/y (``quantity``) on fresh poses
    expected_error: float
    random_error: float  #: m, the same for K random candidates (median over draws)
    sigma: float  #: m, CoP noise assumed
    path_unordered: float  #: rad, joint-space path length in selection order
    path_ordered: float  #: rad, after ordering
    candidates: Candidates
    basis: np.ndarray  #: (3N, p)
    c_test: np.ndarray = field(repr=False)  #: (p, p)
    #: joints the model leaves unlimited, sampled within ±``unlimited_range``
    unlimited: list[str] = field(default_factory=list)
    unlimited_range: float = UNLIMITED_RANGE  #: rad (the default, or what ``limits`` gave)
    compliance: Compliance | None = None  #: the compliant-stability model (None: rigid)
    quantity: Quantity = "CoP"  #: what ``expected_error`` is the error of
    mount: Mount = "stand"  #: "stand", "gantry" or "double"
    rows: BlockRows = field(repr=False)  #: the pool's rows (the CoP's not divided by ``sigma``)
    min_count: int  #: fewest poses that can determine the ``rank`` combinations (and offsets)
    #: of the ``rank`` combinations, how many the chosen poses determine (None: all of them)
    determined: int | None = None

    @property
    def error_scale(self) -> float:
        """What the rows' errors are multiplied by (``engine.expected_error``): σ for the CoP's
        rows, 1 for rows divided by their noise."""
        return self.sigma if self.quantity == "CoP" else 1.0

    @property
    def poses_for_all(self) -> int | None:
        """About how many poses determine every combination when these do not (None when they
        do): the count scaled by the combinations a pose added here."""
        if self.determined is None or self.determined >= self.rank:
            return None
        return math.ceil(len(self.q) * self.rank / max(self.determined, 1))


@dataclass(frozen=True)
class StanceReport:
    """What one stance contributes to a plan over several."""

    stance: Stance
    poses: int  #: poses of the plan in this stance
    rank: int  #: directions of θ its candidates determine alone
    adds: int  #: directions the pool loses without it
    candidates: Candidates


@dataclass(kw_only=True)
class StancePlan(Plan):
    """A plan over several stances, grouped by stance in visiting order (``rank``: directions
    of θ, 4N, the pool determines), and what pooling gains."""

    stance: np.ndarray  #: (K,) each pose's stance label (``Stance.label``)
    stances: tuple[Stance, ...]
    reports: list[StanceReport]
    reference: Stance  #: the stance the pooled plan is compared with
    n_theta: int  #: 4N
    cost: float  #: poses per stance change
    changes: int  #: stance changes in the visiting order
    #: m, expected RMS error of the CoM on fresh poses (reference frame) of a MAP fit of these
    #: poses (``PRIOR_TAU``): 3-D, and x/y
    expected_com: float
    expected_com_xy: float
    #: m, the same for K poses of the reference stance alone (its own D-optimal choice)
    reference_com: float
    reference_com_xy: float
    path_length: float  #: rad, joint-space path summed over the stance groups
    subsets: list[tuple[tuple[str, ...], int, float]]  #: (labels, poses, log det) tried
    test_q: np.ndarray = field(repr=False)  #: (n, nq) rad, the fresh poses of the errors


def default_candidates(robot: Robot, select: Select, count: int, kinds: Kinds = (COP,)) -> int:
    """The pool a choice draws from by default: D-optimal, 20 000 candidates when the profile asks
    for uniform draws (the OP2), 5 000 for the CoM-Jacobian search (dearer per candidate) and for
    designs with torque rows (a pose's J rows cost J²/4 times a CoP pose's two); random,
    ``count`` (a random subset of random candidates is random)."""
    if select == "random":
        return count
    if kinds != (COP,):
        return 5_000
    return 20_000 if robot.profile.pose_sampler == "uniform" else 5_000


def options_with(options: PlanOptions | None, overrides: dict) -> PlanOptions:
    """``options`` with keyword overrides (OptionError naming an unknown one)."""
    opt = options or PlanOptions()
    names = {f.name for f in dataclasses.fields(PlanOptions)}
    bad = sorted(set(overrides) - names)
    if bad:
        raise OptionError(bad[0], f"not an option of plan_poses ({', '.join(sorted(names))})")
    return dataclasses.replace(opt, **overrides)


def plan_notes(
    free: list[str],
    free_range: float,
    opt: PlanOptions,
    model: Compliance | None,
    checked: tuple[int, int] | None,
    held: bool = False,
) -> list[str]:
    """What the plan assumed and checked (``checked``: poses the physics check ran and failed,
    None: no check), one line each (``held``: a gantry, no balance)."""
    out = []
    if free:
        out.append(
            f"{len(free)} joint(s) without limits sampled within "
            f"±{math.degrees(free_range):.4g}°: {', '.join(free[:6])}"
            + (" …" if len(free) > 6 else "")
        )
    if held:
        out.append("held in a gantry: no balance to keep (joint limits, floor, self-collision)")
    elif model is None:
        out.append("stability: the CoP box only (rigid robot)")
    else:
        out.append(f"compliant-robot margin: {model.source}")
    if checked is not None:
        out.append(
            f"{opt.check_name or 'physics'} check: {checked[0]} poses simulated, {checked[1]} "
            "did not stand and were replaced"
        )
    return out
