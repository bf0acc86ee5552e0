"""The fused normal-equation kernel: trig, chain, reduced columns and the symmetric product of a
block of poses in one compiled pass (Φ is never written to memory)."""

from __future__ import annotations

import numpy as np

from sescid.kinematics.compile import GROUP, _numpy_path, lazy_njit
from sescid.kinematics.reduced import Reduction
from sescid.kinematics.tree import Tree
from sescid.kinematics.trig import MAX_ANGLE, _trig_row

#: poses per block of the fused accumulation (rotations, columns and product stay in L2)
GRAM_BLOCK = 128


@lazy_njit(GROUP, cache=True, nogil=True, fastmath={"reassoc", "contract"})
def _gram_upper(x, m, y, ata, atb):  # pragma: no cover - compiled
    """ata[i, j] += Σ_{k<m} x[i, k] x[j, k] on and above the diagonal's 4 × 4 blocks (x has a
    multiple of 4 rows), atb += X y, returns yᵀy: 2 × 4 register blocks, two FMAs per load."""
    p = x.shape[0]
    yty = 0.0
    for k in range(m):
        yty += y[k] * y[k]
    for i in range(p):
        acc = 0.0
        for k in range(m):
            acc += x[i, k] * y[k]
        atb[i] += acc
    for i0 in range(0, p, 2):
        for j0 in range(i0 - i0 % 4, p, 4):
            a00 = a01 = a02 = a03 = a10 = a11 = a12 = a13 = 0.0
            for k in range(m):
                x0 = x[i0, k]
                x1 = x[i0 + 1, k]
                z0 = x[j0, k]
                z1 = x[j0 + 1, k]
                z2 = x[j0 + 2, k]
                z3 = x[j0 + 3, k]
                a00 += x0 * z0
                a01 += x0 * z1
                a02 += x0 * z2
                a03 += x0 * z3
                a10 += x1 * z0
                a11 += x1 * z1
                a12 += x1 * z2
                a13 += x1 * z3
            ata[i0, j0] += a00
            ata[i0, j0 + 1] += a01
            ata[i0, j0 + 2] += a02
            ata[i0, j0 + 3] += a03
            ata[i0 + 1, j0] += a10
            ata[i0 + 1, j0 + 1] += a11
            ata[i0 + 1, j0 + 2] += a12
            ata[i0 + 1, j0 + 3] += a13
    return yty


@lazy_njit(GROUP, cache=True, nogil=True, fastmath={"contract"})
def _gram_reduced(
    q, y, sw, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r, rows, u, blk, ata, atb
):  # pragma: no cover - compiled
    """Normal equations of the reduced regressor for poses q (n, nq), |q| < MAX_ANGLE, and
    targets y (n, nr) = CoM[rows] − d[rows]; sw (n, nr) square-root row weights, or (0, nr)
    for none. Adds Φ_redᵀWΦ_red to ata (P4, P4; upper 4 × 4 blocks, P4 = P_red rounded up to
    a multiple of 4) and Φ_redᵀWy to atb (P4,); returns yᵀWy, or −1 (nothing added) when an
    angle is beyond MAX_ANGLE. Blocks of ``blk`` poses."""
    n, nq = q.shape
    for k in range(n):
        for j in range(nq):
            if not abs(q[k, j]) < MAX_ANGLE:
                return -1.0
    nb = parent.shape[0]
    nr = rows.shape[0]
    p4 = ata.shape[0]
    weighted = sw.shape[0] > 0
    rot = np.empty((nb, 3, nr, blk))
    x = np.zeros((p4, nr * blk))
    yv = np.empty(nr * blk)
    wt = np.ones((nr, blk))
    s = np.zeros(blk)
    c1 = np.zeros(blk)
    mk = np.empty(blk)
    qt = np.empty((nq, blk))
    yty = 0.0
    for s0 in range(0, n, blk):
        w = min(blk, n - s0)
        for k in range(w):
            for j in range(nq):
                qt[j, k] = q[s0 + k, j]
        for i in range(nr):
            for k in range(w):
                if weighted:
                    wt[i, k] = sw[s0 + k, i]
                yv[i * w + k] = y[s0 + k, i] * wt[i, k]
                for c in range(nr):
                    x[c, i * w + k] = wt[i, k] if c == i else 0.0
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
                cb = coef[b]
                ob = off[b]
                _trig_row(qt[jc], cb, ob, w, s, c1)
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
            ca = x[nr + 2 * (b - 1)]
            cb_ = x[nr + 2 * (b - 1) + 1]
            u00, u01, u02 = u[b, 0, 0], u[b, 0, 1], u[b, 0, 2]
            u10, u11, u12 = u[b, 1, 0], u[b, 1, 1], u[b, 1, 2]
            for i in range(nr):
                r0 = rot[b, 0, i]
                r1 = rot[b, 1, i]
                r2 = rot[b, 2, i]
                wi = wt[i]
                o = i * w
                for k in range(w):
                    ca[o + k] = (r0[k] * u00 + r1[k] * u01 + r2[k] * u02) * wi[k]
                    cb_[o + k] = (r0[k] * u10 + r1[k] * u11 + r2[k] * u12) * wi[k]
        yty += _gram_upper(x, nr * w, yv, ata, atb)
    return yty


def padded(p: int) -> int:
    """Rows of the fused kernel's accumulators: ``p`` rounded up to a multiple of 4."""
    return -(-p // 4) * 4


def gram_reduced(
    tree: Tree,
    red: Reduction,
    q: np.ndarray,
    y: np.ndarray,
    sw: np.ndarray | None,
    ata: np.ndarray,
    atb: np.ndarray,
) -> float | None:
    """Add the reduced normal equations of validated poses q (n, nq) to ata (P4, P4, upper
    4 × 4 blocks only) and atb (P4,) in one compiled pass; y (n, len(rows)) [m] targets, sw
    (n, len(rows)) square-root weights or None. Returns yᵀWy, or None (nothing added) where
    ``chain`` would run in numpy (``_numpy_path``) or an angle needs numpy's exact reduction."""
    if _numpy_path(q.shape[0], tree.parent.shape[0]):
        return None
    nr = len(red.rows)
    w = np.empty((0, nr)) if sw is None else np.ascontiguousarray(sw, dtype=float)
    yty = float(
        _gram_reduced(
            q, np.ascontiguousarray(y, dtype=float), w, tree.jcol, tree.coef, tree.off,
            tree.parent, tree.nz_ptr, tree.nz_k, tree.nz_j, tree.nz_a, tree.root_r,
            np.asarray(red.rows, dtype=np.int64), red.u, GRAM_BLOCK, ata, atb,
        )
    )  # fmt: skip
    return None if yty < 0 else yty


def gram_upper(x: np.ndarray, y: np.ndarray, ata: np.ndarray, atb: np.ndarray) -> float:
    """Add X Xᵀ (upper 4 × 4 blocks) to ata (P4, P4) and X y to atb (P4,) for columns x (P, m),
    P ≤ P4, y (m,), on one core; returns yᵀy. Rows are zero-padded to P4 in a copy."""
    p4 = ata.shape[0]
    xp = np.zeros((p4, x.shape[1]))
    xp[: x.shape[0]] = x
    return float(_gram_upper(xp, x.shape[1], np.ascontiguousarray(y, dtype=float), ata, atb))
