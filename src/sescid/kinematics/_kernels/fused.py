"""The fused normal-equation kernel: trig, chain, reduced columns and the symmetric product of a
block of poses in one compiled pass (Φ is never written to memory).

The product is the augmented one, [Φ_red, y]ᵀ W [Φ_red, y]: the targets ride along as one more
column, so ΦᵀWΦ, ΦᵀWy and yᵀWy come out of the same tiles (``gram``), in a fixed order. Each
body's two reduced columns are written as soon as its rotation is known (still in L1), in
depth-first order (every subtree a contiguous range: the torque kind's blocks read the same
columns); the sums are permuted back to ``Reduction`` order at the end, exactly.
"""

from __future__ import annotations

import numpy as np

from sescid.kinematics._kernels.gram import padded, syrk
from sescid.kinematics._kernels.intrinsics import (
    vabsmax,
    vfma,
    vload,
    vmaxlane,
    vmul,
    vneg,
    vsplat,
    vstore,
    vzero,
)
from sescid.kinematics._kernels.reduced import Reduction
from sescid.kinematics._kernels.trig import MAX_ANGLE, SMALL_ANGLE
from sescid.kinematics._kernels.trig_fma import trig_row_fma
from sescid.kinematics.compile import GROUP, lazy_njit
from sescid.kinematics.tree import Tree

#: poses per sub-block of the fused pass (a multiple of 8: the block's rotations, columns and
#: product stay in L2)
GRAM_BLOCK = 128


@lazy_njit(GROUP, cache=True, nogil=True)
def angles_ok(q):  # pragma: no cover - compiled
    """True when every |angle| < MAX_ANGLE (the in-kernel reduction's range)."""
    for k in range(q.shape[0]):
        for j in range(q.shape[1]):
            if not abs(q[k, j]) < MAX_ANGLE:
                return False
    return True


@lazy_njit(GROUP, cache=True, nogil=True)
def block_angles(q, s0, blk, qt):  # pragma: no cover - compiled
    """The block of up to blk poses from s0: qt[j, k] = q[s0 + k, j] for k < w, zero beyond
    (its angles, joint-major); (w, w rounded up to the 8 lanes)."""
    w = min(blk, q.shape[0] - s0)
    qb = q[s0 : s0 + w]
    for k in range(w):
        for j in range(q.shape[1]):
            qt[j, k] = qb[k, j]
    qt[:, w:] = 0.0
    return w, (w + 7) // 8 * 8


@lazy_njit(GROUP, cache=True, nogil=True)
def _trig_simd(qt, jc, lin, w, seg, s, c1):  # pragma: no cover - compiled
    """s, c1 = sin θ, 1 − cos θ of θ = cb·qt[jc] + ob, lin = (cb, ob), for the block
    (``trig_row_fma``'s bits): 8 lanes at a time when every |θ| < SMALL_ANGLE, else its
    reduction."""
    cb, ob = lin
    base = jc * qt.shape[1]
    vb, vo = vsplat(cb), vsplat(ob)
    big = vzero()
    for k in range(0, seg, 8):
        big = vabsmax(big, vfma(vb, vload(qt, base + k), vo))
    if not vmaxlane(big) < SMALL_ANGLE:
        trig_row_fma(qt[jc], cb, ob, w, s, c1)
        return
    for k in range(0, seg, 8):
        r = vfma(vb, vload(qt, base + k), vo)
        z = vmul(r, r)
        ps = vfma(z, vsplat(-1 / 1307674368000), vsplat(1 / 6227020800))
        ps = vfma(z, ps, vsplat(-1 / 39916800))
        ps = vfma(z, ps, vsplat(1 / 362880))
        ps = vfma(z, ps, vsplat(-1 / 5040))
        ps = vfma(z, ps, vsplat(1 / 120))
        ps = vfma(z, ps, vsplat(-1 / 6))
        pc = vfma(z, vsplat(1 / 20922789888000), vsplat(-1 / 87178291200))
        pc = vfma(z, pc, vsplat(1 / 479001600))
        pc = vfma(z, pc, vsplat(-1 / 3628800))
        pc = vfma(z, pc, vsplat(1 / 40320))
        pc = vfma(z, pc, vsplat(-1 / 720))
        pc = vfma(z, pc, vsplat(1 / 24))
        pc = vfma(z, pc, vsplat(-0.5))
        vstore(s, k, vfma(vmul(r, z), ps, r))
        vstore(c1, k, vneg(vmul(z, pc)))


@lazy_njit(GROUP, cache=True, nogil=True)
def body_columns(b, w, seg, qt, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r, rows,
                 u, pos, s, c1, rot, xv, cols=True):  # fmt: skip  # pragma: no cover - compiled
    """Body b for the block's w poses (8 lanes at a time, seg = w rounded up to 8):
    rot[b, j, i, k] = R_b[rows[i], j] from its parent's (trig and chain in FMAs) and, for a
    moving body, its unweighted reduced columns xv[nr + 2·pos[b] + l, i·seg + k] =
    R_b[rows[i]] u_{b,l} (zero for w ≤ k < seg; skipped when not ``cols``)."""
    nr = rows.shape[0]
    blk = s.shape[0]
    p = parent[b]
    ob = b * 3 * nr * blk  # rot[b, j, i] starts at ob + (j·nr + i)·blk
    if p < 0:
        for j in range(3):
            for i in range(nr):
                v = vsplat(root_r[rows[i], j])
                for k in range(0, seg, 8):
                    vstore(rot, ob + (j * nr + i) * blk + k, v)
        return
    jc = jcol[b]
    if jc >= 0:
        _trig_simd(qt, jc, (coef[b], off[b]), w, seg, s, c1)
    else:
        s[:] = 0.0
        c1[:] = 0.0
    op = p * 3 * nr * blk
    started = 0  # bit jj: R_b's column jj has its first term (stored, not added)
    for z in range(nz_ptr[b], nz_ptr[b + 1]):
        kk = nz_k[z]
        jj = nz_j[z]
        a0 = vsplat(nz_a[z, 0])
        a1 = vsplat(nz_a[z, 1])
        a2 = vsplat(nz_a[z, 2])
        first = (started >> jj) & 1 == 0
        started |= 1 << jj
        if nr == 2:  # the CoP's rows: M_b's entry once for both
            d0 = ob + jj * 2 * blk
            s0 = op + kk * 2 * blk
            for k in range(0, seg, 8):
                mz = vfma(a2, vload(c1, k), vfma(a1, vload(s, k), a0))
                if first:
                    vstore(rot, d0 + k, vmul(vload(rot, s0 + k), mz))
                    vstore(rot, d0 + blk + k, vmul(vload(rot, s0 + blk + k), mz))
                else:
                    e0, e1 = d0 + k, d0 + blk + k
                    vstore(rot, e0, vfma(vload(rot, s0 + k), mz, vload(rot, e0)))
                    vstore(rot, e1, vfma(vload(rot, s0 + blk + k), mz, vload(rot, e1)))
            continue
        for i in range(nr):
            dst = ob + (jj * nr + i) * blk
            src = op + (kk * nr + i) * blk
            for k in range(0, seg, 8):
                mz = vfma(a2, vload(c1, k), vfma(a1, vload(s, k), a0))
                acc = vzero() if first else vload(rot, dst + k)
                vstore(rot, dst + k, vfma(vload(rot, src + k), mz, acc))
    for jj in range(3):  # a column with no entry (a degenerate joint transform): zero
        if (started >> jj) & 1 == 0:
            for i in range(nr):
                for k in range(0, seg, 8):
                    vstore(rot, ob + (jj * nr + i) * blk + k, vzero())
    if not cols:
        return
    row = nr + 2 * pos[b]
    ld = xv.shape[1]
    for lc in range(2):
        u0, u1, u2 = vsplat(u[b, lc, 0]), vsplat(u[b, lc, 1]), vsplat(u[b, lc, 2])
        for i in range(nr):
            r0 = ob + i * blk
            r1 = ob + (nr + i) * blk
            r2 = ob + (2 * nr + i) * blk
            dst = (row + lc) * ld + i * seg
            for k in range(0, seg, 8):
                col = vfma(
                    vload(rot, r2 + k),
                    u2,
                    vfma(vload(rot, r1 + k), u1, vmul(vload(rot, r0 + k), u0)),
                )
                vstore(xv, dst + k, col)  # fmt: skip
            for k in range(w, seg):  # the poses past the block's end add nothing
                xv[row + lc, i * seg + k] = 0.0


@lazy_njit(GROUP, cache=True, nogil=True, inline="always")
def chain_buffers(q, parent, nr, blk):  # pragma: no cover - compiled
    """A fused pass over poses q (n, nq) of a tree of nb bodies (``parent``): (n, nq, nb) and
    its chain buffers for blocks of blk poses: rot (nb, 3, nr, blk), s and c1 (blk,) (a joint's
    sin θ, 1 − cos θ) and qt (nq, blk) (the block's angles, joint-major)."""
    n, nq = q.shape
    nb = parent.shape[0]
    rot = np.zeros((nb, 3, nr, blk))
    return n, nq, nb, rot, np.zeros(blk), np.zeros(blk), np.zeros((nq, blk))


@lazy_njit(GROUP, cache=True, nogil=True)
def cop_rows(w, seg, nr, xv):  # pragma: no cover - compiled
    """The CoP's intercept rows xv[c, i·seg + k] = δ_ci (zero for w ≤ k < seg)."""
    for i in range(nr):
        for c in range(nr):
            dst = xv[c, i * seg : (i + 1) * seg]
            v = 1.0 if c == i else 0.0
            for k in range(w):
                dst[k] = v
            for k in range(w, seg):
                dst[k] = 0.0


@lazy_njit(GROUP, cache=True, nogil=True)
def cop_target(span, y, sw, pt, xv, xw):  # pragma: no cover - compiled
    """Target row pt of xv (y, zero tail) and, when weighted (sw (n, nr), else (0, nr)), rows
    0..pt of xv times each CoP row's weight into xw; span = (s0, w, seg): the block's first
    pose, its poses and w rounded up to 8."""
    s0, w, seg = span
    nr = y.shape[1]
    yb = y[s0 : s0 + w]
    for i in range(nr):
        dst = xv[pt, i * seg : (i + 1) * seg]
        for k in range(w):
            dst[k] = yb[k, i]
        for k in range(w, seg):
            dst[k] = 0.0
    if sw.shape[0] == 0:
        return
    swb = sw[s0 : s0 + w]
    for c in range(pt + 1):
        for i in range(nr):
            src = xv[c, i * seg : (i + 1) * seg]
            dst = xw[c, i * seg : (i + 1) * seg]
            for k in range(w):
                dst[k] = src[k] * swb[k, i]
            for k in range(w, seg):
                dst[k] = 0.0


@lazy_njit(GROUP, cache=True, nogil=True)
def _gram_reduced(q, y, sw, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r, rows, u,
                  pos, blk, out):  # fmt: skip  # pragma: no cover - compiled
    """Add [Φ_red, y]ᵀ W [Φ_red, y] of poses q (n, nq) to out (upper 4 × 4 tiles, columns in
    depth-first order, padded(p + 1) square), y (n, nr) targets, sw (n, nr) square-root weights
    or (0, nr); sub-blocks of blk poses. False (nothing added) when an angle is beyond
    MAX_ANGLE."""
    if not angles_ok(q):
        return False
    nr = rows.shape[0]
    n, nq, nb, rot, s, c1, qt = chain_buffers(q, parent, nr, blk)
    p4 = out.shape[0]
    pt = nr + 2 * (nb - 1)
    xv = np.zeros((p4, nr * blk))
    xw = np.zeros((p4 if sw.shape[0] > 0 else 0, nr * blk))
    for s0 in range(0, n, blk):
        w, seg = block_angles(q, s0, blk, qt)
        for b in range(nb):
            body_columns(b, w, seg, qt, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r,
                         rows, u, pos, s, c1, rot, xv)  # fmt: skip
        cop_rows(w, seg, nr, xv)
        cop_target((s0, w, seg), y, sw, pt, xv, xw)
        syrk(xw if sw.shape[0] > 0 else xv, p4, nr * seg, out)
    return True


def augmented_size(p: int) -> int:
    """Rows of the augmented accumulator of p columns: p + 1 (the targets), padded to 4."""
    return padded(p + 1)


def split_augmented(out: np.ndarray, p: int) -> tuple[np.ndarray, np.ndarray, float]:
    """(ΦᵀWΦ (p, p) symmetric, ΦᵀWy (p,), yᵀWy) from an augmented accumulator's upper tiles."""
    a = np.triu(out[:p, :p])
    return a + np.triu(a, 1).T, out[:p, p].copy(), float(out[p, p])


def from_depth_first(tree: Tree, nr: int) -> np.ndarray:
    """(p + 1,) for each ``Reduction``-order index (then the targets) its index in the fused
    pass's depth-first layout."""
    order, _ = tree.depth_first
    inv = np.arange(nr + 2 * len(order) + 1)
    for d, b in enumerate(order):
        inv[nr + 2 * (b - 1)] = nr + 2 * d
        inv[nr + 2 * (b - 1) + 1] = nr + 2 * d + 1
    return inv


def gram_reduced(
    tree: Tree, red: Reduction, q: np.ndarray, y: np.ndarray, sw: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, float] | None:
    """(Φ_redᵀWΦ_red (P_red, P_red), Φ_redᵀWy, yᵀWy) of validated poses q (n, nq) in one
    compiled pass; y (n, len(rows)) [m] targets, sw (n, len(rows)) square-root weights or None.
    None when an angle needs numpy's exact reduction."""
    nr, p = len(red.rows), red.g.shape[0]
    out = np.zeros((augmented_size(p),) * 2)
    ok = add_gram_reduced(tree, red, q, y, sw, out)
    return reduced_order(out, tree, nr, p) if ok else None


def add_gram_reduced(
    tree: Tree,
    red: Reduction,
    q: np.ndarray,
    y: np.ndarray,
    sw: np.ndarray | None,
    out: np.ndarray,
) -> bool:
    """``gram_reduced``'s sums added to ``out`` ((augmented_size(P_red),) * 2: the raw upper
    tiles, depth-first; ``reduced_order`` reads them, once, after any number of blocks); False
    (nothing added) when an angle needs numpy's exact reduction."""
    nr = len(red.rows)
    w = np.empty((0, nr)) if sw is None else np.ascontiguousarray(sw, dtype=float)
    return bool(
        _gram_reduced(
            q, np.ascontiguousarray(y, dtype=float), w, tree.jcol, tree.coef, tree.off,
            tree.parent, tree.nz_ptr, tree.nz_k, tree.nz_j, tree.nz_a, tree.root_r,
            np.asarray(red.rows, dtype=np.int64), red.u, tree.depth_first[1], GRAM_BLOCK, out,
        )
    )  # fmt: skip


def reduced_order(out: np.ndarray, tree: Tree, nr: int, p: int):
    """The fused pass's augmented tiles (depth-first) as (ΦᵀWΦ, ΦᵀWy, yᵀWy) in ``Reduction``
    order."""
    a = np.triu(out[: p + 1, : p + 1])
    full = a + np.triu(a, 1).T
    inv = from_depth_first(tree, nr)
    full = full[np.ix_(inv, inv)]
    return full[:p, :p], full[:p, p].copy(), float(full[p, p])
