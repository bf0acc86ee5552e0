"""The fused normal-equation kernel: trig, chain, reduced columns and the symmetric product of a
block of poses in one compiled pass (Φ is never written to memory).

The product is the augmented one, [Φ_red, y]ᵀ W [Φ_red, y]: the targets ride along as one more
column, so ΦᵀWΦ, ΦᵀWy and yᵀWy come out of the same tiles (``gram``), in a fixed order.
"""

from __future__ import annotations

import numpy as np

from sescid.kinematics.compile import GROUP, lazy_njit
from sescid.kinematics.gram import _syrk, padded
from sescid.kinematics.reduced import Reduction
from sescid.kinematics.tree import Tree
from sescid.kinematics.trig import MAX_ANGLE, _trig_row

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
def _block_chain(q, s0, w, qt, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r, rows,
                 s, c1, mk, rot):  # fmt: skip  # pragma: no cover - compiled
    """rot[b, j, i, k] = R_b[rows[i], j] for the w poses q[s0 : s0 + w] (k < w): trig and chain
    of the rows asked for only (plain products and sums: the numpy chain's bits)."""
    nq = q.shape[1]
    nb = parent.shape[0]
    nr = rows.shape[0]
    for k in range(w):
        for j in range(nq):
            qt[j, k] = q[s0 + k, j]
    for b in range(nb):
        p = parent[b]
        if p < 0:
            for j in range(3):
                for i in range(nr):
                    v = root_r[rows[i], j]
                    for k in range(w):
                        rot[b, j, i, k] = v
            continue
        jc = jcol[b]
        if jc >= 0:
            _trig_row(qt[jc], coef[b], off[b], w, s, c1)
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
                    mz = a0 + a1 * s[k] + a2 * c1[k]
                    o0[k] += i0[k] * mz
                    o1[k] += i1[k] * mz
                continue
            for k in range(w):
                mk[k] = a0 + a1 * s[k] + a2 * c1[k]
            for i in range(nr):
                for k in range(w):
                    rot[b, jj, i, k] += rot[p, kk, i, k] * mk[k]


@lazy_njit(GROUP, cache=True, nogil=True)
def _cop_columns(rot, w, seg, s0, y, sw, u, x):  # pragma: no cover - compiled
    """x[c, i·seg + k] (k < seg, zero for k ≥ w): the weighted reduced columns of row i at pose
    k — intercepts, then R_b[row] u_l of each moving body — and the weighted target in column
    p = nr + 2(N − 1). sw (n, nr) square-root weights, or (0, nr) for none."""
    nb = rot.shape[0]
    nr = rot.shape[2]
    p = nr + 2 * (nb - 1)
    weighted = sw.shape[0] > 0
    for i in range(nr):
        o = i * seg
        for c in range(nr):
            for k in range(w):
                x[c, o + k] = (sw[s0 + k, i] if weighted else 1.0) if c == i else 0.0
        for k in range(w):
            x[p, o + k] = y[s0 + k, i] * sw[s0 + k, i] if weighted else y[s0 + k, i]
        for c in range(p + 1):
            for k in range(w, seg):
                x[c, o + k] = 0.0
    for b in range(1, nb):
        ca = x[nr + 2 * (b - 1)]
        cb = x[nr + 2 * (b - 1) + 1]
        u00, u01, u02 = u[b, 0, 0], u[b, 0, 1], u[b, 0, 2]
        u10, u11, u12 = u[b, 1, 0], u[b, 1, 1], u[b, 1, 2]
        for i in range(nr):
            r0 = rot[b, 0, i]
            r1 = rot[b, 1, i]
            r2 = rot[b, 2, i]
            o = i * seg
            if weighted:
                for k in range(w):
                    wk = sw[s0 + k, i]
                    ca[o + k] = (r0[k] * u00 + r1[k] * u01 + r2[k] * u02) * wk
                    cb[o + k] = (r0[k] * u10 + r1[k] * u11 + r2[k] * u12) * wk
            else:
                for k in range(w):
                    ca[o + k] = r0[k] * u00 + r1[k] * u01 + r2[k] * u02
                    cb[o + k] = r0[k] * u10 + r1[k] * u11 + r2[k] * u12


@lazy_njit(GROUP, cache=True, nogil=True)
def _gram_reduced(q, y, sw, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r, rows, u,
                  blk, out):  # fmt: skip  # pragma: no cover - compiled
    """Add [Φ_red, y]ᵀ W [Φ_red, y] of poses q (n, nq) to out (upper 4 × 4 tiles, padded(p + 1)
    square), y (n, nr) targets, sw (n, nr) square-root weights or (0, nr); sub-blocks of blk
    poses. False (nothing added) when an angle is beyond MAX_ANGLE."""
    if not _angles_ok(q):
        return False
    n, nq = q.shape
    nb = parent.shape[0]
    nr = rows.shape[0]
    p4 = out.shape[0]
    rot = np.zeros((nb, 3, nr, blk))
    x = np.zeros((p4, nr * blk))
    s = np.zeros(blk)
    c1 = np.zeros(blk)
    mk = np.zeros(blk)
    qt = np.zeros((nq, blk))
    for s0 in range(0, n, blk):
        w = min(blk, n - s0)
        seg = (w + 7) // 8 * 8
        _block_chain(q, s0, w, qt, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r,
                     rows, s, c1, mk, rot)  # fmt: skip
        _cop_columns(rot, w, seg, s0, y, sw, u, x)
        _syrk(x, p4, nr * seg, out)
    return True


def augmented_size(p: int) -> int:
    """Rows of the augmented accumulator of p columns: p + 1 (the targets), padded to 4."""
    return padded(p + 1)


def split_augmented(out: np.ndarray, p: int) -> tuple[np.ndarray, np.ndarray, float]:
    """(ΦᵀWΦ (p, p) symmetric, ΦᵀWy (p,), yᵀWy) from an augmented accumulator's upper tiles."""
    a = np.triu(out[:p, :p])
    return a + np.triu(a, 1).T, out[:p, p].copy(), float(out[p, p])


def gram_reduced(
    tree: Tree,
    red: Reduction,
    q: np.ndarray,
    y: np.ndarray,
    sw: np.ndarray | None,
    out: np.ndarray,
) -> bool:
    """Add the augmented reduced normal equations [Φ_red, y]ᵀ W [Φ_red, y] of validated poses q
    (n, nq) to ``out`` ((augmented_size(p),) * 2, upper 4 × 4 tiles; ``split_augmented`` reads
    it) in one compiled pass; y (n, len(rows)) [m] targets, sw (n, len(rows)) square-root
    weights or None. False (nothing added) when an angle needs numpy's exact reduction."""
    nr = len(red.rows)
    w = np.empty((0, nr)) if sw is None else np.ascontiguousarray(sw, dtype=float)
    return bool(
        _gram_reduced(
            q, np.ascontiguousarray(y, dtype=float), w, tree.jcol, tree.coef, tree.off,
            tree.parent, tree.nz_ptr, tree.nz_k, tree.nz_j, tree.nz_a, tree.root_r,
            np.asarray(red.rows, dtype=np.int64), red.u, GRAM_BLOCK, out,
        )
    )  # fmt: skip
