"""The residual pass of a fit: Σ|e|, Σe² of the CoP residuals e = y − CoM_xy(q; r) and, for a
simulation, Σ(y_true − CoM_xy)², or of the joint torques' residuals (level support), in one
compiled pass per block, nothing written per pose.

The RMS follows from the normal equations' sums; the MAE needs each row's residual at the final
estimate, so one more pass over the poses — this one: the fused chain (rows x, y, FMAs), the
CoM summed body by body in FMAs, the residuals' sums in 8 lanes (fixed order). Its bits differ
from ``cop``'s plain sums, so the path is the job's (``use_kernels``); numpy's twin for small
jobs sums in a fixed order too (no BLAS dot).
"""

from __future__ import annotations

import numpy as np

from sescid.kinematics._kernels.fused import (
    GRAM_BLOCK,
    angles_ok,
    block_angles,
    body_columns,
    chain_buffers,
)
from sescid.kinematics._kernels.intrinsics import (
    vabs,
    vadd,
    vfma,
    vload,
    vmul,
    vneg,
    vsplat,
    vstore,
    vsub,
    vsum,
    vzero,
)
from sescid.kinematics.compile import GROUP, lazy_njit
from sescid.kinematics.tree import Tree


@lazy_njit(GROUP, cache=True, nogil=True)
def _cop_residual_sums(q, y, y2, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r,
                       root_o, r, blk, out):  # fmt: skip  # pragma: no cover - compiled
    """Out = (Σ|y − c|, Σ(y − c)², Σ(y2 − c)²) over the poses q (n, nq) and both axes, c the
    CoM's x, y for SESC vectors r (N, 3); y, y2 (n, 2) (y2 (0, 2): none). False (nothing
    written) when an angle is beyond MAX_ANGLE."""
    if not angles_ok(q):
        return False
    n, nq, nb, rot, s, c1, qt = chain_buffers(q, parent, 2, blk)
    rows = np.arange(2)
    tgt = np.zeros((3, 2, blk))  # y, y2 and the mask (1 for a pose of the block, 0 past it)
    dummy = np.zeros((1, 8))
    no_u = np.zeros((1, 2, 3))
    pos = np.zeros(nb, dtype=np.int64)
    truth = y2.shape[0] > 0
    a_abs = vzero()
    a_sq = vzero()
    a_tr = vzero()
    for s0 in range(0, n, blk):
        w, seg = block_angles(q, s0, blk, qt)
        tgt[:, :, w:] = 0.0
        for k in range(w):
            for i in range(2):
                tgt[0, i, k] = y[s0 + k, i]
                tgt[1, i, k] = y2[s0 + k, i] if truth else 0.0
                tgt[2, i, k] = 1.0
        for b in range(nb):
            body_columns(b, w, seg, qt, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r,
                         rows, no_u, pos, s, c1, rot, dummy, False)  # fmt: skip
        for i in range(2):
            for k in range(0, seg, 8):
                c = vsplat(root_o[i])
                for b in range(nb):
                    base = (b * 6 + i) * blk + k  # rot[b, j, i] at ((b·3 + j)·2 + i)·blk
                    c = vfma(vload(rot, base), vsplat(r[b, 0]), c)
                    c = vfma(vload(rot, base + 2 * blk), vsplat(r[b, 1]), c)
                    c = vfma(vload(rot, base + 4 * blk), vsplat(r[b, 2]), c)
                mask = vload(tgt, (4 + i) * blk + k)
                e = vmul(vsub(vload(tgt, i * blk + k), c), mask)
                a_abs = vadd(a_abs, vabs(e))
                a_sq = vfma(e, e, a_sq)
                if truth:
                    d = vmul(vsub(vload(tgt, (2 + i) * blk + k), c), mask)
                    a_tr = vfma(d, d, a_tr)
    out[0] = vsum(a_abs)
    out[1] = vsum(a_sq)
    out[2] = vsum(a_tr)
    return True


def cop_residual_sums(
    tree: Tree, q: np.ndarray, r: np.ndarray, y: np.ndarray, y2: np.ndarray | None
) -> np.ndarray | None:
    """(Σ|y − c|, Σ(y − c)², Σ(y2 − c)²) [m, m², m²] over validated poses q (n, nq) and both
    axes, c = CoM_xy(q) for SESC vectors r (N, 3); y, y2 (n, 2) targets (y2 None: 0). One
    compiled pass; None when an angle needs numpy's exact reduction."""
    out = np.zeros(3)
    ok = _cop_residual_sums(
        q, np.ascontiguousarray(y, dtype=float),
        np.empty((0, 2)) if y2 is None else np.ascontiguousarray(y2, dtype=float),
        tree.jcol, tree.coef, tree.off, tree.parent, tree.nz_ptr, tree.nz_k, tree.nz_j,
        tree.nz_a, tree.root_r, tree.root_o, np.ascontiguousarray(r, dtype=float).reshape(-1, 3),
        GRAM_BLOCK, out,
    )  # fmt: skip
    return out if ok else None


@lazy_njit(GROUP, cache=True, nogil=True)
def _torque_residual_sums(q, tau, approach, off_j, fr_j, mg, jbody, jcol, coef, off, parent,
                          nz_ptr, nz_k, nz_j, nz_a, root_r, axis, r, blk,
                          out):  # fmt: skip  # pragma: no cover - compiled
    """Out = (Σ|e|, Σe²) of the torque residuals e = τ − off_j − side·fr_j − M g0 Σ_b coef_b
    (−(R_b a_b)_y F_x + (R_b a_b)_x F_y) (level support; F_b the first moment beyond body b,
    rows x, y) over the poses and the joints of jbody (J, B); approach (n,) or (0,). False
    (nothing written) when an angle is beyond MAX_ANGLE."""
    if not angles_ok(q):
        return False
    n, nq, nb, rot, s, c1, qt = chain_buffers(q, parent, 2, blk)
    nj = tau.shape[1]
    rows = np.arange(2)
    f = np.zeros((nb, 2, blk))
    tt = np.zeros((nj + 2, blk))  # the block's torques, approach sides, mask
    dummy = np.zeros((1, 8))
    no_u = np.zeros((1, 2, 3))
    pos = np.zeros(nb, dtype=np.int64)
    a_abs = vzero()
    a_sq = vzero()
    for s0 in range(0, n, blk):
        w, seg = block_angles(q, s0, blk, qt)
        tt[:, w:] = 0.0
        tb = tau[s0 : s0 + w]
        for k in range(w):
            for m in range(nj):
                tt[m, k] = tb[k, m]
            tt[nj, k] = approach[s0 + k] if approach.shape[0] > 0 else 0.0
            tt[nj + 1, k] = 1.0
        for b in range(nb):
            body_columns(b, w, seg, qt, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r,
                         rows, no_u, pos, s, c1, rot, dummy, False)  # fmt: skip
            r0, r1, r2 = vsplat(r[b, 0]), vsplat(r[b, 1]), vsplat(r[b, 2])
            for i in range(2):
                base = (b * 6 + i) * blk
                for k in range(0, seg, 8):
                    c = vfma(vload(rot, base + 4 * blk + k), r2,
                             vfma(vload(rot, base + 2 * blk + k), r1,
                                  vmul(vload(rot, base + k), r0)))  # fmt: skip
                    vstore(f, (b * 2 + i) * blk + k, c)
        for b in range(nb - 1, 0, -1):  # F[parent] += F[b], children first
            p = parent[b]
            for i in range(2):
                for k in range(0, seg, 8):
                    t = (p * 2 + i) * blk + k
                    vstore(f, t, vadd(vload(f, t), vload(f, (b * 2 + i) * blk + k)))
        for m in range(nj):
            o, fr = vsplat(off_j[m]), vsplat(fr_j[m])
            for k in range(0, seg, 8):
                pred = vzero()
                for t in range(jbody.shape[1]):
                    b = jbody[m, t]
                    if b < 0:
                        continue
                    a0, a1, a2 = vsplat(axis[b, 0]), vsplat(axis[b, 1]), vsplat(axis[b, 2])
                    rb = b * 6 * blk + k
                    ax = vfma(
                        vload(rot, rb + 4 * blk),
                        a2,
                        vfma(vload(rot, rb + 2 * blk), a1, vmul(vload(rot, rb), a0)),
                    )
                    ay = vfma(
                        vload(rot, rb + 5 * blk),
                        a2,
                        vfma(vload(rot, rb + 3 * blk), a1, vmul(vload(rot, rb + blk), a0)),
                    )
                    fx = vload(f, b * 2 * blk + k)
                    fy = vload(f, (b * 2 + 1) * blk + k)
                    hf = vfma(ax, fy, vneg(vmul(ay, fx)))
                    pred = vfma(vsplat(mg * coef[b]), hf, pred)  # fmt: skip
                meas = vsub(vsub(vload(tt, m * blk + k), o),
                            vmul(vload(tt, nj * blk + k), fr))  # fmt: skip
                e = vmul(vsub(meas, pred), vload(tt, (nj + 1) * blk + k))
                a_abs = vadd(a_abs, vabs(e))
                a_sq = vfma(e, e, a_sq)
    out[0] = vsum(a_abs)
    out[1] = vsum(a_sq)
    return True


def torque_residual_sums(
    tree: Tree, q: np.ndarray, r: np.ndarray, mass_g0: float, cols: np.ndarray, data: tuple
) -> np.ndarray | None:
    """(Σ|e|, Σe²) [N·m, (N·m)²] of the torque residuals at validated poses q (n, nq), level
    support, for SESC vectors r (N, 3), M·g0 [kg·m/s²] and q columns ``cols`` (J,); ``data`` =
    (τ (n, J), approach sides (n,) or None, offsets (J,), friction bands (J,)). One compiled
    pass; None when an angle needs numpy's exact reduction."""
    from sescid.kinematics._kernels.torque_values import joint_bodies_padded

    tau, side, off_j, fr_j = data
    out = np.zeros(2)
    ok = _torque_residual_sums(
        q, np.ascontiguousarray(tau, dtype=float),
        np.empty(0) if side is None else np.ascontiguousarray(side, dtype=float),
        np.ascontiguousarray(off_j, dtype=float), np.ascontiguousarray(fr_j, dtype=float),
        float(mass_g0), joint_bodies_padded(tree, np.asarray(cols, dtype=np.int64)), tree.jcol,
        tree.coef, tree.off, tree.parent, tree.nz_ptr, tree.nz_k, tree.nz_j, tree.nz_a,
        tree.root_r, tree.axis, np.ascontiguousarray(r, dtype=float).reshape(-1, 3),
        GRAM_BLOCK, out,
    )  # fmt: skip
    return out if ok else None
