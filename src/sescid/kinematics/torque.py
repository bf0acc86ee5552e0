"""The joint torques' normal equations in the fused pass: one chain (the CoP's rows x, y) feeds the
CoP's product and the torque rows' blocks (``torque_plan``), Φ never written to memory.

The torque accumulator is augmented like the CoP's: its columns are the moving bodies' reduced
columns in depth-first order, the measured joints' offsets (and friction bands), then the
targets; each pair of columns is summed once, in a fixed order (``gram``'s 8-lane FMA tiles),
and ``fold_torque`` turns it into the symmetric sums in ``Reduction`` order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sescid.kinematics.compile import GROUP, lazy_njit, simd_intrinsic
from sescid.kinematics.fused import (
    GRAM_BLOCK,
    _angles_ok,
    _block_chain,
    _cop_columns,
    augmented_size,
)
from sescid.kinematics.gram import _syrk, _tile, padded
from sescid.kinematics.reduced import Reduction
from sescid.kinematics.torque_plan import ROW_OFFSET, ROW_PAIR, TorquePlan
from sescid.kinematics.tree import Tree

fma = simd_intrinsic("fma")
vload = simd_intrinsic("vload")
vzero = simd_intrinsic("vzero")
vfma = simd_intrinsic("vfma")
vsum = simd_intrinsic("vsum")


@lazy_njit(GROUP, cache=True, nogil=True, inline="always")
def _dot(a, ia, b, ib, kk):  # pragma: no cover - compiled
    """Σ_{k<kk} a.flat[ia + k] b.flat[ib + k] in 8 lanes (kk a multiple of 8)."""
    acc = vzero()
    for k in range(0, kk, 8):
        acc = vfma(vload(a, ia + k), vload(b, ib + k), acc)
    return vsum(acc)


@lazy_njit(GROUP, cache=True, nogil=True)
def _torque_rows(rot, w, seg, s0, tau, tau_sw, approach, mg, u, order, meas, axis, coef,
                 v, lev, e):  # fmt: skip  # pragma: no cover - compiled
    """The sub-block's columns v[2·pos + l, q·seg + k] = (R_i u_{i,l})_q (depth-first), the
    measured joints' weighted levers lev[m, q, k] = s·w_q and rows e[m] = (s, s·approach,
    s·τ) (s the square-root weight); zero for k ≥ w."""
    weighted = tau_sw.shape[0] > 0
    friction = approach.shape[0] > 0
    for idx in range(order.shape[0]):
        b = order[idx]
        for lc in range(2):
            row = v[2 * idx + lc]
            u0, u1, u2 = u[b, lc, 0], u[b, lc, 1], u[b, lc, 2]
            for q in range(2):
                o = q * seg
                r0 = rot[b, 0, q]
                r1 = rot[b, 1, q]
                r2 = rot[b, 2, q]
                for k in range(w):
                    row[o + k] = r0[k] * u0 + r1[k] * u1 + r2[k] * u2
                for k in range(w, seg):
                    row[o + k] = 0.0
    for b in range(1, rot.shape[0]):
        m = meas[b]
        if m < 0:
            continue
        f = mg * coef[b]
        a0, a1, a2 = axis[b, 0], axis[b, 1], axis[b, 2]
        for k in range(w):
            ax = rot[b, 0, 0, k] * a0 + rot[b, 1, 0, k] * a1 + rot[b, 2, 0, k] * a2
            ay = rot[b, 0, 1, k] * a0 + rot[b, 1, 1, k] * a1 + rot[b, 2, 1, k] * a2
            sk = tau_sw[s0 + k, m] if weighted else 1.0
            lev[m, 0, k] = -(f * ay) * sk
            lev[m, 1, k] = (f * ax) * sk
            e[m, 0, k] = sk
            e[m, 1, k] = sk * approach[s0 + k] if friction else 0.0
            e[m, 2, k] = tau[s0 + k, m] * sk
        for k in range(w, seg):
            lev[m, 0, k] = 0.0
            lev[m, 1, k] = 0.0
            e[m, 0, k] = 0.0
            e[m, 1, k] = 0.0
            e[m, 2, k] = 0.0


@lazy_njit(GROUP, cache=True, nogil=True)
def _prefix(seg, order, parent, meas, lev, e, sp, zp):  # pragma: no cover - compiled
    """Down the tree: sp[c] = (xx, xy, yy) of Σ s²w wᵀ and zp[c, q·seg + k] = Σ s²τ w_q over the
    measured joints on the path support → c (a body's parent before the body)."""
    for idx in range(order.shape[0]):
        c = order[idx]
        p = parent[c]
        for k in range(seg):
            sp[c, 0, k] = sp[p, 0, k] if p > 0 else 0.0
            sp[c, 1, k] = sp[p, 1, k] if p > 0 else 0.0
            sp[c, 2, k] = sp[p, 2, k] if p > 0 else 0.0
            zp[c, k] = zp[p, k] if p > 0 else 0.0
            zp[c, seg + k] = zp[p, seg + k] if p > 0 else 0.0
        m = meas[c]
        if m < 0:
            continue
        for k in range(seg):
            t0 = lev[m, 0, k]
            t1 = lev[m, 1, k]
            y = e[m, 2, k]
            sp[c, 0, k] = fma(t0, t0, sp[c, 0, k])
            sp[c, 1, k] = fma(t0, t1, sp[c, 1, k])
            sp[c, 2, k] = fma(t1, t1, sp[c, 2, k])
            zp[c, k] = fma(t0, y, zp[c, k])
            zp[c, seg + k] = fma(t1, y, zp[c, seg + k])


@lazy_njit(GROUP, cache=True, nogil=True)
def _left_rows(seg, lrows, v, lev, e, sp, ul):  # pragma: no cover - compiled
    """The left rows of the plan's blocks: a column transformed by S_c, or a joint's offset or
    friction row (s·w_q times s or s·approach)."""
    for r in range(lrows.shape[0]):
        kind, src, c = lrows[r, 0], lrows[r, 1], lrows[r, 2]
        out = ul[r]
        if kind == ROW_PAIR:
            col = v[src]
            for k in range(seg):
                v0 = col[k]
                v1 = col[seg + k]
                out[k] = fma(sp[c, 1, k], v1, sp[c, 0, k] * v0)
                out[seg + k] = fma(sp[c, 2, k], v1, sp[c, 1, k] * v0)
        else:
            er = e[src, 0] if kind == ROW_OFFSET else e[src, 1]
            for k in range(seg):
                out[k] = lev[src, 0, k] * er[k]
                out[seg + k] = lev[src, 1, k] * er[k]


@lazy_njit(GROUP, cache=True, nogil=True)
def _blocks(seg, lrows, tasks, n_sesc, ul, v, out):  # pragma: no cover - compiled
    """Each block of the plan as 4 × 4 tiles (rows clamped at the block's edge, only its own
    entries written): out[row, col] += Σ ul[row] v[col] over the sub-block, once per pair."""
    ldl = ul.shape[1]
    ldv = v.shape[1]
    kk = 2 * seg
    for t in range(tasks.shape[0]):
        ls, lc, rs, rc, oc = tasks[t, 0], tasks[t, 1], tasks[t, 2], tasks[t, 3], tasks[t, 4]
        for r0 in range(0, lc, 4):
            ra = ls + r0
            a0 = ra * ldl
            a1 = (ls + min(r0 + 1, lc - 1)) * ldl
            a2 = (ls + min(r0 + 2, lc - 1)) * ldl
            a3 = (ls + min(r0 + 3, lc - 1)) * ldl
            for c0 in range(0, rc, 4):
                b0 = (rs + c0) * ldv
                b1 = (rs + min(c0 + 1, rc - 1)) * ldv
                b2 = (rs + min(c0 + 2, rc - 1)) * ldv
                b3 = (rs + min(c0 + 3, rc - 1)) * ldv
                tile = _tile(ul, a0, a1, a2, a3, v, b0, b1, b2, b3, kk)
                for i in range(min(4, lc - r0)):
                    orow = lrows[ra + i, 3]
                    for j in range(min(4, rc - c0)):
                        ocol = oc + c0 + j
                        if orow >= n_sesc or ocol >= orow:
                            out[orow, ocol] += tile[4 * i + j]


@lazy_njit(GROUP, cache=True, nogil=True)
def _targets(seg, order, n_sesc, friction, v, zp, e, out):  # pragma: no cover - compiled
    """The targets' column and the nuisance block: columns × y from the prefix zp, and per
    measured joint offset/friction against each other and y, and yᵀy."""
    nj = e.shape[0]
    yc = n_sesc + nj * (2 if friction else 1)
    ldv = v.shape[1]
    ldz = zp.shape[1]
    for idx in range(order.shape[0]):
        b = order[idx]
        for lc in range(2):
            row = 2 * idx + lc
            out[row, yc] += _dot(zp, b * ldz, v, row * ldv, 2 * seg)
    lde = e.shape[2]
    for m in range(nj):
        e0 = (3 * m) * lde
        e1 = (3 * m + 1) * lde
        ey = (3 * m + 2) * lde
        off = n_sesc + m
        out[off, off] += _dot(e, e0, e, e0, seg)
        out[off, yc] += _dot(e, e0, e, ey, seg)
        if friction:
            fr = n_sesc + nj + m
            out[off, fr] += _dot(e, e0, e, e1, seg)
            out[fr, fr] += _dot(e, e1, e, e1, seg)
            out[fr, yc] += _dot(e, e1, e, ey, seg)
        out[yc, yc] += _dot(e, ey, e, ey, seg)


@lazy_njit(GROUP, cache=True, nogil=True)
def _gram_fused(q, cop_y, cop_sw, tau, tau_sw, approach, mg, jcol, coef, off, parent, nz_ptr,
                nz_k, nz_j, nz_a, root_r, u, order, meas, axis, lrows, tasks, n_sesc, blk,
                out_cop, out_tau):  # fmt: skip  # pragma: no cover - compiled
    """The CoP's (when out_cop has rows) and the torques' augmented sums of poses q in one pass
    over the chain's rows x, y; False (nothing added) when an angle is beyond MAX_ANGLE."""
    if not _angles_ok(q):
        return False
    n, nq = q.shape
    nb = parent.shape[0]
    nj = tau.shape[1]
    rows = np.arange(2)
    rot = np.zeros((nb, 3, 2, blk))
    s = np.zeros(blk)
    c1 = np.zeros(blk)
    mk = np.zeros(blk)
    qt = np.zeros((nq, blk))
    pc = out_cop.shape[0]
    x = np.zeros((pc, 2 * blk))
    v = np.zeros((n_sesc + 4, 2 * blk))
    lev = np.zeros((nj, 2, blk))
    e = np.zeros((nj, 3, blk))
    sp = np.zeros((nb, 3, blk))
    zp = np.zeros((nb, 2 * blk))
    ul = np.zeros((lrows.shape[0] + 4, 2 * blk))
    friction = approach.shape[0] > 0
    for s0 in range(0, n, blk):
        w = min(blk, n - s0)
        seg = (w + 7) // 8 * 8
        _block_chain(q, s0, w, qt, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r,
                     rows, s, c1, mk, rot)  # fmt: skip
        if pc > 0:
            _cop_columns(rot, w, seg, s0, cop_y, cop_sw, u, x)
            _syrk(x, pc, 2 * seg, out_cop)
        _torque_rows(rot, w, seg, s0, tau, tau_sw, approach, mg, u, order, meas, axis, coef,
                     v, lev, e)  # fmt: skip
        _prefix(seg, order, parent, meas, lev, e, sp, zp)
        _left_rows(seg, lrows, v, lev, e, sp, ul)
        _blocks(seg, lrows, tasks, n_sesc, ul, v, out_tau)
        _targets(seg, order, n_sesc, friction, v, zp, e, out_tau)
    return True


@dataclass(frozen=True)
class TorqueRows:
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
    torque: TorqueRows,
    cop: tuple[np.ndarray, np.ndarray | None, np.ndarray] | None,
    out_tau: np.ndarray,
) -> bool:
    """Add the torque rows' augmented sums of validated poses q (n, nq), level support, to
    out_tau ((torque_size(plan),) * 2; ``fold_torque`` reads it) and, with ``cop`` = (y (n, 2)
    m, square-root weights (n, 2) or None, out_cop (augmented_size(P_red),) * 2), the CoP's
    (``fused.gram_reduced``'s layout) in the same pass. ``red.rows`` must be (0, 1). False
    (nothing added) when an angle needs numpy's exact reduction."""
    if red.rows != (0, 1):
        raise ValueError("the fused torque pass takes the CoP's rows (0, 1)")
    nj = torque.tau.shape[1]
    empty = np.empty((0, nj))
    if cop is None:
        y_c, sw_c, out_c = np.empty((0, 2)), np.empty((0, 2)), np.zeros((0, 0))
    else:
        y_c = np.ascontiguousarray(cop[0], dtype=float)
        sw_c = np.empty((0, 2)) if cop[1] is None else np.ascontiguousarray(cop[1], dtype=float)
        out_c = cop[2]
        assert out_c.shape[0] == augmented_size(red.g.shape[0])
    return bool(
        _gram_fused(
            q, y_c, sw_c, np.ascontiguousarray(torque.tau, dtype=float),
            empty if torque.sw is None else np.ascontiguousarray(torque.sw, dtype=float),
            np.empty(0) if torque.approach is None else np.ascontiguousarray(torque.approach),
            float(torque.mass_g0), tree.jcol, tree.coef, tree.off, tree.parent, tree.nz_ptr,
            tree.nz_k, tree.nz_j, tree.nz_a, tree.root_r, red.u, plan.order, plan.meas,
            plan.axis, plan.lrows, plan.tasks, plan.n_sesc, GRAM_BLOCK, out_c, out_tau,
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
