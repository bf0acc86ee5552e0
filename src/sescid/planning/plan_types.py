"""What a pose plan is given and gives (``PlanOptions``, ``PosePlan``), the default pool, the
physics check's choose-again loop and the plan's notes: shared by the CoP plan (``plan``) and
the torque plan (``plan_kinds``)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from sescid.base import check_ranges, option
from sescid.errors import OptionError, SescidError
from sescid.planning.design.doptimal import Selection
from sescid.planning.design.kinds import DEFAULT_TAU_NOISE, BlockRows, DesignKind
from sescid.planning.feasibility.candidates import CandidateOptions, Candidates, Mount, candidates
from sescid.planning.feasibility.com import level_cop
from sescid.planning.feasibility.compliance import Compliance, compliance
from sescid.planning.feasibility.limits import UNLIMITED_RANGE, sampling_limits, unlimited_joints
from sescid.planning.feasibility.stability import DEFAULT_CLEARANCE
from sescid.planning.ordering import order_poses, path_length
from sescid.robot import Robot
from sescid.simulation import PAPER_NOISE

#: (k, nq) poses [rad] → (k,) True where the pose stands (a physics bench, ``bench.standing``)
PoseCheck = Callable[[np.ndarray], np.ndarray]


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
    check: PoseCheck | None = None  #: keeps only chosen poses it passes (a physics bench)
    check_name: str = ""  #: what ``check`` is, for the notes
    max_check_rounds: int = 20  #: choose again at most this often after failed checks
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


@dataclass
class PosePlan:
    """K chosen poses in visiting order, with what the choice is expected to achieve."""

    q: np.ndarray  #: (K, nq) rad, ordered
    cop: np.ndarray  #: (K, 2) model CoP on a level floor, m (CPU-independent bits; nan: gantry)
    method: Select
    #: m, expected noise-free error of least squares on these poses: of the CoP (a CoP design),
    #: else of the CoM x/y (``quantity``) on fresh poses
    expected_error: float
    random_error: float  #: m, the same for K random candidates (median over draws)
    sigma: float  #: m, CoP noise assumed
    rank: int  #: dimension p of the identifiable subspace
    logdet: float
    path_unordered: float  #: rad, joint-space path length in selection order
    path_ordered: float  #: rad, after ordering
    candidates: Candidates
    selection: Selection
    basis: np.ndarray  #: (3N, p)
    a_pool: np.ndarray = field(repr=False)  #: (n, 2, p)
    c_test: np.ndarray = field(repr=False)  #: (p, p)
    #: joints the model leaves unlimited, sampled within ±``unlimited_range``
    unlimited: list[str] = field(default_factory=list)
    unlimited_range: float = UNLIMITED_RANGE  #: rad (the default, or what ``limits`` gave)
    compliance: Compliance | None = None  #: the compliant-stability model (None: rigid)
    n_checked: int = 0  #: poses the physics check ran
    n_check_failed: int = 0  #: of which did not stand (replaced)
    notes: list[str] = field(default_factory=list)
    kinds: DesignKind = "cop"  #: the kinds the design counts
    quantity: Quantity = "CoP"  #: what ``expected_error`` is the error of
    mount: Mount = "stand"  #: "stand", "gantry" or "double"
    rows: BlockRows | None = field(default=None, repr=False)  #: the pool's rows (kinds ≠ cop)
    #: of the ``rank`` combinations, how many the chosen poses determine (None: all of them)
    determined: int | None = None

    @property
    def poses_for_all(self) -> int | None:
        """About how many poses determine every combination when these do not (None when they
        do): the count scaled by the combinations a pose added here."""
        if self.determined is None or self.determined >= self.rank:
            return None
        return math.ceil(len(self.q) * self.rank / max(self.determined, 1))


def default_candidates(robot: Robot, select: Select, count: int, kinds: DesignKind = "cop") -> int:
    """The pool a choice draws from by default: D-optimal, 20 000 candidates when the profile asks
    for uniform draws (the OP2), 5 000 for the CoM-Jacobian search (dearer per candidate) and for
    designs with torque rows (a pose's J rows cost J²/4 times a CoP pose's two); random,
    ``count`` (a random subset of random candidates is random)."""
    if select == "random":
        return count
    if kinds != "cop":
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


def checked_choice(
    choose: Callable[[np.ndarray], Selection],
    q: np.ndarray,
    opt: PlanOptions,
    by_index: Callable[[np.ndarray], np.ndarray] | None = None,
) -> tuple[Selection, int, int]:
    """(selection, poses checked, failed): ``choose(keep)`` among the pool poses ``q`` where
    ``keep``, run ``opt.check`` (or ``by_index``, given the pool indices) on the chosen poses
    not checked yet, drop those that fail from the pool and choose again, until all stand."""
    keep = np.ones(len(q), dtype=bool)
    sel = choose(keep)
    if opt.check is None and by_index is None:
        return sel, 0, 0
    check = by_index or (lambda idx: opt.check(q[idx]))  # type: ignore[misc]
    stands: dict[int, bool] = {}
    for _ in range(opt.max_check_rounds):
        new = [int(i) for i in sel.index if int(i) not in stands]
        if new:
            ok = np.asarray(check(np.asarray(new, dtype=np.int64)), dtype=bool)
            stands |= dict(zip(new, ok.tolist(), strict=True))
        bad = [int(i) for i in sel.index if not stands[int(i)]]
        if not bad:
            return sel, len(stands), sum(not v for v in stands.values())
        keep[bad] = False
        sel = choose(keep)
    raise SescidError(
        f"after {opt.max_check_rounds} rounds some chosen poses still fail the "
        f"{opt.check_name or 'physics'} check ({sum(not v for v in stands.values())} of "
        f"{len(stands)} checked failed): more candidates (--candidates) or a tighter box"
    )


def plan_notes(
    free: list[str],
    free_range: float,
    opt: PlanOptions,
    model: Compliance | None,
    checked: tuple[int, int],
    held: bool = False,
) -> list[str]:
    """What the plan assumed and checked, one line each (``held``: a gantry, no balance)."""
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
    if opt.check is not None:
        out.append(
            f"{opt.check_name or 'physics'} check: {checked[0]} poses simulated, {checked[1]} "
            "did not stand and were replaced"
        )
    return out


def sampling_range(robot: Robot, opt: PlanOptions) -> tuple[np.ndarray, list[str], float]:
    """The joint ranges (nq, 2) [rad] candidates are drawn in (``opt.limits`` or the robot's),
    the joints the model leaves unlimited, and the widest range given to them (rad; 0: none)."""
    lim = sampling_limits(robot) if opt.limits is None else np.asarray(opt.limits, dtype=float)
    free = unlimited_joints(robot)
    free_range = float(np.abs(lim[[robot.joint_names.index(j) for j in free]]).max()) if free else 0
    return lim, free, free_range


def standing_candidates(
    robot: Robot,
    n: int,
    seed: int,
    opt: PlanOptions,
    lim: np.ndarray,
    progress,
    double: bool = False,
) -> Candidates:
    """``n`` candidates for a robot standing on its support foot (``double``: on both feet,
    ``planning.double``): a level support checked, the compliant-robot margin unless
    ``opt.rigid``, the floor and self-collision."""
    robot.check_support_level()
    model = None if opt.rigid else compliance(robot)
    draw = CandidateOptions(
        limits=lim, half_extents=opt.half_extents, clearance=opt.clearance, compliance=model
    )
    if double:
        from sescid.planning.feasibility.double import double_candidates

        return double_candidates(robot, n, seed, draw, progress=progress)
    return candidates(robot, n, seed, draw, progress=progress)


def visiting_order(q_sel: np.ndarray) -> tuple[np.ndarray, float, float]:
    """The chosen poses (k, nq) in visiting order (``ordering.order_poses``), and the length of
    the joint-space path from the zero pose through them before and after ordering (rad)."""
    q_ord = q_sel[order_poses(q_sel)]
    zero = np.zeros(q_sel.shape[1])
    return q_ord, path_length(q_sel, zero), path_length(q_ord, zero)


def pose_plan(
    robot: Robot,
    chosen: tuple[Candidates, np.ndarray, Selection],
    opt: PlanOptions,
    sampled: tuple[list[str], float],
    **fields,
) -> PosePlan:
    """The plan of the selection of ``chosen`` = (candidates, pool poses (n, nq), selection),
    in visiting order, with what every design reports (the sampled range of ``sampled`` = (the
    unlimited joints, their range), the compliance model); ``fields``: what the design adds
    (its errors, basis, notes, …). ``cop``: False leaves the model CoP nan (a held robot)."""
    cand, pool_q, sel = chosen
    q_ord, path_unordered, path_ordered = visiting_order(pool_q[sel.index])
    free, free_range = sampled
    level = fields.pop("cop", True)
    return PosePlan(
        q=q_ord,
        cop=level_cop(robot, q_ord) if level else np.full((len(q_ord), 2), np.nan),
        sigma=opt.sigma,
        logdet=sel.logdet,
        path_unordered=path_unordered,
        path_ordered=path_ordered,
        candidates=cand,
        selection=sel,
        unlimited=free,
        unlimited_range=free_range if free else UNLIMITED_RANGE,
        compliance=cand.compliance,
        **fields,
    )
