"""The residual pass of a fit: each kind's Σ|e|, Σe² and the count of rows, and for a simulation
Σ(CoP_true − predicted)², in one pass over the data (the CoP's true-error and residuals from the
same kinematics).

The RMS follows from the normal equations' sums; the MAE needs each row's residual at the final
estimate, which only the poses give. Sums run in blocks of ``RESIDUAL_BLOCK`` poses counted from
each source's first pose (the chunks a file arrives in do not matter: the same bits streamed or
in memory), blocks in order, each in a fixed order: compiled for a large fit
(``kinematics.cop_residual_sums``, the job being the fit's poses), numpy for a small one; never
BLAS.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from sescid.base.threads import ordered_map, usable_cores
from sescid.estimation.data.balance_rows import balance_residuals
from sescid.estimation.data.measurements import Measurements
from sescid.estimation.result.fit import Fit
from sescid.estimation.sums.block_sums import aligned
from sescid.estimation.sums.pooled import for_support
from sescid.kinds import BALANCE, COP, TORQUE
from sescid.kinematics import cop_residual_sums, torque_residual_sums, use_kernels

#: poses per block of the residual pass
RESIDUAL_BLOCK = 8192


@dataclass
class ResidualSums:
    """Running sums of a fit's residuals per kind."""

    abs_sum: dict[str, float] = field(default_factory=dict)
    sq_sum: dict[str, float] = field(default_factory=dict)
    count: dict[str, int] = field(default_factory=dict)
    truth_sq: float = 0.0
    truth_n: int = 0

    def add(self, kind: str, a: float, s: float, n: int) -> None:
        """Add a block's sums of one kind."""
        self.abs_sum[kind] = self.abs_sum.get(kind, 0.0) + a
        self.sq_sum[kind] = self.sq_sum.get(kind, 0.0) + s
        self.count[kind] = self.count.get(kind, 0) + n


def block_sums(fit: Fit, m: Measurements, kernels: bool) -> list[tuple[str, float, float, int]]:
    """(kind, Σ|e|, Σe², rows) of one block, and ("truth", 0, Σd², rows) for a simulation;
    a block of another stance (``Measurements.stance_on``) with the fit seen there."""
    fit = _stance_fit(fit, m.stance_on(fit.robot).label)
    out: list[tuple[str, float, float, int]] = []
    if m.balance is not None:
        assert m.gravity is not None
        e = balance_residuals(fit.robot, fit.r, m.q, m.balance, m.gravity)
        out.append((BALANCE, float(np.sum(np.abs(e))), float(np.sum(e * e)), m.n))
    if m.cop is not None and m.cop_missing:  # numpy over the measured coordinates
        y = m.cop - fit.cop_bias
        pred = fit.predict_cop(m.q, m.gravity)
        e = (y - pred).reshape(-1)
        e = e[~np.isnan(e)]
        out.append((COP, float(np.sum(np.abs(e))), float(np.sum(e * e)), e.size))
        if m.cop_true is not None:
            d = (m.cop_true - pred).reshape(-1)
            out.append(("truth", 0.0, float(np.sum(d * d)), d.size))
    elif m.cop is not None:
        y = m.cop - fit.cop_bias
        sums = None
        if kernels and m.gravity is None:
            sums = cop_residual_sums(fit.robot.tree, m.q, fit.r, y, m.cop_true)
        if sums is None:  # numpy: the CoM's plain sums, then fixed-order reductions
            pred = fit.predict_cop(m.q, m.gravity)
            e = (y - pred).reshape(-1)
            sums = [float(np.sum(np.abs(e))), float(np.sum(e * e)), 0.0]
            if m.cop_true is not None:
                d = (m.cop_true - pred).reshape(-1)
                sums[2] = float(np.sum(d * d))
        out.append((COP, float(sums[0]), float(sums[1]), 2 * m.n))
        if m.cop_true is not None:
            out.append(("truth", 0.0, float(sums[2]), 2 * m.n))
    if m.tau is not None and m.tau_joints:
        off, fr = (fit.torque_nuisance(w, m.tau_joints) for w in ("offset", "friction"))
        if kernels and m.gravity is None:
            mass = fit.total_mass if math.isfinite(fit.total_mass) else fit.robot.total_mass
            sums = torque_residual_sums(
                fit.robot.tree, m.q, fit.r, mass * fit.gravity_accel,
                fit.robot.joint_columns(m.tau_joints), (m.tau, m.approach, off, fr),
            )  # fmt: skip
            if sums is not None:
                out.append((TORQUE, float(sums[0]), float(sums[1]), m.tau.size))
                return out
        e = m.tau - fit.predict_torque(m.q, m.tau_joints, m.gravity) - off
        if m.approach is not None:
            e = e - m.approach[:, None] * fr
        flat = e.reshape(-1)
        out.append((TORQUE, float(np.sum(np.abs(flat))), float(np.sum(flat * flat)), flat.size))
    return out


def _stance_fit(fit: Fit, support: str) -> Fit:
    """``pooled.for_support(fit, support)``, kept on the fit's body record for the next block."""
    cache = fit.bodies.__dict__.setdefault("_stance_fits", {}) if fit.bodies is not None else {}
    if support not in cache:
        cache[support] = for_support(fit, support)
    return cache[support]


def _blocks(chunks: Iterable[Measurements]) -> Iterable[Measurements]:
    """The source's poses in blocks of ``RESIDUAL_BLOCK`` from its first, whatever its chunks
    (only a block that spans two chunks is copied)."""
    yield from aligned(chunks, RESIDUAL_BLOCK)


def residual_sums(fit: Fit, sources: Iterable[Iterable[Measurements]]) -> ResidualSums:
    """The residual sums of a fit over its sources (each an iterable of chunks), in one pass."""
    out = ResidualSums()
    rows = sum(k.n_rows for k in fit.kinds)  # the job: as the accumulation counted it
    kernels = use_kernels(
        fit.n_poses * len(fit.robot.body_names) + rows * fit.robot.reduction.g.shape[0]
    )
    for chunks in sources:
        batch: list[Measurements] = []
        for blk in _blocks(chunks):
            batch.append(blk)
            if len(batch) == 2 * usable_cores():  # a few blocks at a time on every core
                _add(out, ordered_map(lambda b: block_sums(fit, b, kernels), batch))
                batch = []
        _add(out, ordered_map(lambda b: block_sums(fit, b, kernels), batch))
    return out


def _add(out: ResidualSums, parts: Iterable[list[tuple[str, float, float, int]]]) -> None:
    for part in parts:
        for kind, a, s, n in part:
            if kind == "truth":
                out.truth_sq += s
                out.truth_n += n
            else:
                out.add(kind, a, s, n)
