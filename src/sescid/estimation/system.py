"""One linear system over θ = [vec(r); nuisance] that every measurement kind feeds.

Each kind's rows are summed into its own normal equations (``KindSums``: ΦᵀWΦ, ΦᵀWy, yᵀWy in
the full parameter vector), so the solver can weigh the kinds by their own noise. The SESC part
is accumulated in the reduced coordinates of ``Robot.reduction`` (the structural null space
removed in closed form) and expanded exactly at the end; a CoP under tilted gravity (rows with a
CoM-height component) is accumulated in full coordinates. Rows are added in fixed blocks of
``ACCUMULATE_BLOCK`` poses counted from the first pose of a source, whatever the chunks they
arrive in: a file streamed in chunks gives the same sums, bit for bit, as its arrays in memory.

Nuisance parameters are columns of the same system: a constant offset per measured torque, a
friction band per torque when the approach side is known, and (for a MAP fit) a constant CoP
offset, which on one support foot is confounded with the support body's own x/y components.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from sescid.errors import DataError
from sescid.estimation.measurements import COP, TORQUE, Measurements, concatenate
from sescid.estimation.normal_equations import (
    ACCUMULATE_BLOCK,
    NormalEquations,
    add_columns,
    add_cop_reduced,
    add_cop_tilted,
    upper_to_full,
)
from sescid.estimation.torque_rows import NUISANCE_PRIOR_TORQUE, nuisance_names, torque_columns
from sescid.kinematics import Workspace, padded
from sescid.robot import Robot
from sescid.sesc import STANDARD_GRAVITY

#: MAP prior standard deviation of a constant CoP offset: effectively flat, m
NUISANCE_PRIOR_COP = 1.0


@dataclass(frozen=True)
class Nuisance:
    """A nuisance parameter: a column of the system beside the SESC vectors."""

    kind: str  #: the measurement kind it belongs to ("cop", "tau")
    what: str  #: "offset" or "friction"
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

    kind: str
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
    gravity_accel: float = STANDARD_GRAVITY  #: |g| behind the torque rows, m/s²

    @property
    def size(self) -> int:
        """Length of θ."""
        return self.n_x + len(self.nuisance)

    @property
    def kinds(self) -> tuple[str, ...]:
        """The kinds with rows, in a fixed order."""
        return tuple(k for k in (COP, TORQUE) if k in self.parts)

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
            ne = NormalEquations(
                mine.ne.ata + part.ne.ata,
                mine.ne.atb + part.ne.atb,
                mine.ne.yty + part.ne.yty,
                mine.ne.n_rows + part.ne.n_rows,
                mine.ne.n_poses + part.ne.n_poses,
            )
            parts[kind] = dataclasses.replace(mine, ne=ne)
        return dataclasses.replace(
            a, parts=parts, n_poses=a.n_poses + b.n_poses, sources=a.sources + b.sources
        )


@dataclass(frozen=True)
class RowOptions:
    """How rows are made: weights from the standard-error columns, the total mass [kg] that
    scales the torque rows (None: the model's) and |g| [m/s²], a CoP offset column (MAP)."""

    weighted: bool = False
    total_mass: float | None = None
    cop_offset: bool = False
    gravity_accel: float = STANDARD_GRAVITY


class Accumulator:
    """The normal equations of one source (a file, or arrays), fed in chunks of any size."""

    def __init__(self, robot: Robot, options: RowOptions = RowOptions()):
        self.robot, self.options = robot, options
        self.mass = robot.total_mass if options.total_mass is None else float(options.total_mass)
        red = robot.reduction
        self.p_red = red.g.shape[0]
        self.cop_red = NormalEquations.empty(padded(self.p_red))
        self.cop_full: NormalEquations | None = None
        self.tau_red: NormalEquations | None = None
        self.first: Measurements | None = None
        self.pending: list[Measurements] = []
        self.n_pending = 0
        self.ws = Workspace(robot.tree, ACCUMULATE_BLOCK)
        self.n_poses = 0
        self.progress = None

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
        self.pending.append(m)
        self.n_pending += m.n
        whole = self.n_pending - self.n_pending % ACCUMULATE_BLOCK
        if whole:
            joined = concatenate(self.pending)
            self._blocks(joined.take(slice(0, whole)), progress)
            rest = joined.take(slice(whole, None))
            self.pending, self.n_pending = ([rest] if rest.n else []), rest.n

    def _blocks(self, m: Measurements, progress) -> None:
        """Rows of poses whose count is a multiple of the block (or the source's last ones)."""
        done = self.n_poses
        report = None if progress is None else (lambda d, _n: progress(done + d))
        self.n_poses += m.n
        if m.cop is not None:
            sw = _cop_weights(m) if self.options.weighted else None
            if m.gravity is None:
                y = m.cop - self.robot.d[:2]
                add_cop_reduced(self.robot, self.cop_red, m.q, y, sw, self.ws, report)
            else:
                if self.cop_full is None:
                    self.cop_full = NormalEquations.empty(3 * len(self.robot.body_names))
                add_cop_tilted(self.robot, self.cop_full, m.q, m.cop, sw, m.gravity)
            self.cop_red.n_poses += m.n
        if m.tau is not None and m.tau_joints:
            size = padded(self.p_red + len(torque_nuisance(m)))  # the product's 4 × 4 blocks
            if self.tau_red is None:
                self.tau_red = NormalEquations.empty(size)
            for s in range(0, m.n, ACCUMULATE_BLOCK):
                blk = m.take(slice(s, s + ACCUMULATE_BLOCK))
                x, y, sw = torque_columns(
                    self.robot, blk, self.mass, self.options.weighted, self.options.gravity_accel
                )
                part = NormalEquations.empty(size)
                add_columns(part, x, y, sw)
                self.tau_red.ata += part.ata
                self.tau_red.atb += part.atb
                self.tau_red.yty += part.yty
                self.tau_red.n_rows += part.n_rows
                if progress is not None:
                    progress(done + min(s + ACCUMULATE_BLOCK, m.n))
            self.tau_red.n_poses += m.n

    def finish(self) -> System:
        """The source's system, in full coordinates (DataError when it had no poses)."""
        if self.pending:
            self._blocks(concatenate(self.pending), self.progress)
            self.pending, self.n_pending = [], 0
        if self.first is None or self.n_poses == 0:
            raise DataError("no poses to identify from")
        first = self.first
        nuisance = cop_offsets() if (COP in first.kinds and self.options.cop_offset) else ()
        n_x = 3 * len(self.robot.body_names)
        g = self.robot.reduction.g
        parts: dict[str, KindSums] = {}
        if COP in first.kinds:
            ne = NormalEquations.empty(n_x)
            p = self.p_red
            ne.ata += g.T @ upper_to_full(self.cop_red.ata)[:p, :p] @ g
            ne.atb += g.T @ self.cop_red.atb[:p]
            ne.yty += self.cop_red.yty
            ne.n_rows += self.cop_red.n_rows
            if self.cop_full is not None:
                ne.ata += self.cop_full.ata
                ne.atb += self.cop_full.atb
                ne.yty += self.cop_full.yty
                ne.n_rows += self.cop_full.n_rows
            ne.n_poses = self.cop_red.n_poses
            ne = _with_cop_offset(self.robot, ne) if self.options.cop_offset else ne
            parts[COP] = KindSums(COP, ne, self.options.weighted)
        system = System(n_x, nuisance, parts, self.mass, self.options.total_mass is not None)
        if self.tau_red is not None:
            t = self.tau_red
            k = len(torque_nuisance(first))
            size = self.p_red + k
            expand = np.zeros((size, n_x + k))
            expand[: self.p_red, :n_x] = g
            expand[self.p_red :, n_x:] = np.eye(k)
            full = upper_to_full(t.ata)[:size, :size]
            ne = NormalEquations(
                expand.T @ full @ expand, expand.T @ t.atb[:size], t.yty, t.n_rows, t.n_poses
            )
            tau_sys = System(
                n_x,
                torque_nuisance(first),
                {TORQUE: KindSums(TORQUE, ne, self.options.weighted)},
                self.mass,
                system.mass_given,
            )
            if parts:
                system = system.merged(dataclasses.replace(tau_sys, n_poses=0))
            else:
                system = tau_sys
        system.n_poses = self.n_poses
        system.sources = [first.source]
        system.gravity_accel = self.options.gravity_accel
        return system


def _cop_weights(m: Measurements) -> np.ndarray:
    if m.cop_se is None:
        raise DataError(f"{m.source}: weighted CoP rows need the cop_se_x, cop_se_y columns")
    return 1.0 / m.cop_se


def _with_cop_offset(robot: Robot, ne: NormalEquations) -> NormalEquations:
    """The CoP sums with two offset columns appended. A constant offset b shifts every CoP row
    as the support body's r would by Δr0 = R_rootᵀ (b_x, b_y, 0) (its row is constant, level or
    tilted), so [Φ, B] = Φ T with T = [I, E] and the sums follow as Tᵀ(·)T."""
    n_x = ne.ata.shape[0]
    t = np.zeros((n_x, n_x + 2))
    t[:, :n_x] = np.eye(n_x)
    t[:3, n_x:] = robot.tree.root_r.T[:, :2]
    return NormalEquations(t.T @ ne.ata @ t, t.T @ ne.atb, ne.yty, ne.n_rows, ne.n_poses)


def accumulate_sources(
    robot: Robot, sources, options: RowOptions = RowOptions(), progress=None
) -> System:
    """The pooled system of several sources, each an iterable of ``Measurements`` chunks
    (validated); ``progress(poses_done)`` counts the poses of all sources."""
    system: System | None = None
    before = 0
    for chunks in sources:
        acc = Accumulator(robot, options)
        start = before
        report = None if progress is None else (lambda d, s0=start: progress(s0 + d))
        for m in chunks:
            acc.add(m, report)
        part = acc.finish()
        before += part.n_poses
        system = part if system is None else system.merged(part)
    if system is None:
        raise DataError("no data to identify from")
    return system
