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

from sescid.kinematics.compile import GROUP, lazy_njit, simd_intrinsic
from sescid.kinematics.gram import _syrk, padded
from sescid.kinematics.reduced import Reduction
from sescid.kinematics.tree import Tree
from sescid.kinematics.trig import MAX_ANGLE
from sescid.kinematics.trig_fma import _trig_row_fma

fma = simd_intrinsic("fma")

#: poses per sub-block of the fused pass (a multiple of 8: the block's rotations, columns and
#: product stay in L2)
GRAM_BLOCK = 128


@lazy_njit(GROUP, cache=True, nogil=True)
def _angles_ok(q):  # pragma: no cover - compiled
    """True when every |angle| < MAX_ANGLE (the in-kernel reduction's range)."""
    for k in range(q.shape[0]):
        for j in range(q.shape[1]):
            if not abs(q[k, j]) < MAX_ANGLE:
                return False
    return True


@lazy_njit(GROUP, cache=True, nogil=True)
def _transpose(q, s0, w, qt):  # pragma: no cover - compiled
    """qt[j, k] = q[s0 + k, j] for k < w: the block's angles, joint-major."""
    qb = q[s0 : s0 + w]
    for k in range(w):
        for j in range(q.shape[1]):
            qt[j, k] = qb[k, j]


@lazy_njit(GROUP, cache=True, nogil=True)
def _body(b, w, seg, qt, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r, rows, u,
          pos, s, c1, rot, xv):  # fmt: skip  # pragma: no cover - compiled
    """Body b for the block's w poses: rot[b, j, i, k] = R_b[rows[i], j] from its parent's (trig
    and chain in FMAs) and, for a moving body, its unweighted reduced columns
    xv[nr + 2·pos[b] + l, i·seg + k] = R_b[rows[i]] u_{b,l} (zero for w ≤ k < seg)."""
    nr = rows.shape[0]
    p = parent[b]
    if p < 0:
        for j in range(3):
            for i in range(nr):
                v = root_r[rows[i], j]
                for k in range(w):
                    rot[b, j, i, k] = v
        return
    jc = jcol[b]
    if jc >= 0:
        _trig_row_fma(qt[jc], coef[b], off[b], w, s, c1)
    else:
        for k in range(w):
            s[k] = 0.0
            c1[k] = 0.0
    for j in range(3):
        for i in range(nr):
            for k in range(w):
                rot[b, j, i, k] = 0.0
    for z in range(nz_ptr[b], nz_ptr[b + 1]):
        kk = nz_k[z]
        jj = nz_j[z]
        a0 = nz_a[z, 0]
        a1 = nz_a[z, 1]
        a2 = nz_a[z, 2]
        if nr == 2:  # the CoP's rows: one pass, the entry of M_b in a register
            o0 = rot[b, jj, 0]
            o1 = rot[b, jj, 1]
            i0 = rot[p, kk, 0]
            i1 = rot[p, kk, 1]
            for k in range(w):
                mz = fma(a2, c1[k], fma(a1, s[k], a0))
                o0[k] = fma(i0[k], mz, o0[k])
                o1[k] = fma(i1[k], mz, o1[k])
            continue
        for i in range(nr):
            o = rot[b, jj, i]
            ip = rot[p, kk, i]
            for k in range(w):
                o[k] = fma(ip[k], fma(a2, c1[k], fma(a1, s[k], a0)), o[k])
    row = nr + 2 * pos[b]
    for lc in range(2):
        u0, u1, u2 = u[b, lc, 0], u[b, lc, 1], u[b, lc, 2]
        for i in range(nr):
            r0 = rot[b, 0, i]
            r1 = rot[b, 1, i]
            r2 = rot[b, 2, i]
            dst = xv[row + lc, i * seg : (i + 1) * seg]  # a view: plain k indices vectorise
            for k in range(w):
                dst[k] = fma(r2[k], u2, fma(r1[k], u1, r0[k] * u0))
            for k in range(w, seg):
                dst[k] = 0.0


@lazy_njit(GROUP, cache=True, nogil=True)
def _cop_rows(w, seg, nr, xv):  # pragma: no cover - compiled
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
def _cop_target(w, seg, s0, y, sw, pt, xv, xw):  # pragma: no cover - compiled
    """Target row pt of xv (y, zero tail) and, when weighted (sw (n, nr), else (0, nr)), rows
    0..pt of xv times each CoP row's weight into xw."""
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
    if not _angles_ok(q):
        return False
    n, nq = q.shape
    nb = parent.shape[0]
    nr = rows.shape[0]
    p4 = out.shape[0]
    pt = nr + 2 * (nb - 1)
    rot = np.zeros((nb, 3, nr, blk))
    xv = np.zeros((p4, nr * blk))
    xw = np.zeros((p4 if sw.shape[0] > 0 else 0, nr * blk))
    s = np.zeros(blk)
    c1 = np.zeros(blk)
    qt = np.zeros((nq, blk))
    for s0 in range(0, n, blk):
        w = min(blk, n - s0)
        seg = (w + 7) // 8 * 8
        _transpose(q, s0, w, qt)
        for b in range(nb):
            _body(b, w, seg, qt, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r,
                  rows, u, pos, s, c1, rot, xv)  # fmt: skip
        _cop_rows(w, seg, nr, xv)
        _cop_target(w, seg, s0, y, sw, pt, xv, xw)
        _syrk(xw if sw.shape[0] > 0 else xv, p4, nr * seg, out)
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
    w = np.empty((0, nr)) if sw is None else np.ascontiguousarray(sw, dtype=float)
    out = np.zeros((augmented_size(p),) * 2)
    ok = _gram_reduced(
        q, np.ascontiguousarray(y, dtype=float), w, tree.jcol, tree.coef, tree.off,
        tree.parent, tree.nz_ptr, tree.nz_k, tree.nz_j, tree.nz_a, tree.root_r,
        np.asarray(red.rows, dtype=np.int64), red.u, tree.depth_first[1], GRAM_BLOCK, out,
    )  # fmt: skip
    return reduced_order(out, tree, nr, p) if ok else None


def reduced_order(out: np.ndarray, tree: Tree, nr: int, p: int):
    """The fused pass's augmented tiles (depth-first) as (ΦᵀWΦ, ΦᵀWy, yᵀWy) in ``Reduction``
    order."""
    a = np.triu(out[: p + 1, : p + 1])
    full = a + np.triu(a, 1).T
    inv = from_depth_first(tree, nr)
    full = full[np.ix_(inv, inv)]
    return full[:p, :p], full[:p, p].copy(), float(full[p, p])
