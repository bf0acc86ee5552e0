"""Compiled kernels of the D-optimal search over poses of r rows each (``blocks``): one pass
over the candidates per greedy step, exchange trial or refresh, single-threaded.

A candidate's rows are A_j = [x_j, nuisance] (r × (p + K)): ``x`` (n, r, p) and, per row a,
the value ``val[a]`` in nuisance column ``col[a]`` (−1: none). Each candidate's
S_j = A_j M⁻¹ A_jᵀ (r × r, symmetric, stored whole) is kept with its gain log det(I + S_j).
No ``fastmath``: every sum runs in the written order (the bits do not depend on the CPU).

Eight candidates go through together, one per lane of an explicit vector (``simd``: their rows
gathered into a block, each lane's operations those of the scalar per-candidate loops, in the
same order — a product and a sum each rounded, no FMA): the same bits as one candidate at a
time, 3–4× faster (a torque design's time is mostly here).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from sescid.kinematics import LANES, lazy_njit
from sescid.kinematics.compile import simd_intrinsic

vload = simd_intrinsic("vload")
vstore = simd_intrinsic("vstore")
vzero = simd_intrinsic("vzero")
vsplat = simd_intrinsic("vsplat")
vadd = simd_intrinsic("vadd")
vsub = simd_intrinsic("vsub")
vmul = simd_intrinsic("vmul")
vdiv = simd_intrinsic("vdiv")
vsqrt = simd_intrinsic("vsqrt")


class KernelRows(NamedTuple):
    """The candidates' rows A_j = [x_j, nuisance] as the kernels read them (``BlockRows``)."""

    x: np.ndarray  #: (n, r, p) SESC part
    col: np.ndarray  #: (r,) int64 nuisance column of row a (−1: none)
    val: np.ndarray  #: (r,) its value


class Split(NamedTuple):
    """A (p + K, c) matrix U = [x; o] split into its SESC rows and its nuisance rows."""

    x: np.ndarray  #: (p, c)
    o: np.ndarray  #: (K, c)


class Sandwiches(NamedTuple):
    """Every candidate's S_j = A_j M⁻¹ A_jᵀ and its gain log det(I + S_j) (updated in place)."""

    s: np.ndarray  #: (n, r, r)
    gain: np.ndarray  #: (n,)


def split(u: np.ndarray, p: int) -> Split:
    """``u`` (p + K, c) split at row ``p``, each part contiguous."""
    return Split(np.ascontiguousarray(u[:p]), np.ascontiguousarray(u[p:]))


@lazy_njit(cache=True, nogil=True)
def _gather(x, j0, xb):  # pragma: no cover - compiled
    """xb[(a p + t) 8 + l] = x[j0 + l, a, t] (the last candidate repeated past the end)."""
    n, r, p = x.shape
    for lane in range(LANES):
        j = min(j0 + lane, n - 1)
        for a in range(r):
            for t in range(p):
                xb[(a * p + t) * LANES + lane] = x[j, a, t]


@lazy_njit(cache=True, nogil=True)
def _times(xb, r, p, ut, uo, col, val, lower, wb):  # pragma: no cover - compiled
    """W = A_j U for the block's 8 candidates (lanes): wb[(a c + e) 8 + l], U = [ux; uo]
    ((p + K) × c) given as ``ut`` = uxᵀ (c, p) and ``uo`` (K, c). Each W[a, e] is summed as
    the scalar product's loops did: from 0, over t ascending, the nuisance term last;
    ``lower``: U lower triangular, its zero terms (t < e) skipped, not added. Four columns e
    at a time (four independent sums in flight, each in its own order)."""
    c = ut.shape[0]
    for a in range(r):
        k = col[a]
        top = (p + k if lower else c - 1) if k >= 0 else -1  # last e with a nuisance term
        e = 0
        while e + 4 <= c:
            a0 = a1 = a2 = a3 = vzero()
            t0 = 0
            if lower:  # column e + i starts at t = e + i
                for t in range(e, min(e + 3, p)):
                    xv = vload(xb, (a * p + t) * LANES)
                    a0 = vadd(a0, vmul(xv, vsplat(ut[e, t])))
                    if t >= e + 1:
                        a1 = vadd(a1, vmul(xv, vsplat(ut[e + 1, t])))
                    if t >= e + 2:
                        a2 = vadd(a2, vmul(xv, vsplat(ut[e + 2, t])))
                t0 = e + 3
            for t in range(t0, p):
                xv = vload(xb, (a * p + t) * LANES)
                a0 = vadd(a0, vmul(xv, vsplat(ut[e, t])))
                a1 = vadd(a1, vmul(xv, vsplat(ut[e + 1, t])))
                a2 = vadd(a2, vmul(xv, vsplat(ut[e + 2, t])))
                a3 = vadd(a3, vmul(xv, vsplat(ut[e + 3, t])))
            if e <= top:
                a0 = vadd(a0, vsplat(val[a] * uo[k, e]))
            if e + 1 <= top:
                a1 = vadd(a1, vsplat(val[a] * uo[k, e + 1]))
            if e + 2 <= top:
                a2 = vadd(a2, vsplat(val[a] * uo[k, e + 2]))
            if e + 3 <= top:
                a3 = vadd(a3, vsplat(val[a] * uo[k, e + 3]))
            at = (a * c + e) * LANES
            vstore(wb, at, a0)
            vstore(wb, at + LANES, a1)
            vstore(wb, at + 2 * LANES, a2)
            vstore(wb, at + 3 * LANES, a3)
            e += 4
        for e in range(c - c % 4, c):  # the columns left after the groups of 4
            acc = vzero()
            for t in range(e if lower else 0, p):
                acc = vadd(acc, vmul(vload(xb, (a * p + t) * LANES), vsplat(ut[e, t])))
            if e <= top:
                acc = vadd(acc, vsplat(val[a] * uo[k, e]))
            vstore(wb, (a * c + e) * LANES, acc)


@lazy_njit(cache=True, nogil=True)
def _dots(u, ua, us, v, vb, vo, vs, count, n_out, init, out, ob):  # pragma: no cover - compiled
    """Up to four sums of lane-wise products (flat offsets into arrays of 8-lane vectors):
    out[ob + 8 i] = init[8 i] + Σ_{t < count} u[ua + t us] · v[vb + i vo + t vs], i < n_out,
    each from its start over t ascending (the scalar loops' order), four in flight."""
    a0 = vload(init, 0)
    a1 = vload(init, LANES)
    a2 = vload(init, 2 * LANES)
    a3 = vload(init, 3 * LANES)
    if n_out == 4:
        for t in range(count):
            x = vload(u, ua + t * us)
            at = vb + t * vs
            a0 = vadd(a0, vmul(x, vload(v, at)))
            a1 = vadd(a1, vmul(x, vload(v, at + vo)))
            a2 = vadd(a2, vmul(x, vload(v, at + 2 * vo)))
            a3 = vadd(a3, vmul(x, vload(v, at + 3 * vo)))
    else:
        for t in range(count):
            x = vload(u, ua + t * us)
            at = vb + t * vs
            a0 = vadd(a0, vmul(x, vload(v, at)))
            if n_out > 1:
                a1 = vadd(a1, vmul(x, vload(v, at + vo)))
            if n_out > 2:
                a2 = vadd(a2, vmul(x, vload(v, at + 2 * vo)))
    vstore(out, ob, a0)
    if n_out > 1:
        vstore(out, ob + LANES, a1)
    if n_out > 2:
        vstore(out, ob + 2 * LANES, a2)
    if n_out > 3:
        vstore(out, ob + 3 * LANES, a3)


@lazy_njit(cache=True, nogil=True)
def _chol_logdet(cb, r, tmp, out):  # pragma: no cover - compiled
    """Log det of each lane's symmetric r × r matrix (upper triangle of ``cb``, (a r + b) 8 + l)
    by an in-place Cholesky factorisation UᵀU, row by row; ``out`` (8,) gets −inf for a lane
    that is not positive definite. Every lane's operations are the scalar factorisation's."""
    for lane in range(LANES):
        out[lane] = 0.0
    bad = 0
    for k in range(r):
        d = vload(cb, (k * r + k) * LANES)
        vstore(tmp, 0, d)
        for lane in range(LANES):
            if not tmp[lane] > 0.0:
                bad |= 1 << lane
        d = vsqrt(d)
        vstore(cb, (k * r + k) * LANES, d)
        vstore(tmp, 0, d)
        for lane in range(LANES):
            out[lane] += 2.0 * math.log(tmp[lane])
        for i in range(k + 1, r):
            at = (k * r + i) * LANES
            vstore(cb, at, vdiv(vload(cb, at), d))
        for i in range(k + 1, r):
            f = vload(cb, (k * r + i) * LANES)
            for t in range(i, r):
                at = (i * r + t) * LANES
                vstore(cb, at, vsub(vload(cb, at), vmul(f, vload(cb, (k * r + t) * LANES))))
    for lane in range(LANES):
        if bad & (1 << lane):
            out[lane] = -math.inf


@lazy_njit(cache=True, nogil=True)
def _plus_identity(sb, r, cb):  # pragma: no cover - compiled
    """The block's I + S into ``cb``, on and above the diagonal (lanes as ``sb``)."""
    one = vsplat(1.0)
    for a in range(r):
        for b in range(a, r):
            at = (a * r + b) * LANES
            v = vload(sb, at)
            vstore(cb, at, vadd(v, one) if a == b else v)


@lazy_njit(cache=True, nogil=True)
def _scatter(sb, r, j0, s, gain, g8):  # pragma: no cover - compiled
    """s[j0 + l] = lane l of ``sb`` (upper triangle, mirrored), gain[j0 + l] = g8[l], for the
    block's candidates inside the pool."""
    for lane in range(min(LANES, s.shape[0] - j0)):
        j = j0 + lane
        for a in range(r):
            for b in range(a, r):
                v = sb[(a * r + b) * LANES + lane]
                s[j, a, b] = v
                s[j, b, a] = v
        gain[j] = g8[lane]


@lazy_njit(cache=True, nogil=True)
def _sandwich(rows, low, out):  # pragma: no cover - compiled
    """S_j = A_j M⁻¹ A_jᵀ = (A_j L)(A_j L)ᵀ for M⁻¹ = L Lᵀ, L = [lx; lo] ((p + K), p + K)
    (a ``Split``), and the gains, for every candidate, into ``out`` (``Sandwiches``): eight
    candidates at a time, one per vector lane, each by the scalar loops' operations."""
    x, col, val = rows
    s, gain = out
    n, r, p = x.shape
    c = low.x.shape[1]
    ut = np.ascontiguousarray(low.x.T)
    xb = np.empty(r * p * LANES)
    wb = np.empty(r * c * LANES)
    sb = np.empty(r * r * LANES)
    cb = np.empty(r * r * LANES)
    tmp, g8 = np.empty(LANES), np.empty(LANES)
    zero = np.zeros(4 * LANES)
    for j0 in range(0, n, LANES):
        _gather(x, j0, xb)
        _times(xb, r, p, ut, low.o, col, val, True, wb)
        for a in range(r):  # S = W Wᵀ, upper triangle, each sum over e ascending from 0
            for b in range(a, r, 4):
                _dots(wb, a * c * LANES, LANES, wb, b * c * LANES, c * LANES, LANES, c,
                      min(4, r - b), zero, sb, (a * r + b) * LANES)  # fmt: skip
        _plus_identity(sb, r, cb)
        _chol_logdet(cb, r, tmp, g8)
        _scatter(sb, r, j0, s, gain, g8)


@lazy_njit(cache=True, nogil=True)
def _update(rows, u, g, sign, out):  # pragma: no cover - compiled
    """S_j += sign · (A_j U) G (A_j U)ᵀ, G (r × r) symmetric, U = [ux; uo] ((p + K) × r, a
    ``Split``), and the gains, for every candidate (``out``: ``Sandwiches``), eight at a time:
    W = A_j U, V = (sign W) G, then S_j's upper triangle += V Wᵀ over t ascending, mirrored."""
    x, col, val = rows
    s, gain = out
    n, r, p = x.shape
    ut = np.ascontiguousarray(u.x.T)
    xb = np.empty(r * p * LANES)
    wb = np.empty(r * r * LANES)
    vb = np.empty(r * r * LANES)
    sb = np.empty(r * r * LANES)
    cb = np.empty(r * r * LANES)
    tmp, g8 = np.empty(LANES), np.empty(LANES)
    zero, init = np.zeros(4 * LANES), np.empty(4 * LANES)
    sv = vsplat(sign)
    swb = np.empty(r * r * LANES)  # sign · W
    gb = np.empty(r * r * LANES)  # G, each entry in every lane
    for t in range(r):
        for e in range(r):
            vstore(gb, (t * r + e) * LANES, vsplat(g[t, e]))
    for j0 in range(0, n, LANES):
        m = min(LANES, n - j0)
        _gather(x, j0, xb)
        _times(xb, r, p, ut, u.o, col, val, False, wb)
        for i in range(r * r):
            vstore(swb, i * LANES, vmul(sv, vload(wb, i * LANES)))
        for a in range(r):  # V = (sign W) G, each sum over t ascending from 0
            for e in range(0, r, 4):
                _dots(swb, a * r * LANES, LANES, gb, e * LANES, LANES, r * LANES, r,
                      min(4, r - e), zero, vb, (a * r + e) * LANES)  # fmt: skip
        for a in range(r):  # S_j += V Wᵀ, upper triangle, each from S_j over t ascending
            for b in range(a, r, 4):
                for i in range(min(4, r - b)):
                    for lane in range(m):
                        init[i * LANES + lane] = s[j0 + lane, a, b + i]
                _dots(vb, a * r * LANES, LANES, wb, b * r * LANES, r * LANES, LANES, r,
                      min(4, r - b), init, sb, (a * r + b) * LANES)  # fmt: skip
        _plus_identity(sb, r, cb)
        _chol_logdet(cb, r, tmp, g8)
        _scatter(sb, r, j0, s, gain, g8)


@lazy_njit(cache=True, nogil=True)
def _swap(rows, u, s, s_o, chosen, out):  # pragma: no cover - compiled
    """out[j] = log det(M − A_oᵀA_o + A_jᵀA_j) − log det M for each unchosen j (−inf for the
    chosen): log det(I + S_j) + log det(I − S_o + Xᵀ (I + S_j)⁻¹ X), X = A_j M⁻¹ A_oᵀ = A_j U
    with U = M⁻¹A_oᵀ = [ux; uo] (a ``Split``). Never forms the design without o. Eight
    candidates at a time, each by the scalar loops' operations."""
    x, col, val = rows
    n, r, p = x.shape
    ut = np.ascontiguousarray(u.x.T)
    xb = np.empty(r * p * LANES)
    yb = np.empty(r * r * LANES)
    cb = np.empty(r * r * LANES)
    qb = np.empty(r * r * LANES)
    tmp, f8, q8 = np.empty(LANES), np.empty(LANES), np.empty(LANES)
    init = np.zeros(4 * LANES)
    for j0 in range(0, n, LANES):
        m = min(LANES, n - j0)
        live = False
        for lane in range(m):
            live = live or not chosen[j0 + lane]
        if not live:
            for lane in range(m):
                out[j0 + lane] = -math.inf
            continue
        for a in range(r):  # I + S_j, upper triangle
            for b in range(a, r):
                for lane in range(LANES):
                    tmp[lane] = s[min(j0 + lane, n - 1), a, b]
                v = vload(tmp, 0)
                vstore(cb, (a * r + b) * LANES, vadd(v, vsplat(1.0)) if a == b else v)
        _chol_logdet(cb, r, tmp, f8)  # I + S_j = UᵀU
        _gather(x, j0, xb)
        _times(xb, r, p, ut, u.o, col, val, False, yb)  # y = X, then y ← U⁻ᵀ X row by row
        for a in range(r):
            d = vload(cb, (a * r + a) * LANES)
            for e in range(r):
                at = (a * r + e) * LANES
                vstore(yb, at, vdiv(vload(yb, at), d))
            for i in range(a + 1, r):
                f = vload(cb, (a * r + i) * LANES)
                for e in range(r):
                    at = (i * r + e) * LANES
                    vstore(yb, at, vsub(vload(yb, at), vmul(f, vload(yb, (a * r + e) * LANES))))
        for a in range(r):  # q = I − S_o + yᵀy (upper triangle), each over t ascending
            for b in range(a, r, 4):
                for i in range(min(4, r - b)):
                    q0 = -s_o[a, b + i]
                    if b + i == a:
                        q0 += 1.0
                    vstore(init, i * LANES, vsplat(q0))
                _dots(yb, a * LANES, r * LANES, yb, b * LANES, LANES, r * LANES, r,
                      min(4, r - b), init, qb, (a * r + b) * LANES)  # fmt: skip
        _chol_logdet(qb, r, tmp, q8)
        for lane in range(m):
            j = j0 + lane
            out[j] = -math.inf if chosen[j] or f8[lane] == -math.inf else f8[lane] + q8[lane]


def sandwich_blocks(rows: KernelRows, minv: np.ndarray, out: Sandwiches) -> None:
    """S_j = A_j M⁻¹ A_jᵀ and log det(I + S_j) of every candidate, into ``out`` (s (n, r, r),
    gain (n,)); M⁻¹ (p + K, p + K) positive definite."""
    low = np.linalg.cholesky(minv)
    _sandwich(rows, split(low, rows.x.shape[2]), out)


def update_blocks(
    rows: KernelRows, u: np.ndarray, g: np.ndarray, sign: float, out: Sandwiches
) -> None:
    """S_j += sign · (A_j U) G (A_j U)ᵀ and the gains, for every candidate, in ``out``;
    U (p + K, r), G (r, r) symmetric."""
    gs = np.ascontiguousarray((g + g.T) / 2)
    _update(rows, split(u, rows.x.shape[2]), gs, float(sign), out)


def swap_gains(
    rows: KernelRows, u: np.ndarray, s: np.ndarray, s_o: np.ndarray, chosen: np.ndarray
) -> np.ndarray:
    """(n,) log det rise of swapping the chosen o (U = M⁻¹A_oᵀ (p + K, r), S_o (r, r)) for
    each unchosen candidate (S_j in ``s`` (n, r, r)); −inf for the chosen and where the swap is
    singular."""
    out = np.empty(rows.x.shape[0])
    _swap(rows, split(u, rows.x.shape[2]), s, np.ascontiguousarray(s_o), chosen, out)
    return out
