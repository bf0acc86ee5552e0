"""Compiled kernels of the D-optimal search over poses of r rows each (``blocks``): one pass
over the candidates per greedy step, exchange trial or refresh, single-threaded.

A candidate's rows are A_j = [x_j, nuisance] (r × (p + K)): ``x`` (n, r, p) and, per row a,
the value ``val[a]`` in nuisance column ``col[a]`` (−1: none). Each candidate's
S_j = A_j M⁻¹ A_jᵀ (r × r, symmetric, stored whole) is kept with its gain log det(I + S_j).
No ``fastmath``: every sum runs in the written order (the bits do not depend on the CPU);
the innermost loops run over independent outputs, so they vectorise without reassociation.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from sescid.kinematics import lazy_njit


class Rows(NamedTuple):
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
def _chol_logdet(a, r):  # pragma: no cover - compiled
    """Log det of the symmetric r × r matrix ``a`` (its upper triangle is read) by an in-place
    Cholesky factorisation a = UᵀU (U in the upper triangle, row by row: the inner loops run
    along rows); −inf when it is not positive definite."""
    out = 0.0
    for k in range(r):
        d = a[k, k]
        if not d > 0.0:
            return -math.inf
        d = math.sqrt(d)
        a[k, k] = d
        out += 2.0 * math.log(d)
        for i in range(k + 1, r):
            a[k, i] /= d
        for i in range(k + 1, r):
            f = a[k, i]
            for t in range(i, r):
                a[i, t] -= f * a[k, t]
    return out


@lazy_njit(cache=True, nogil=True)
def _rows_times(rows, j, u, w, lower):  # pragma: no cover - compiled
    """W (r, c) = A_j U for U = [ux (p, c); uo (K, c)] (a ``Split``); ``lower``: U is lower
    triangular (row t has no entries beyond column t: they are skipped)."""
    x, col, val = rows
    ux, uo = u
    r, p = x.shape[1], x.shape[2]
    c = ux.shape[1]
    for a in range(r):
        for e in range(c):
            w[a, e] = 0.0
        for t in range(p):
            xv = x[j, a, t]
            top = min(t + 1, c) if lower else c
            for e in range(top):
                w[a, e] += xv * ux[t, e]
        k = col[a]
        if k >= 0:
            v = val[a]
            top = min(p + k + 1, c) if lower else c
            for e in range(top):
                w[a, e] += v * uo[k, e]


@lazy_njit(cache=True, nogil=True)
def _gram(z, s, j, sign, first, zt):  # pragma: no cover - compiled
    """s[j] = (0 if ``first`` else s[j]) + sign · z zᵀ for z (r, c), as c rank-one updates of
    the upper triangle (z transposed into ``zt`` (c, r) first: the inner loop runs along a
    row), then mirrored."""
    r, c = z.shape
    for a in range(r):
        for e in range(c):
            zt[e, a] = z[a, e]
    if first:
        for a in range(r):
            for b in range(a, r):
                s[j, a, b] = 0.0
    for e in range(c):
        for a in range(r):
            v = sign * zt[e, a]
            for b in range(a, r):
                s[j, a, b] += v * zt[e, b]
    for a in range(r):
        for b in range(a + 1, r):
            s[j, b, a] = s[j, a, b]


@lazy_njit(cache=True, nogil=True)
def _gain(s, j, r, scratch):  # pragma: no cover - compiled
    """Log det(I + S_j) (−inf when not positive definite)."""
    for a in range(r):
        for b in range(a, r):
            scratch[a, b] = s[j, a, b]
        scratch[a, a] += 1.0
    return _chol_logdet(scratch, r)


@lazy_njit(cache=True, nogil=True)
def _sandwich(rows, low, out):  # pragma: no cover - compiled
    """S_j = A_j M⁻¹ A_jᵀ = (A_j L)(A_j L)ᵀ for M⁻¹ = L Lᵀ, L = [lx; lo] ((p + K), p + K)
    (a ``Split``), and the gains, for every candidate, into ``out`` (``Sandwiches``)."""
    s, gain = out
    n, r = rows.x.shape[0], rows.x.shape[1]
    w = np.empty((r, low.x.shape[1]))
    wt = np.empty((low.x.shape[1], r))
    scratch = np.empty((r, r))
    for j in range(n):
        _rows_times(rows, j, low, w, True)
        _gram(w, s, j, 1.0, True, wt)
        gain[j] = _gain(s, j, r, scratch)


@lazy_njit(cache=True, nogil=True)
def _update(rows, u, g, sign, out):  # pragma: no cover - compiled
    """S_j += sign · (A_j U) G (A_j U)ᵀ, G (r × r) symmetric, U = [ux; uo] ((p + K) × r, a
    ``Split``), and the gains, for every candidate (``out``: ``Sandwiches``): V = W G, then
    S_j's upper triangle += sign · V Wᵀ as r rank-one updates (inner loops along rows),
    mirrored."""
    s, gain = out
    n, r = rows.x.shape[0], rows.x.shape[1]
    w = np.empty((r, r))
    wt = np.empty((r, r))
    v = np.empty((r, r))
    scratch = np.empty((r, r))
    for j in range(n):
        _rows_times(rows, j, u, w, False)
        for a in range(r):
            for e in range(r):
                wt[e, a] = w[a, e]
                v[a, e] = 0.0
            for t in range(r):
                wv = sign * w[a, t]
                for e in range(r):
                    v[a, e] += wv * g[t, e]
        for a in range(r):
            for t in range(r):
                f = v[a, t]
                for b in range(a, r):
                    s[j, a, b] += f * wt[t, b]
        for a in range(r):
            for b in range(a + 1, r):
                s[j, b, a] = s[j, a, b]
        gain[j] = _gain(s, j, r, scratch)


@lazy_njit(cache=True, nogil=True)
def _swap(rows, u, s, s_o, chosen, out):  # pragma: no cover - compiled
    """out[j] = log det(M − A_oᵀA_o + A_jᵀA_j) − log det M for each unchosen j (−inf for the
    chosen): log det(I + S_j) + log det(I − S_o + Xᵀ (I + S_j)⁻¹ X), X = A_j M⁻¹ A_oᵀ = A_j U
    with U = M⁻¹A_oᵀ = [ux; uo] (a ``Split``). Never forms the design without o."""
    n, r = rows.x.shape[0], rows.x.shape[1]
    y = np.empty((r, r))
    ch = np.empty((r, r))
    q = np.empty((r, r))
    for j in range(n):
        if chosen[j]:
            out[j] = -math.inf
            continue
        for a in range(r):
            for b in range(a, r):
                ch[a, b] = s[j, a, b]
            ch[a, a] += 1.0
        first = _chol_logdet(ch, r)  # I + S_j = UᵀU
        if first == -math.inf:
            out[j] = -math.inf
            continue
        _rows_times(rows, j, u, y, False)  # y = X, then y ← U⁻ᵀ X row by row
        for a in range(r):
            d = ch[a, a]
            for e in range(r):
                y[a, e] /= d
            for i in range(a + 1, r):
                f = ch[a, i]
                for e in range(r):
                    y[i, e] -= f * y[a, e]
        for a in range(r):  # q = I − S_o + yᵀy (upper triangle), rank-one updates
            for b in range(a, r):
                q[a, b] = -s_o[a, b]
            q[a, a] += 1.0
        for t in range(r):
            for a in range(r):
                v = y[t, a]
                for b in range(a, r):
                    q[a, b] += v * y[t, b]
        out[j] = first + _chol_logdet(q, r)


def sandwich_blocks(rows: Rows, minv: np.ndarray, out: Sandwiches) -> None:
    """S_j = A_j M⁻¹ A_jᵀ and log det(I + S_j) of every candidate, into ``out`` (s (n, r, r),
    gain (n,)); M⁻¹ (p + K, p + K) positive definite."""
    low = np.linalg.cholesky(minv)
    _sandwich(rows, split(low, rows.x.shape[2]), out)


def update_blocks(rows: Rows, u: np.ndarray, g: np.ndarray, sign: float, out: Sandwiches) -> None:
    """S_j += sign · (A_j U) G (A_j U)ᵀ and the gains, for every candidate, in ``out``;
    U (p + K, r), G (r, r) symmetric."""
    gs = np.ascontiguousarray((g + g.T) / 2)
    _update(rows, split(u, rows.x.shape[2]), gs, float(sign), out)


def swap_gains(
    rows: Rows, u: np.ndarray, s: np.ndarray, s_o: np.ndarray, chosen: np.ndarray
) -> np.ndarray:
    """(n,) log det rise of swapping the chosen o (U = M⁻¹A_oᵀ (p + K, r), S_o (r, r)) for
    each unchosen candidate (S_j in ``s`` (n, r, r)); −inf for the chosen and where the swap is
    singular."""
    out = np.empty(rows.x.shape[0])
    _swap(rows, split(u, rows.x.shape[2]), s, np.ascontiguousarray(s_o), chosen, out)
    return out
