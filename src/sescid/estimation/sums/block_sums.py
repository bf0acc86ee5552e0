"""The sums of one block of poses, every measurement kind, in one pass where one suffices.

A block (``ACCUMULATE_BLOCK`` poses counted from a source's first pose) gives the CoP's reduced
sums, a tilted CoP's full ones and the torque rows' reduced sums (with their nuisance columns).
On the compiled path a level CoP and level torques share one chain: the fused kernel computes
the rotations' rows x, y once and feeds both products (``kinematics.gram_fused``); a tilted
support, a mimic joint among the measured ones or an angle beyond the kernels' range takes the
explicit rows with the same fixed-order product. Small jobs take numpy (``use_kernels``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from sescid.errors import DataError
from sescid.estimation.data.balance_rows import balance_rows
from sescid.estimation.data.measurements import Measurements, concatenate
from sescid.estimation.data.torque_rows import torque_columns
from sescid.estimation.sums.normal_equations import (
    NormalEquations,
    add_columns,
    reduced_sums,
    tilted_sums,
)
from sescid.kinematics import (
    TorqueBlock,
    TorquePlan,
    add_gram_fused,
    add_gram_reduced,
    augmented_size,
    torque_plan,
    torque_size,
)
from sescid.robot import Robot


@dataclass
class BlockSums:
    """One block's sums per kind (None: the kind has no rows in the block)."""

    cop_red: NormalEquations | None = None  #: level CoP, reduced coordinates
    cop_full: NormalEquations | None = None  #: tilted CoP, full coordinates
    balance: NormalEquations | None = None  #: balance on a line, full coordinates
    tau_red: NormalEquations | None = None  #: torques: reduced coordinates, then nuisance
    #: the compiled passes' raw accumulators (``fused.reduced_order``, ``torque.fold_torque``
    #: read their sum over the blocks once) and their rows
    cop_raw: np.ndarray | None = None
    tau_raw: np.ndarray | None = None
    cop_rows: int = 0
    tau_rows: int = 0


@dataclass(frozen=True)
class RowMaker:
    """What turns a source's blocks into sums: the robot, the path (``kernels``), whether rows
    are weighted (the torque rows: ``tau_w``), the total mass [kg] and |g| [m/s²] of the
    torque rows."""

    robot: Robot
    kernels: bool
    weighted: bool
    mass: float
    g0: float
    tau_joints: tuple[str, ...] = ()
    friction: bool = False
    tau_weighted: bool | None = None  #: torque rows weighted (None: as ``weighted``)

    @property
    def tau_w(self) -> bool:
        """Whether the torque rows are weighted by their standard errors."""
        return self.weighted if self.tau_weighted is None else self.tau_weighted

    @cached_property
    def plan(self) -> TorquePlan | None:
        """The fused torque plan for these joints (None: a mimic joint among them)."""
        if not self.tau_joints:
            return None
        cols = self.robot.joint_columns(self.tau_joints)
        return torque_plan(self.robot.tree, cols, self.friction, len(self.robot.reduction.rows))

    def sums(self, m: Measurements) -> BlockSums:
        """The sums of one block of validated measurements."""
        out = BlockSums()
        level = m.gravity is None
        cop_sw = _cop_weights(m) if (self.weighted and m.cop is not None) else None
        missing = m.cop_missing
        if missing:  # a coordinate not measured: a row of weight 0, not counted
            assert m.cop is not None
            mask = ~np.isnan(m.cop)
            cop_sw = mask.astype(float) if cop_sw is None else np.where(mask, cop_sw, 0.0)
            m = dataclasses.replace(m, cop=np.where(mask, m.cop, 0.0))
        has_tau = m.tau is not None and bool(m.tau_joints)
        if m.balance is not None:
            assert m.gravity is not None
            x, y = balance_rows(self.robot, m.q, m.balance, m.gravity)
            out.balance = NormalEquations.empty(x.shape[0])
            add_columns(out.balance, x, y, None, self.kernels)
        if m.cop is not None and not level:
            out.cop_full = tilted_sums(self.robot, m.q, m.cop, cop_sw, m.gravity, self.kernels)
            out.cop_full.n_rows -= missing
        if self.kernels and level and self._compiled(m, cop_sw, out):
            out.cop_rows -= missing if out.cop_raw is not None else 0
            if not has_tau or out.tau_raw is not None:
                return out
        elif m.cop is not None and level:
            y = m.cop - self.robot.d[:2]
            out.cop_red = reduced_sums(self.robot, m.q, y, cop_sw, self.kernels, None)
            out.cop_red.n_rows -= missing
        if has_tau:
            x, y, sw = torque_columns(self.robot, m, self.mass, self.tau_w, self.g0)
            out.tau_red = NormalEquations.empty(x.shape[0])
            add_columns(out.tau_red, x, y, sw, self.kernels)
        return out

    def _compiled(self, m: Measurements, cop_sw, out: BlockSums) -> bool:
        """A level block on the compiled passes: the CoP (and the torques, when their plan
        allows) into raw accumulators. False (nothing added) when an angle is beyond the
        kernels' range."""
        red = self.robot.reduction
        p = red.g.shape[0]
        cop = None if m.cop is None else (m.cop - self.robot.d[:2], cop_sw)
        raw_c = None if cop is None else np.zeros((augmented_size(p),) * 2)
        if m.tau is None or not m.tau_joints or self.plan is None:
            if cop is None or raw_c is None:
                return True  # torques with a mimic joint: the explicit rows
            if not add_gram_reduced(self.robot.tree, red, m.q, cop[0], cop[1], raw_c):
                return False
            out.cop_raw, out.cop_rows = raw_c, 2 * m.n
            return True
        tau_sw = None
        if self.tau_w:
            if m.tau_se is None:
                raise DataError(f"{m.source}: weighted torques need tau_se_<joint> columns")
            tau_sw = 1.0 / m.tau_se
        rows = TorqueBlock(m.tau, tau_sw, m.approach, self.mass * self.g0)
        raw_t = np.zeros((torque_size(self.plan),) * 2)
        if not add_gram_fused(self.robot.tree, red, self.plan, m.q, rows, cop, (raw_t, raw_c)):
            return False
        out.tau_raw, out.tau_rows = raw_t, m.n * len(m.tau_joints)
        if raw_c is not None:
            out.cop_raw, out.cop_rows = raw_c, 2 * m.n
        return True


def _cop_weights(m: Measurements) -> np.ndarray:
    if m.cop_se is None:
        raise DataError(f"{m.source}: weighted CoP rows need the cop_se_x, cop_se_y columns")
    return 1.0 / m.cop_se


def work(robot: Robot, m: Measurements, n: int) -> int:
    """Work units (``kinematics.NUMPY_JOB``) of n poses measured like ``m``: the chain, and a row
    of reduced columns per CoP axis, per measured torque and per balance."""
    rows = 2 * (m.cop is not None) + len(m.tau_joints) * (m.tau is not None)
    rows += m.balance is not None
    return n * (len(robot.body_names) + rows * robot.reduction.g.shape[0])


def aligned(chunks: Iterable[Measurements], size: int) -> Iterable[Measurements]:
    """Consecutive blocks of ``size`` poses (the last may be shorter) of chunks of any size:
    views into the chunks, a copy only for a block that spans two of them; a block never spans
    two stances (``Measurements.support``: a chunk of another ends the block before it)."""
    carry: Measurements | None = None
    for m in chunks:
        if carry is not None and carry.support != m.support:  # a block holds one stance
            yield carry
            carry = None
        if carry is not None:
            need = size - carry.n
            if m.n < need:
                carry = concatenate([carry, m])
                continue
            yield concatenate([carry, m.take(slice(0, need))])
            m = m.take(slice(need, None))
            carry = None
        whole = m.n - m.n % size
        for s in range(0, whole, size):
            yield m.take(slice(s, s + size))
        if m.n > whole:
            carry = m.take(slice(whole, None))
    if carry is not None:
        yield carry
