"""How the fused pass sums the joint-torque rows: the tree's pairs of columns grouped by their
lowest common ancestor, as products of contiguous blocks of rows.

With the support level, the torque row of measured joint b at one pose is, in reduced coordinates
(``Reduction``: columns u_{i,l} ⊥ each body's axis), T[b, (i, l)] = w_b · v_{i,l} for the moving
bodies i in the subtree of b, where v_{i,l} = (R_i u_{i,l})_{x,y} (the CoP's reduced columns at
rows x, y) and w_b = M g0 coef_b (−(R_b a_b)_y, (R_b a_b)_x) (the lever of gravity about the
axis). The Gram of these nested rows, column pair by column pair, is

    Σ_b s_b² (w_b·v_i)(w_b·v_j) = v_iᵀ S_c v_j,  S_c = Σ_{measured b ∈ ancestors(c)} s_b² w_b w_bᵀ

with c the lowest common ancestor of i and j (a 2 × 2 prefix sum down the tree, s_b the row's
weight): about as many products as the CoP's two rows, where one rank-1 update per joint costs
Σ_b |subtree(b)|². In depth-first order every subtree is a contiguous range of columns, so the
pairs with ancestor c are two kinds of blocks: c's own two columns against its whole subtree, and
each child's subtree against the subtrees of the later children — rows transformed by S_c on the
left, plain columns on the right (``torque``'s tiles). The nuisance columns of joint b (offset,
friction) only meet columns of b's subtree: they ride along as two more rows of b's own block.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sescid.kinematics.tree import Tree

#: kinds of left rows: a column transformed by S_c, a joint's offset row, its friction row
ROW_PAIR, ROW_OFFSET, ROW_FRICTION = 0, 1, 2


@dataclass(frozen=True)
class TorquePlan:
    """The blocks of the torque rows' Gram for one tree and one set of measured joints."""

    order: np.ndarray  #: (N − 1,) moving bodies, depth-first (parents before children)
    pos: np.ndarray  #: (N,) each body's place in ``order`` (−1: the support body)
    meas: np.ndarray  #: (N,) index of the body's joint among the measured ones, −1 if none
    axis: np.ndarray  #: (N, 3) joint axes (body frame)
    coef: np.ndarray  #: (N,) sign × mimic multiplier of each body's joint
    lrows: np.ndarray  #: (L, 4) left rows: kind, source (V row or joint), node c, output index
    tasks: np.ndarray  #: (T, 5) left start, left count, right start, right count, output column
    n_sesc: int  #: 2 (N − 1) reduced columns of the moving bodies (depth-first)
    n_joints: int
    friction: bool
    to_reduced: np.ndarray  #: (n_sesc,) each depth-first column's index in ``Reduction`` order
    own_ptr: np.ndarray  #: (N + 1,) the left rows each body owns: own[own_ptr[b] : own_ptr[b + 1]]
    own: np.ndarray  #: (L,) left rows by owner (the body of the column or joint they come from)

    @property
    def n_nuisance(self) -> int:
        """Offsets (and friction bands) of the measured joints."""
        return self.n_joints * (2 if self.friction else 1)

    @property
    def target(self) -> int:
        """Index of the targets' column in the augmented accumulator."""
        return self.n_sesc + self.n_nuisance


def torque_plan(tree: Tree, cols: np.ndarray, friction: bool, nr: int) -> TorquePlan | None:
    """The plan for measured q columns ``cols`` (friction columns when the approach side is known;
    ``nr`` intercept columns in front of the reduced ones). None when a measured joint drives
    several bodies (a mimic joint): its row is no nested subtree row, the caller builds the rows
    explicitly."""
    nb = tree.parent.shape[0]
    meas = np.full(nb, -1, dtype=np.int64)
    for m, j in enumerate(np.asarray(cols, dtype=np.int64)):
        hit = np.flatnonzero(tree.jcol == j)
        if len(hit) != 1:
            return None
        meas[hit[0]] = m
    order, pos = tree.depth_first
    end = pos.copy()  # end of each subtree's range in ``order`` (exclusive)
    for b in order[::-1]:
        end[b] = max(end[b], pos[b] + 1)
        p = tree.parent[b]
        if p > 0:
            end[p] = max(end[p], end[b])
    n_sesc, n_j = 2 * (nb - 1), len(cols)
    seen = np.zeros(nb, dtype=bool)  # a measured joint on the path support → body
    for b in order:
        seen[b] = meas[b] >= 0 or (tree.parent[b] > 0 and seen[tree.parent[b]])
    lrows: list[tuple[int, int, int, int]] = []
    tasks: list[tuple[int, int, int, int, int]] = []
    for c in order:
        if not seen[c]:
            continue
        start = len(lrows)
        lrows += [(ROW_PAIR, 2 * pos[c] + lc, c, 2 * pos[c] + lc) for lc in range(2)]
        if meas[c] >= 0:
            lrows.append((ROW_OFFSET, meas[c], c, n_sesc + meas[c]))
            if friction:
                lrows.append((ROW_FRICTION, meas[c], c, n_sesc + n_j + meas[c]))
        span = 2 * (end[c] - pos[c])
        tasks.append((start, len(lrows) - start, 2 * pos[c], span, 2 * pos[c]))
        kids = [b for b in order if tree.parent[b] == c]
        for a, later in zip(kids[:-1], kids[1:], strict=True):
            start = len(lrows)
            rows = range(2 * pos[a], 2 * end[a])
            lrows += [(ROW_PAIR, r, c, r) for r in rows]
            first = 2 * pos[later]
            tasks.append((start, len(rows), first, 2 * end[c] - first, first))
    lr = np.asarray(lrows, dtype=np.int64).reshape(-1, 4)
    owner = np.where(lr[:, 0] == ROW_PAIR, order[lr[:, 1] // 2], lr[:, 2])
    by_owner = np.argsort(owner, kind="stable")
    own_ptr = np.searchsorted(owner[by_owner], np.arange(nb + 1)).astype(np.int64)
    to_red = np.empty(n_sesc, dtype=np.int64)
    for b in order:
        for lc in range(2):
            to_red[2 * pos[b] + lc] = nr + 2 * (b - 1) + lc
    return TorquePlan(
        order=order,
        pos=pos,
        meas=meas,
        axis=np.ascontiguousarray(tree.axis, dtype=float),
        coef=np.ascontiguousarray(tree.coef, dtype=float),
        lrows=lr,
        tasks=np.asarray(tasks, dtype=np.int64).reshape(-1, 5),
        n_sesc=n_sesc,
        n_joints=n_j,
        friction=friction,
        to_reduced=to_red,
        own_ptr=own_ptr,
        own=by_owner.astype(np.int64),
    )
