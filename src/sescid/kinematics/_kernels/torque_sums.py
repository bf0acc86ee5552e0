"""The torque kind's fused sums from Python: the data of a block (``TorqueBlock``), the pass
(``gram_fused``: torques alone or with a level CoP), and the raw accumulator read once
(``fold_torque``: the symmetric sums in ``Reduction`` order). The kernels are ``torque``'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sescid.kinematics._kernels.fused import GRAM_BLOCK, augmented_size, reduced_order
from sescid.kinematics._kernels.gram import padded
from sescid.kinematics._kernels.reduced import Reduction
from sescid.kinematics._kernels.torque import gram_fused_kernel
from sescid.kinematics._kernels.torque_plan import TorquePlan
from sescid.kinematics.tree import Tree

#: (ΦᵀWΦ, ΦᵀWy, yᵀWy) of one block
Sums = tuple[np.ndarray, np.ndarray, float]


@dataclass(frozen=True)
class TorqueBlock:
    """Validated torque data of a block: tau (n, J) N·m, square-root weights sw (n, J) or None,
    approach sides (n,) or None, and M·g0 [kg·m/s²] (total mass × |g|)."""

    tau: np.ndarray
    sw: np.ndarray | None
    approach: np.ndarray | None
    mass_g0: float


def torque_size(plan: TorquePlan) -> int:
    """Rows of the torque augmented accumulator (padded to 4)."""
    return padded(plan.target + 1)


def gram_fused(
    tree: Tree,
    red: Reduction,
    plan: TorquePlan,
    q: np.ndarray,
    torque: TorqueBlock,
    cop: tuple[np.ndarray, np.ndarray | None] | None = None,
) -> tuple[Sums | None, Sums] | None:
    """The torque rows' sums (ΦᵀWΦ, ΦᵀWy, yᵀWy) over [reduced columns; nuisance] of validated
    poses q (n, nq), level support, and with ``cop`` = (y (n, 2) m, square-root weights (n, 2)
    or None) the CoP's reduced sums (``fused.gram_reduced``'s) from the same pass: (CoP sums or
    None, torque sums). ``red.rows`` must be (0, 1). None when an angle needs numpy's exact
    reduction."""
    p = red.g.shape[0]
    out_t = np.zeros((torque_size(plan),) * 2)
    out_c = None if cop is None else np.zeros((augmented_size(p),) * 2)
    if not add_gram_fused(tree, red, plan, q, torque, cop, (out_t, out_c)):
        return None
    cop_sums = None if out_c is None else reduced_order(out_c, tree, 2, p)
    return cop_sums, fold_torque(out_t, plan, p)


def add_gram_fused(
    tree: Tree,
    red: Reduction,
    plan: TorquePlan,
    q: np.ndarray,
    torque: TorqueBlock,
    cop: tuple[np.ndarray, np.ndarray | None] | None,
    out: tuple[np.ndarray, np.ndarray | None],
) -> bool:
    """``gram_fused``'s sums added to out = (torque accumulator (torque_size(plan),) * 2,
    ``fold_torque`` reads it; CoP accumulator (augmented_size(P_red),) * 2 or None,
    ``fused.reduced_order`` reads it), raw, once after any number of blocks. False (nothing
    added) when an angle needs numpy's exact reduction."""
    if red.rows != (0, 1):
        raise ValueError("the fused torque pass takes the CoP's rows (0, 1)")
    nj = torque.tau.shape[1]
    empty = np.empty((0, nj))
    out_t, out_c = out
    if cop is None or out_c is None:
        y_c, sw_c, out_c = np.empty((0, 2)), np.empty((0, 2)), np.zeros((0, 0))
    else:
        y_c = np.ascontiguousarray(cop[0], dtype=float)
        sw_c = np.empty((0, 2)) if cop[1] is None else np.ascontiguousarray(cop[1], dtype=float)
    return bool(
        gram_fused_kernel(
            q, y_c, sw_c, np.ascontiguousarray(torque.tau, dtype=float),
            empty if torque.sw is None else np.ascontiguousarray(torque.sw, dtype=float),
            np.empty(0) if torque.approach is None else np.ascontiguousarray(torque.approach),
            float(torque.mass_g0), tree.jcol, tree.coef, tree.off, tree.parent, tree.nz_ptr,
            tree.nz_k, tree.nz_j, tree.nz_a, tree.root_r, red.u, tree.depth_first[1],
            plan.meas, plan.axis, plan.own_ptr, plan.own, plan.lrows, plan.tasks, plan.n_sesc,
            GRAM_BLOCK, out_c, out_t,
        )
    )  # fmt: skip


def fold_torque(
    out: np.ndarray, plan: TorquePlan, p_red: int
) -> tuple[np.ndarray, np.ndarray, float]:
    """(ΦᵀWΦ, ΦᵀWy, yᵀWy) over [reduced columns (``Reduction`` order, p_red); nuisance] from the
    torque accumulator (each pair summed once, in either triangle)."""
    t = plan.target
    a = out[: t + 1, : t + 1]
    full = a + a.T
    full[np.diag_indices(t + 1)] = np.diag(a)
    k = plan.n_nuisance
    where = np.concatenate([plan.to_reduced, p_red + np.arange(k)])
    size = p_red + k
    ata = np.zeros((size, size))
    ata[np.ix_(where, where)] = full[:t, :t]
    atb = np.zeros(size)
    atb[where] = full[:t, t]
    return ata, atb, float(full[t, t])
