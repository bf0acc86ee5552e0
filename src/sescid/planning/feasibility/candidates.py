"""Candidate poses: drawn within the sampling limits, kept when stable (the CoP box, and the
compliant-robot margin of ``compliance``), clear of the ground and free of self-collision.

Uniform draws first (the paper's study) when the profile asks for them; when fewer than
``SWITCH_RATE`` of them are accepted after ``SWITCH_AFTER`` draws, the adjusted draws of
``adjust`` (the CoM moved over the foot by the CoM Jacobian) take over (a caller that asks
for ``sampler="uniform"`` in its ``CandidateOptions`` gets uniform draws only, up to
``max_sampled``). When those find
nothing either, the error says which check stops them: the CoM that cannot reach the box within the
joint limits (how near it came), or the compliant margin, the floor, self-collision.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from sescid.errors import SescidError, check_choice
from sescid.kinematics import cop_xy, reducible
from sescid.planning.feasibility.collision import Capsules, collision_capsules
from sescid.planning.feasibility.com import com_state
from sescid.planning.feasibility.compliance import Compliance, compliant_margin
from sescid.planning.feasibility.ground import ground_clear
from sescid.planning.feasibility.limits import sampling_limits
from sescid.planning.feasibility.stability import (
    DEFAULT_CLEARANCE,
    coarse_screen_tree,
    cop_half_extents,
    inside_box,
    stable_subset,
)
from sescid.robot import Robot
from sescid.robots import PoseSampler
from sescid.stance import Mount

SWITCH_AFTER = 400_000  #: uniform draws before the adjusted draws may take over
SWITCH_RATE = 1e-4  #: accepted share of uniform draws below which they do
#: adjusted draws without one CoP in the box: the robot cannot put its CoM over the foot
GIVE_UP_BOX = 30_000
GIVE_UP = 200_000  #: adjusted draws without one accepted pose: something else stops them all

#: a candidate pool's mount: one of ``Mount``, or "stances" for the union of several
PoolMount = Literal[Mount, "stances"]
#: how candidates were drawn: uniform, adjusted (``planning.adjust``), or uniform draws that
#: handed over to adjusted ones when too few were accepted
Sampling = Literal[PoseSampler, "uniform+adjusted", "near", "uniform+near"]


@dataclass
class Candidates:
    """Stable, collision-free, ground-clear poses sampled within ``limits``."""

    q: np.ndarray  #: (n, nq) rad
    cop: np.ndarray  #: (n, 2) model CoP, m
    limits: np.ndarray  #: (nq, 2) sampling limits, rad
    half_extents: np.ndarray  #: (2,) CoP rectangle, m
    n_sampled: int  #: raw poses drawn
    n_stable: int  #: of which stable (CoP box, and compliant margin when checked)
    n_ground: int  #: of which also clear of the ground
    n_free: int  #: of which also free of self-collision (= accepted, before truncation)
    capsules: Capsules | None = None
    sampler: Sampling = "uniform"
    centre: np.ndarray | None = None  #: (2,) centre of the CoP rectangle, m (None: 0)
    n_box: int = 0  #: raw poses whose CoP is in the box
    compliance: Compliance | None = None  #: the compliant-stability model checked (None: rigid)
    notes: list[str] = field(default_factory=list)
    mount: PoolMount = "stand"  #: on the support foot, held, on both feet, or several stances
    #: (n, 4) double support: the free sole's placement x, y [m], cos ψ, sin ψ on the floor
    placement: np.ndarray | None = None

    @classmethod
    def counted(cls, counts: np.ndarray, **fields) -> Candidates:
        """Candidates whose funnel is ``counts`` (5,): poses drawn, CoP in the box, stable,
        clear of the ground, free of self-collision; ``fields``: the rest."""
        c = [int(x) for x in counts]
        return cls(n_sampled=c[0], n_box=c[1], n_stable=c[2], n_ground=c[3], n_free=c[4],
                   **fields)  # fmt: skip

    @property
    def acceptance(self) -> float:
        """Fraction of raw draws that are stable, ground-clear and collision free."""
        return self.n_free / max(self.n_sampled, 1)

    def summary(self) -> str:
        """One line: acceptance at each stage and the number accepted."""
        s = max(self.n_sampled, 1)
        if self.mount == "gantry":
            drawn = "uniform poses" if self.sampler == "uniform" else "poses (uniform, then near "
            drawn += "" if self.sampler == "uniform" else "accepted ones)"
            return (
                f"{self.n_sampled} {drawn}, held: {self.n_ground / s:.2%} clear of the floor, "
                f"{self.n_free / s:.2%} also free of self-collision ({self.n_free} accepted)"
            )
        if self.mount == "double":
            return (
                f"{self.n_sampled} draws on both feet: {self.n_box / s:.2%} closed onto the "
                f"floor within the limits, {self.n_stable / s:.2%} stable (CoP inside both "
                f"feet){' and compliant' if self.compliance is not None else ''}, "
                f"{self.n_ground / s:.2%} also ground-clear, {self.n_free / s:.2%} also free of "
                f"self-collision ({self.n_free} accepted)"
            )
        kind = {
            "uniform": "uniform poses",
            "adjusted": "draws moved over the foot by the CoM Jacobian",
            "uniform+adjusted": "draws (uniform, then moved over the foot by the CoM Jacobian)",
        }[self.sampler]
        comp = " and compliant" if self.compliance is not None else ""
        return (
            f"{self.n_sampled} {kind}: {self.n_box / s:.2%} CoP in the box, "
            f"{self.n_stable / s:.2%} stable{comp}, {self.n_ground / s:.2%} also ground-clear, "
            f"{self.n_free / s:.2%} also free of self-collision ({self.n_free} accepted)"
        )


@dataclass(frozen=True)
class CandidateOptions:
    """How ``candidates`` draws and checks poses (SI units, radians)."""

    limits: np.ndarray | None = None  #: (nq, 2) rad; None: ``sampling_limits(robot)``
    half_extents: np.ndarray | None = None  #: (2,) m CoP box; None: ``cop_half_extents(robot)``
    clearance: float = DEFAULT_CLEARANCE  #: m, free sole corners above the floor
    #: m, sole length and width for the floor check (None: the robot's sole)
    sole_size: tuple[float, float] | None = None
    compliance: Compliance | None = None  #: compliant-stability model to check (None: CoP box)
    #: "uniform" (only uniform draws, at most ``max_sampled``) or "adjusted"; None: the
    #: profile's, whose "uniform" hands over to the adjusted draws when too few are accepted
    sampler: PoseSampler | None = None
    max_sampled: int = 200_000_000  #: uniform draws at most, with ``sampler="uniform"``
    chunk: int = 100_000  #: uniform draws per batch

    def __post_init__(self) -> None:
        if self.sampler is not None:
            check_choice("sampler", self.sampler, PoseSampler)

    def half(self, robot: Robot) -> np.ndarray:
        """(2,) the CoP box's half-extents [m]: ``half_extents``, else ``cop_half_extents``."""
        given = self.half_extents
        return cop_half_extents(robot) if given is None else np.asarray(given, dtype=float)


@dataclass
class _Run:
    """State of one candidate search."""

    robot: Robot
    lim: np.ndarray
    half: np.ndarray
    centre: np.ndarray
    cap: Capsules
    opt: CandidateOptions
    qs: list = field(default_factory=list)
    cops: list = field(default_factory=list)
    counts: np.ndarray = field(default_factory=lambda: np.zeros(5, dtype=np.int64))
    closest: float = np.inf  #: nearest |CoP − centre| / half over the adjusted draws

    def keep(self, q: np.ndarray, ok: np.ndarray, cop: np.ndarray, n_drawn: int) -> None:
        """Count ``n_drawn`` draws; the box-stable ones ``q[ok]`` (CoP ``cop``) through the
        compliant, floor and self-collision checks."""
        from sescid.planning.feasibility.broadphase import collision_free_mask_broad

        q = q[ok]
        self.counts[0] += n_drawn
        self.counts[1] += len(q)
        model = self.opt.compliance
        if len(q) and model is not None:
            good = compliant_margin(model, com_state(self.robot, q)) > 0
            q, cop = q[good], cop[good]
        self.counts[2] += len(q)
        if len(q):
            rot, org = self.robot.forward(q)
            clearance, sole_size = self.opt.clearance, self.opt.sole_size
            g = ground_clear(self.robot, self.cap, rot, org, clearance, sole_size)
            q, cop, rot, org = q[g], cop[g], rot[g], org[g]
            self.counts[3] += len(q)
            f = collision_free_mask_broad(self.cap, rot, org)
            q, cop = q[f], cop[f]
            self.counts[4] += len(q)
            self.qs.append(q)
            self.cops.append(cop)


def first_empty(counts: np.ndarray, stages: tuple[str, ...]) -> str:
    """The first of the funnel's ``stages`` (after the draws: ``counts[1:]``, in order) that no
    draw passed; the last when each passed some."""
    return next((s for c, s in zip(counts[1:], stages, strict=False) if c == 0), stages[-1])


def candidates(
    robot: Robot,
    n: int,
    seed: int | np.random.Generator = 0,
    options: CandidateOptions | None = None,
    *,
    progress: Callable[[int, int], None] | None = None,
) -> Candidates:
    """Draw ``n`` accepted poses within the sampling limits (``CandidateOptions``: limits, CoP
    box, floor clearance, compliant-stability model, sampler), reporting
    ``progress(accepted, n)``. SescidError when no pose passes, saying which check stops them.
    """
    from sescid.planning.feasibility.adjust import Search, closest_box

    opt = options or CandidateOptions()
    only = opt.sampler is not None
    sampler = opt.sampler or robot.profile.pose_sampler
    if n < 1:
        raise SescidError(f"number of candidates must be ≥ 1, got {n}")
    rng = np.random.default_rng(seed)
    lim = sampling_limits(robot) if opt.limits is None else np.asarray(opt.limits, dtype=float)
    half = opt.half(robot)
    run = _Run(robot, lim, half, robot.sole_centre, collision_capsules(robot), opt)
    used: Sampling = sampler
    if sampler == "uniform":
        _uniform(run, n, rng, progress, opt.max_sampled if only else None)
        if run.counts[4] < n:
            used = "uniform+adjusted" if run.counts[4] else "adjusted"
    if run.counts[4] < n:
        drawn, size = 0, 1_000
        search = Search(robot, run.cap, lim, half, run.centre)
        while run.counts[4] < n:
            pool = np.concatenate(run.qs) if run.qs else None
            q = search.draws(size, rng, pool)
            ok, cop = stable_subset(robot, q, half, run.centre)
            run.closest = min(run.closest, closest_box(robot, q, half, run.centre))
            run.keep(q, ok, cop, size)
            drawn += size
            if progress is not None:
                progress(int(min(run.counts[4], n)), n)
            if not run.counts[4] and drawn >= (GIVE_UP if run.counts[1] else GIVE_UP_BOX):
                raise SescidError(_nothing(run))
            left = n - run.counts[4]
            rate = run.counts[4] / drawn if run.counts[4] else 0.0
            want = 1.05 * left / rate + 500 if rate else 5_000  # ≤ 4× the last: rates climb
            size = int(min(100_000, 4 * size, max(1_000, want)))
    return Candidates.counted(
        run.counts,
        q=np.concatenate(run.qs)[:n],
        cop=np.concatenate(run.cops)[:n],
        limits=lim,
        half_extents=half,
        capsules=run.cap,
        sampler=used,
        centre=run.centre,
        compliance=opt.compliance,
    )


def _uniform(
    run: _Run,
    n: int,
    rng: np.random.Generator,
    progress: Callable | None,
    max_sampled: int | None,
) -> None:
    """Uniform draws, ``run.opt.chunk`` at a time, until ``n`` are accepted, or until they are
    too rarely accepted (then SescidError when ``max_sampled`` is given: uniform draws only)."""
    robot, lim, chunk = run.robot, run.lim, run.opt.chunk
    width = lim[:, 1] - lim[:, 0]
    draw = np.empty((chunk, robot.nq))
    screen = None
    if reducible(lim):
        screen = coarse_screen_tree(robot, lim[:, 0], width)
    while run.counts[4] < n:
        u = rng.random((chunk, robot.nq), out=draw)
        if screen is None:
            q = u * width + lim[:, 0]
            ok, cop = stable_subset(robot, q, run.half, run.centre)
        else:
            # unit draws screened by the coarse CoP before they are scaled; the survivors get
            # the same numbers as lim[:, 0] + width * rng.random((chunk, nq))
            tree, r, bound = screen
            q = u[inside_box(cop_xy(tree, u, r), run.centre, run.half + bound)]
            q *= width
            q += lim[:, 0]
            ok, cop = stable_subset(robot, q, run.half, run.centre, coarse=False)
        run.keep(q, ok, cop, chunk)
        if progress is not None:
            progress(int(min(run.counts[4], n)), n)
        done, drawn = int(run.counts[4]), int(run.counts[0])
        if max_sampled is None:
            if drawn >= SWITCH_AFTER and done < SWITCH_RATE * drawn:
                return
        elif drawn >= 1_000_000 and (done == 0 or n * drawn / done > max_sampled):
            raise SescidError(
                f"only {done} of {drawn} uniform poses are accepted: {n} would need more "
                f"than {max_sampled} draws (the adjusted sampler moves draws over the foot)"
            )


def _nothing(run: _Run) -> str:
    """Why no draw was accepted: the first check that stops them all."""
    c = run.counts
    r = run.robot
    if c[1] == 0:
        return (
            f"{r.name} cannot put its CoP in the stability box (±{run.half[0] * 1e3:.1f} x "
            f"±{run.half[1] * 1e3:.1f} mm around the sole centre) within its joint limits: "
            f"moved by the CoM Jacobian, {c[0]} draws came no nearer than "
            f"{run.closest:.2f} times the box's half-size — it cannot stand on '{r.support}' "
            "alone: hold it in a gantry (--mount gantry --kinds tau, by its pelvis or torso), "
            "widen the joint limits, or stand it on another foot"
        )
    stage = first_empty(c, ("the stability box",
        "the compliant-robot margin (stiffer servos or a stiffer sole in the profile, or --rigid)",
        "the floor check", "self-collision"))  # fmt: skip
    return (
        f"no pose of {r.name} passes every check: of {c[0]} draws moved over the foot by the "
        f"CoM Jacobian {c[1]} had their CoP in the box, {c[2]} kept the compliant margin, "
        f"{c[3]} cleared the floor, {c[4]} were free of self-collision: {stage} stops them"
    )
