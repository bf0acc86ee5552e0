"""One linear system over θ = [vec(r); nuisance] that every measurement kind feeds.

Each kind's rows are summed into its own normal equations (``KindSums``: ΦᵀWΦ, ΦᵀWy, yᵀWy in
the full parameter vector), so the solver can weigh the kinds by their own noise. The SESC part
is accumulated in the reduced coordinates of ``Robot.reduction`` (the structural null space
removed in closed form) and expanded exactly at the end; a CoP under tilted gravity (rows with a
CoM-height component) is accumulated in full coordinates. Rows are added in fixed blocks of
``ACCUMULATE_BLOCK`` poses counted from the first pose of a source, whatever the chunks they
arrive in: a file streamed in chunks gives the same sums, bit for bit, as its arrays in memory.
``Accumulator`` is the one accumulator: ``pooled.accumulate_sources`` feeds it files and
stances, ``accumulate`` CoP arrays (the planners' information, the online estimator).

Nuisance parameters are columns of the same system: a constant offset per measured torque, a
friction band per torque when the approach side is known, and (for a MAP fit) a constant CoP
offset, which on one support foot is confounded with the support body's own x/y components.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from sescid.base import G0
from sescid.base.threads import one_blas_thread, ordered_map
from sescid.errors import DataError
from sescid.estimation.data.measurements import Measurements
from sescid.estimation.data.torque_rows import NUISANCE_PRIOR_TORQUE, nuisance_names
from sescid.estimation.result.records import NuisanceWhat
from sescid.estimation.sums.block_sums import BlockSums, RowMaker, aligned, work
from sescid.estimation.sums.distinct import DistinctPoses
from sescid.estimation.sums.normal_equations import (
    ACCUMULATE_BLOCK,
    NormalEquations,
    check_cop,
    cop_errors,
    expand,
)
from sescid.kinds import BALANCE, COP, KINDS, TORQUE, Kind
from sescid.kinematics import as_poses, fold_torque, reduced_order, use_kernels
from sescid.robot import Robot

#: MAP prior standard deviation of a constant CoP offset: effectively flat, m
NUISANCE_PRIOR_COP = 1.0


#: what a system's parameters are: one stance's SESC vectors, or the body parameters that
#: several stances share (``System.space``)
Space = Literal["sesc", "bodies"]


@dataclass(frozen=True)
class Nuisance:
    """A nuisance parameter: a column of the system beside the SESC vectors."""

    kind: Kind  #: the measurement kind it belongs to
    what: NuisanceWhat
    name: str  #: the axis ("x", "y") of a CoP offset, or the joint of a torque sensor
    unit: str  #: "m" or "N·m"
    prior_scale: float  #: MAP prior standard deviation (effectively flat), in ``unit``

    @property
    def label(self) -> str:
        """``tau.offset[knee]`` style name."""
        return f"{self.kind}.{self.what}[{self.name}]"


def cop_offsets() -> tuple[Nuisance, ...]:
    """The two constant CoP offsets b_x, b_y."""
    return tuple(Nuisance(COP, "offset", a, "m", NUISANCE_PRIOR_COP) for a in "xy")


def torque_nuisance(m: Measurements) -> tuple[Nuisance, ...]:
    """The torque kind's nuisance columns for data ``m`` (``torque_rows.nuisance_names``)."""
    return tuple(
        Nuisance(TORQUE, what, joint, "N·m", NUISANCE_PRIOR_TORQUE)
        for what, joint in nuisance_names(m)
    )


@dataclass
class KindSums:
    """The normal equations of one kind over θ = [vec(r); the system's nuisance columns]."""

    kind: Kind
    ne: NormalEquations
    weighted: bool  #: rows weighted by the given standard errors (σ is then a scale)


@dataclass
class System:
    """Every kind's normal equations over one parameter vector θ = [vec(r) (3N); nuisance]."""

    n_x: int  #: 3N
    nuisance: tuple[Nuisance, ...]
    parts: dict[str, KindSums]
    total_mass: float  #: kg: the scale of the torque rows (M · r)
    mass_given: bool  #: the total mass was weighed, not taken from the model
    n_poses: int = 0
    sources: list[str] = field(default_factory=list)
    gravity_accel: float = G0  #: |g| behind the torque rows, m/s²
    #: the parameters: "sesc" (vec(r) of the robot's support, 3N) or "bodies" (the body
    #: parameters x = [m/M; vec(m c)/(M ℓ)], 4N, that several stances share: ``pooled``)
    space: Space = "sesc"
    #: a pooled system: each stance's own sums over the same x (support → System)
    stances: dict[str, System] = field(default_factory=dict)
    #: distinct poses (``DistinctPoses``: counted up to its cap, more count as the cap); None:
    #: not counted
    distinct_poses: int | None = None

    @property
    def size(self) -> int:
        """Length of θ."""
        return self.n_x + len(self.nuisance)

    @property
    def kinds(self) -> tuple[Kind, ...]:
        """The kinds with rows, in a fixed order."""
        return tuple(k for k in KINDS if k in self.parts)

    def labels(self) -> list[str]:
        """Labels of the nuisance columns (the SESC part is labelled by the robot)."""
        return [n.label for n in self.nuisance]

    def embedded(self, nuisance: tuple[Nuisance, ...]) -> System:
        """The same sums in a larger nuisance list (a superset of this one's, any order)."""
        if nuisance == self.nuisance:
            return self
        index = [self.n_x + nuisance.index(n) for n in self.nuisance]
        where = np.concatenate([np.arange(self.n_x), np.asarray(index, dtype=int)])
        size = self.n_x + len(nuisance)
        parts = {}
        for kind, part in self.parts.items():
            ata = np.zeros((size, size))
            atb = np.zeros(size)
            ata[np.ix_(where, where)] = part.ne.ata
            atb[where] = part.ne.atb
            ne = dataclasses.replace(part.ne, ata=ata, atb=atb)
            parts[kind] = dataclasses.replace(part, ne=ne)
        return dataclasses.replace(self, nuisance=nuisance, parts=parts)

    def merged(self, other: System) -> System:
        """The sums of two sources over the union of their nuisance columns."""
        if other.total_mass != self.total_mass or other.gravity_accel != self.gravity_accel:
            raise DataError("sources with different total masses or |g| cannot be pooled")
        union = self.nuisance + tuple(n for n in other.nuisance if n not in self.nuisance)
        a, b = self.embedded(union), other.embedded(union)
        parts = dict(a.parts)
        for kind, part in b.parts.items():
            if kind not in parts:
                parts[kind] = part
                continue
            mine = parts[kind]
            if mine.weighted != part.weighted:
                raise DataError(f"pooled {kind} data are weighted in one source only")
            ne = NormalEquations(mine.ne.ata.copy(), mine.ne.atb.copy(), mine.ne.yty,
                                 mine.ne.n_rows, mine.ne.n_poses + part.ne.n_poses)  # fmt: skip
            ne.add_sums(part.ne)
            parts[kind] = dataclasses.replace(mine, ne=ne)
        distinct = (
            None
            if a.distinct_poses is None or b.distinct_poses is None
            else a.distinct_poses + b.distinct_poses
        )
        return dataclasses.replace(
            a, parts=parts, n_poses=a.n_poses + b.n_poses, sources=a.sources + b.sources,
            distinct_poses=distinct,
        )  # fmt: skip


@dataclass(frozen=True)
class RowOptions:
    """How rows are made: weights from the standard-error columns, the total mass [kg] that
    scales the torque rows (None: the model's) and |g| [m/s²], a CoP offset column (MAP)."""

    weighted: bool = False
    total_mass: float | None = None
    cop_offset: bool = False
    gravity_accel: float = G0
    #: the torque rows weighted by their tau_se columns (None: as ``weighted``); a per-joint
    #: noise model (``torque_noise``) sets them without weighting the CoP
    tau_weighted: bool | None = None

    @property
    def torques_weighted(self) -> bool:
        """Whether the torque rows are weighted by their standard errors."""
        return self.weighted if self.tau_weighted is None else self.tau_weighted


class Accumulator:
    """The normal equations of one source (a file, or arrays), fed in chunks of any size.

    The source is one job: its size alone picks numpy or the compiled kernels
    (``kinematics.use_kernels``), decided once its poses exceed numpy's budget or at ``finish``
    (until then its poses wait, at most that budget's worth), so a file streamed in chunks and
    the same data in memory take the same path and give the same bits."""

    def __init__(self, robot: Robot, options: RowOptions = RowOptions(), distinct: bool = True):
        self.robot, self.options = robot, options
        self.mass = robot.total_mass if options.total_mass is None else float(options.total_mass)
        self.p_red = robot.reduction.g.shape[0]
        self.cop_red = NormalEquations.empty(self.p_red)
        self.cop_full: NormalEquations | None = None
        self.balance: NormalEquations | None = None
        self.tau_red: NormalEquations | None = None
        self.cop_raw: np.ndarray | None = None  #: the compiled passes' raw sums (block order)
        self.tau_raw: np.ndarray | None = None
        self.first: Measurements | None = None
        self.pending: list[Measurements] = []
        self.n_pending = 0
        self.n_poses = 0
        self.progress = None
        self.maker: RowMaker | None = None  #: set when the path is decided
        #: the distinct poses counted (``System.distinct_poses``), unless not asked for
        self.distinct = DistinctPoses(robot.nq, self.p_red + 1) if distinct else None

    def add(self, m: Measurements, progress=None) -> None:
        """Add validated measurements (``Measurements.checked``) of this source;
        ``progress(poses_done)`` after each block."""
        if self.first is None:
            self.first = m
        elif m.kinds != self.first.kinds or m.tau_joints != self.first.tau_joints:
            raise DataError(f"{m.source}: a chunk measures other kinds or joints than the first")
        elif (m.approach is None) != (self.first.approach is None):
            raise DataError(f"{m.source}: the approach column is missing in part of the data")
        self.progress = progress
        if self.distinct is not None:
            self.distinct.add(m.q)
        self.pending.append(m)
        self.n_pending += m.n
        if self.maker is None:
            if not use_kernels(work(self.robot, m, self.n_poses + self.n_pending)):
                return  # a small job so far: its poses wait for the end (numpy), or for more
            self.maker = self._maker(True)
        if self.n_pending < ACCUMULATE_BLOCK:
            return
        blocks = list(aligned(self.pending, ACCUMULATE_BLOCK))  # views (a copy at a seam)
        rest = blocks.pop() if blocks[-1].n < ACCUMULATE_BLOCK else None
        self._blocks(blocks, progress)
        self.pending = [] if rest is None else [rest]
        self.n_pending = 0 if rest is None else rest.n

    def _maker(self, kernels: bool) -> RowMaker:
        first = self.first
        assert first is not None
        return RowMaker(
            self.robot, kernels, self.options.weighted, self.mass, self.options.gravity_accel,
            first.tau_joints if first.tau is not None else (), first.approach is not None,
            self.options.torques_weighted,
        )  # fmt: skip

    def _blocks(self, blocks: list[Measurements], progress) -> None:
        """Sums of consecutive blocks (``ACCUMULATE_BLOCK`` poses, the source's last one
        shorter): each block on its own (on every core for the compiled path), in block order."""
        maker = self.maker
        assert maker is not None
        parts = (
            ordered_map(maker.sums, blocks)
            if maker.kernels and len(blocks) > 1
            else map(maker.sums, blocks)
        )
        for blk, part in zip(blocks, parts, strict=True):
            self._add(part)
            self.n_poses += blk.n
            if progress is not None:
                progress(self.n_poses)
            if blk.cop is not None:
                self.cop_red.n_poses += blk.n
            if blk.balance is not None and self.balance is not None:
                self.balance.n_poses += blk.n
            if blk.tau is not None and blk.tau_joints:
                self._torque_sums().n_poses += blk.n

    def _torque_sums(self) -> NormalEquations:
        if self.tau_red is None:
            first = self.first
            assert first is not None
            self.tau_red = NormalEquations.empty(self.p_red + len(torque_nuisance(first)))
        return self.tau_red

    def _add(self, part: BlockSums) -> None:
        """One block's sums, in block order."""
        if part.cop_red is not None:
            self.cop_red.add_sums(part.cop_red)
        if part.cop_raw is not None:
            self.cop_raw = part.cop_raw if self.cop_raw is None else self.cop_raw + part.cop_raw
            self.cop_red.n_rows += part.cop_rows
        if part.cop_full is not None:
            if self.cop_full is None:
                self.cop_full = NormalEquations.empty(3 * len(self.robot.body_names))
            self.cop_full.add_sums(part.cop_full)
        if part.balance is not None:
            if self.balance is None:
                self.balance = NormalEquations.empty(3 * len(self.robot.body_names))
            self.balance.add_sums(part.balance)
        if part.tau_red is not None:
            self._torque_sums().add_sums(part.tau_red)
        if part.tau_raw is not None:
            self.tau_raw = part.tau_raw if self.tau_raw is None else self.tau_raw + part.tau_raw
            self._torque_sums().n_rows += part.tau_rows

    def _raw_sums(self) -> None:
        """The compiled passes' raw accumulators, read once: into the reduced sums."""
        tree, p = self.robot.tree, self.p_red
        if self.cop_raw is not None:
            sums = reduced_order(self.cop_raw, tree, len(self.robot.reduction.rows), p)
            self.cop_red.add_sums(NormalEquations(*sums))
            self.cop_raw = None
        if self.tau_raw is not None:
            assert self.maker is not None and self.maker.plan is not None
            self._torque_sums().add_sums(
                NormalEquations(*fold_torque(self.tau_raw, self.maker.plan, p))
            )
            self.tau_raw = None

    def finish(self) -> System:
        """The source's system, in full coordinates (DataError when it had no poses)."""
        if self.first is not None and self.maker is None:
            self.maker = self._maker(False)  # the whole source fit numpy's budget
        if self.pending:
            self._blocks(list(aligned(self.pending, ACCUMULATE_BLOCK)), self.progress)
            self.pending, self.n_pending = [], 0
        if self.first is None or self.n_poses == 0:
            raise DataError("no poses to identify from")
        self._raw_sums()
        first = self.first
        nuisance = cop_offsets() if (COP in first.kinds and self.options.cop_offset) else ()
        n_x = 3 * len(self.robot.body_names)
        g = self.robot.reduction.g
        parts: dict[str, KindSums] = {}
        if COP in first.kinds:
            ata, atb = expand(g, self.cop_red)
            ne = NormalEquations(ata, atb, self.cop_red.yty, self.cop_red.n_rows)
            if self.cop_full is not None:
                ne.add_sums(self.cop_full)
            ne.n_poses = self.cop_red.n_poses
            ne = _with_cop_offset(self.robot, ne) if self.options.cop_offset else ne
            parts[COP] = KindSums(COP, ne, self.options.weighted)
        if self.balance is not None:
            parts[BALANCE] = KindSums(BALANCE, self.balance, False)
        system = System(n_x, nuisance, parts, self.mass, self.options.total_mass is not None)
        if self.tau_red is not None:
            system = self._with_torques(system, parts)
        system.n_poses = self.n_poses
        system.distinct_poses = None if self.distinct is None else self.distinct.count
        system.sources = [first.source]
        system.gravity_accel = self.options.gravity_accel
        return system

    def _with_torques(self, system: System, parts: dict[str, KindSums]) -> System:
        """The torque kind's sums expanded to [vec(r); its nuisance], merged into ``system``."""
        t, first = self.tau_red, self.first
        assert t is not None and first is not None
        n_x = system.n_x
        k = len(torque_nuisance(first))
        expand_m = np.zeros((self.p_red + k, n_x + k))
        expand_m[: self.p_red, :n_x] = self.robot.reduction.g
        expand_m[self.p_red :, n_x:] = np.eye(k)
        ata, atb = expand(expand_m, t)
        ne = NormalEquations(ata, atb, t.yty, t.n_rows, t.n_poses)
        tau_sys = System(
            n_x,
            torque_nuisance(first),
            {TORQUE: KindSums(TORQUE, ne, self.options.torques_weighted)},
            self.mass,
            system.mass_given,
        )
        if parts:
            return system.merged(dataclasses.replace(tau_sys, n_poses=0))
        return tau_sys


def pinned_system(system: System, directions: np.ndarray, theta0: np.ndarray) -> System:
    """The system restricted to the models that equal θ0 along ``directions`` (P, k): each
    kind's sums with P = I − UUᵀ (U an orthonormal basis of the directions), A' = PAP,
    b' = P(b − Aθ0) + A'θ0 and yᵀy' such that every such model's residual is the data's. The
    restricted sums see nothing along the directions, so any solver fills them from θ0 (least
    squares) or keeps them at θ0 with the prior's uncertainty (MAP)."""
    u, _ = np.linalg.qr(np.asarray(directions, dtype=float).reshape(theta0.size, -1))
    proj = np.eye(theta0.size) - u @ u.T
    parts = {}
    for kind, part in system.parts.items():
        ne = part.ne
        ata = proj @ ne.ata @ proj
        ata = (ata + ata.T) / 2
        atb = proj @ (ne.atb - ne.ata @ theta0) + ata @ theta0
        rss0 = ne.rss(theta0)
        yty = rss0 + 2 * theta0 @ atb - theta0 @ ata @ theta0
        new = NormalEquations(ata, atb, yty, ne.n_rows, ne.n_poses)
        parts[kind] = dataclasses.replace(part, ne=new)
    return dataclasses.replace(system, parts=parts)


def _with_cop_offset(robot: Robot, ne: NormalEquations) -> NormalEquations:
    """The CoP sums with two offset columns appended. A constant offset b shifts every CoP row
    as the support body's r would by Δr0 = R_rootᵀ (b_x, b_y, 0) (its row is constant, level or
    tilted), so [Φ, B] = Φ T with T = [I, E] and the sums follow as Tᵀ(·)T."""
    n_x = ne.ata.shape[0]
    t = np.zeros((n_x, n_x + 2))
    t[:, :n_x] = np.eye(n_x)
    t[:3, n_x:] = robot.tree.root_r.T[:, :2]
    ata, atb = expand(t, ne)
    return NormalEquations(ata, atb, ne.yty, ne.n_rows, ne.n_poses)


@one_blas_thread()
def accumulate(
    robot: Robot, chunks: Iterable[tuple], ne: NormalEquations | None = None
) -> NormalEquations:
    """The CoP's normal equations over vec(r) of one source given as chunks ``(q, cop)``,
    ``(q, cop, sigma)`` or ``(q, cop, sigma, gravity)``: q (n, nq) [rad], cop (n, 2) [m], sigma
    per-pose standard errors (n,) or (n, 2) [m] (weighted rows), gravity (n, 3) the per-pose
    direction in the support frame (tilted rows); added to ``ne`` when given. The
    ``Accumulator``'s sums (the same path and bits as ``identify``'s), for the planners and the
    online estimator."""
    acc: Accumulator | None = None
    n_poses = 0
    for chunk in chunks:
        q = as_poses(chunk[0], robot.nq)
        cop = check_cop(chunk[1], q.shape[0])
        sigma = chunk[2] if len(chunk) > 2 else None
        gravity = chunk[3] if len(chunk) > 3 else None
        if acc is None:
            acc = Accumulator(robot, RowOptions(weighted=sigma is not None), distinct=False)
        elif acc.options.weighted != (sigma is not None):
            raise DataError("sigma: give the CoP's standard errors with every chunk or with none")
        se = None if sigma is None else cop_errors(sigma, q.shape[0])
        g = None if gravity is None else np.asarray(gravity, dtype=float)
        acc.add(Measurements(q=q, cop=cop, cop_se=se, gravity=g))
        n_poses += q.shape[0]
    if acc is None or n_poses == 0:
        return ne or NormalEquations.empty(3 * len(robot.body_names))
    part = acc.finish().parts[COP].ne
    if ne is None:
        return part
    ne.add_sums(part)
    ne.n_poses += part.n_poses
    return ne
