"""Compiled kernels of the D-optimal search (``doptimal``): one pass over the candidates per
greedy step or exchange trial, single-threaded (no BLAS threads spinning on a busy machine).

Each candidate's S_j = A_j M⁻¹ A_jᵀ (2 × 2, symmetric) is stored as (s00, s01, s11). No
``fastmath``: every sum runs in the written order, so the bits do not depend on the CPU (no
fused multiply-add, no reassociation); the argmax breaks near-ties deterministically
(``TIE_LOGDET``). They live in one module because a lazily compiled kernel calls other
kernels through its own module's globals (``kinematics.lazy_njit``).
"""

from __future__ import annotations

import math

import numpy as np

from sescid.kinematics import lazy_njit

#: log det rises within this of the best are ties, won by the lowest candidate index: a choice
#: that rounding at the last bit cannot flip (the first greedy step is an exact tie on any robot:
#: every pose's x/y regressor rows have the same Gram matrix, Φ Φᵀ = N I)
TIE_LOGDET = 1e-9


@lazy_njit(cache=True, nogil=True)
def _rank2(a, ut, g, sign, s, chosen, tie):  # pragma: no cover - compiled
    """s[j] += sign · W_j g W_jᵀ with W_j = A_j U (2 × 2), for every candidate j.

    ``a`` (n, 2, p), ``ut`` = Uᵀ (2, p), ``g`` (2, 2) symmetric, ``s`` (n, 3). Returns the
    lowest unchosen j whose det(I + s[j]) > 0 is within the factor exp(−``tie``) of the
    largest, or −1.
    """
    n, _, p = a.shape
    g00 = g[0, 0]
    g01 = g[0, 1]
    g11 = g[1, 1]
    best_det = 0.0
    for j in range(n):
        w00 = 0.0
        w01 = 0.0
        w10 = 0.0
        w11 = 0.0
        for t in range(p):
            a0 = a[j, 0, t]
            a1 = a[j, 1, t]
            w00 += a0 * ut[0, t]
            w01 += a0 * ut[1, t]
            w10 += a1 * ut[0, t]
            w11 += a1 * ut[1, t]
        h0 = g00 * w00 + g01 * w01  # (G Wᵀ)[:, 0] = G · (row 0 of W)
        h1 = g01 * w00 + g11 * w01
        k0 = g00 * w10 + g01 * w11
        k1 = g01 * w10 + g11 * w11
        s00 = s[j, 0] + sign * (w00 * h0 + w01 * h1)
        s01 = s[j, 1] + sign * (w00 * k0 + w01 * k1)
        s11 = s[j, 2] + sign * (w10 * k0 + w11 * k1)
        s[j, 0] = s00
        s[j, 1] = s01
        s[j, 2] = s11
        if not chosen[j]:
            det = (1.0 + s00) * (1.0 + s11) - s01 * s01
            if det > best_det:
                best_det = det
    return _first_within(s, chosen, best_det * math.exp(-tie))


@lazy_njit(cache=True, nogil=True)
def _first_within(s, chosen, floor):  # pragma: no cover - compiled
    """The lowest unchosen j with det(I + S_j) ≥ ``floor`` > 0, or −1."""
    if not floor > 0.0:
        return -1
    for j in range(s.shape[0]):
        if not chosen[j]:
            det = (1.0 + s[j, 0]) * (1.0 + s[j, 2]) - s[j, 1] * s[j, 1]
            if det >= floor:
                return j
    return -1


@lazy_njit(cache=True, nogil=True)
def _swap(a, ut, s, s_out, chosen, tie):  # pragma: no cover - compiled
    """Best candidate to swap in for the chosen one whose A_o M⁻¹ A_oᵀ is ``s_out`` (3,), with
    ``ut`` = (M⁻¹ A_oᵀ)ᵀ (2, p): for each unchosen j, X = A_j M⁻¹ A_oᵀ and the exact ratio
    det(M − A_oᵀA_o + A_jᵀA_j) / det M = det(I + S_j) · det(I − S_o + Xᵀ (I + S_j)⁻¹ X),
    which never forms the (possibly singular) design without o. Returns (j, ratio): the lowest j
    whose ratio is within the factor exp(−``tie``) of the largest; (−1, 0) when none is > 0."""
    n, _, p = a.shape
    best = 0.0
    for sweep in range(2):
        floor = best * math.exp(-tie)
        for j in range(n):
            if chosen[j]:
                continue
            x00 = 0.0
            x01 = 0.0
            x10 = 0.0
            x11 = 0.0
            for t in range(p):
                a0 = a[j, 0, t]
                a1 = a[j, 1, t]
                x00 += a0 * ut[0, t]
                x01 += a0 * ut[1, t]
                x10 += a1 * ut[0, t]
                x11 += a1 * ut[1, t]
            p00 = 1.0 + s[j, 0]
            p01 = s[j, 1]
            p11 = 1.0 + s[j, 2]
            det_p = p00 * p11 - p01 * p01
            if not det_p > 0.0:
                continue
            # Y = Xᵀ P⁻¹ X, P⁻¹ = [[p11, −p01], [−p01, p00]] / det_p
            k00 = (p11 * x00 - p01 * x10) / det_p
            k01 = (p11 * x01 - p01 * x11) / det_p
            k10 = (p00 * x10 - p01 * x00) / det_p
            k11 = (p00 * x11 - p01 * x01) / det_p
            y00 = x00 * k00 + x10 * k10
            y01 = x00 * k01 + x10 * k11
            y11 = x01 * k01 + x11 * k11
            q00 = 1.0 - s_out[0] + y00
            q01 = -s_out[1] + y01
            q11 = 1.0 - s_out[2] + y11
            ratio = det_p * (q00 * q11 - q01 * q01)
            if sweep == 0:
                if ratio > best:
                    best = ratio
            elif ratio >= floor and ratio > 0.0:
                return j, ratio
    return -1, 0.0


@lazy_njit(cache=True, nogil=True)
def _sandwich(a, kt, s):  # pragma: no cover - compiled
    """s[j] = (s00, s01, s11) of A_j M⁻¹ A_jᵀ = |K A_jᵀ|² with M⁻¹ = KᵀK, ``kt`` = Kᵀ (p, p)
    lower triangular: y = K a accumulated column by column."""
    n, _, p = a.shape
    y0 = np.empty(p)
    y1 = np.empty(p)
    for j in range(n):
        y0[:] = 0.0
        y1[:] = 0.0
        for t in range(p):
            a0 = a[j, 0, t]
            a1 = a[j, 1, t]
            for r in range(t + 1):
                y0[r] += kt[t, r] * a0
                y1[r] += kt[t, r] * a1
        s00 = 0.0
        s01 = 0.0
        s11 = 0.0
        for r in range(p):
            s00 += y0[r] * y0[r]
            s01 += y0[r] * y1[r]
            s11 += y1[r] * y1[r]
        s[j, 0] = s00
        s[j, 1] = s01
        s[j, 2] = s11


@lazy_njit(cache=True, nogil=True)
def _project(x, t, out):  # pragma: no cover - compiled
    """out[k, i, :] = Σ_c x[c, i·m + k] t[c, :] for x (P, 2m), t (P, p), out (m, 2, p); x is
    transposed first, then eight output columns at a time are held in registers."""
    m = out.shape[0]
    p = t.shape[1]
    nc = x.shape[0]
    xt = np.empty((2 * m, nc))
    for c in range(nc):
        for col in range(2 * m):
            xt[col, c] = x[c, col]
    for i in range(2):
        for k in range(m):
            col = i * m + k
            e0 = 0
            while e0 + 8 <= p:
                a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = 0.0
                for c in range(nc):
                    v = xt[col, c]
                    a0 += v * t[c, e0]
                    a1 += v * t[c, e0 + 1]
                    a2 += v * t[c, e0 + 2]
                    a3 += v * t[c, e0 + 3]
                    a4 += v * t[c, e0 + 4]
                    a5 += v * t[c, e0 + 5]
                    a6 += v * t[c, e0 + 6]
                    a7 += v * t[c, e0 + 7]
                out[k, i, e0] = a0
                out[k, i, e0 + 1] = a1
                out[k, i, e0 + 2] = a2
                out[k, i, e0 + 3] = a3
                out[k, i, e0 + 4] = a4
                out[k, i, e0 + 5] = a5
                out[k, i, e0 + 6] = a6
                out[k, i, e0 + 7] = a7
                e0 += 8
            for e in range(e0, p):
                acc = 0.0
                for c in range(nc):
                    acc += xt[col, c] * t[c, e]
                out[k, i, e] = acc


def project_columns(x: np.ndarray, t: np.ndarray, out: np.ndarray) -> None:
    """Out (m, 2, p) = the block's rows Φ_red (columns of ``x`` (P, 2m), ordered (row, pose))
    times ``t`` (P, p): one compiled pass, no BLAS threads."""
    _project(x, t, out)


def sandwich(a: np.ndarray, minv: np.ndarray) -> np.ndarray:
    """(n, 3) (s00, s01, s11) of S_j = A_j M⁻¹ A_jᵀ for A (n, 2, p) and a positive definite
    M⁻¹ (p, p), one compiled pass (M⁻¹ = KᵀK, Kᵀ the Cholesky factor of M⁻¹)."""
    k = np.ascontiguousarray(np.linalg.cholesky(minv))
    s = np.empty((a.shape[0], 3))
    _sandwich(np.ascontiguousarray(a), k, s)
    return s


def rank2(
    a: np.ndarray, u: np.ndarray, g: np.ndarray, sign: float, s: np.ndarray, chosen: np.ndarray
) -> int:
    """``_rank2`` with U (p, 2): S_j ± A_j U g Uᵀ A_jᵀ in ``s`` (n, 3), in place; the best
    unchosen j (near-ties: the lowest index, ``TIE_LOGDET``)."""
    ut = np.ascontiguousarray(u.T)
    return int(_rank2(a, ut, g, float(sign), s, chosen, TIE_LOGDET))


def swap_best(
    a: np.ndarray, u: np.ndarray, s: np.ndarray, s_out: np.ndarray, chosen: np.ndarray
) -> tuple[int, float]:
    """``_swap`` with U = M⁻¹ A_oᵀ (p, 2): the best candidate j to swap in for the chosen o and
    det(M')/det(M) (near-ties: the lowest index, ``TIE_LOGDET``)."""
    j, ratio = _swap(a, np.ascontiguousarray(u.T), s, np.ascontiguousarray(s_out), chosen,
                     TIE_LOGDET)  # fmt: skip
    return int(j), float(ratio)


def first_best(gain: np.ndarray) -> int:
    """Index of the largest finite ``gain`` (log det rises), near-ties (``TIE_LOGDET``) won by
    the lowest index; −1 when none is finite."""
    ok = np.isfinite(gain)
    if not ok.any():
        return -1
    best = float(gain[ok].max())
    return int(np.flatnonzero(ok & (gain >= best - TIE_LOGDET))[0])
