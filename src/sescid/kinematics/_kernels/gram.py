"""Sums of products of rows, Σ_k a[i, k] b[j, k], in a fixed order: the normal equations' product.

Rows are stored with the summed index k (poses, rows of a pose) contiguous, in blocks whose length
is a multiple of 8 (zero-padded). Each output is summed in ``LANES`` = 8 partial sums (lane
l takes k = l, l + 8, …, each term an FMA) joined in a fixed tree: vectorised across independent
outputs, never by reassociating a sum, so the bits are the same on every CPU. Outputs come in 4 × 4
tiles (16 vector accumulators: 8 loads per 16 FMAs). ``gram_numpy`` is the deterministic numpy
product of the small jobs (plain products and sums, one column at a time: other bits than the
kernel's, the same on every CPU).
"""

from __future__ import annotations

import numpy as np

from sescid.kinematics._kernels.intrinsics import vfma, vload, vsum, vzero
from sescid.kinematics.compile import GROUP, compiled, lazy_njit

#: lanes of ``simd.Vec`` and the step of the summed index: part of the summation order, so
#: fixed (not the CPU's vector width)
LANES = 8


def lanes_padded(k: int) -> int:
    """``k`` rounded up to a multiple of ``LANES``."""
    return -(-k // LANES) * LANES


def padded(p: int) -> int:
    """Rows of a tiled accumulator: ``p`` rounded up to a multiple of 4."""
    return -(-p // 4) * 4


@lazy_njit(GROUP, cache=True, nogil=True, inline="always")
def sum_tile(a, ra, b, rb, kk):  # pragma: no cover - compiled
    """The 16 sums Σ_{k<kk} a.flat[ai + k] b.flat[bj + k] of a 4 × 4 tile (ra = (a0, …, a3),
    rb = (b0, …, b3): flat offsets of the rows), row-major; kk a multiple of 8."""
    a0, a1, a2, a3 = ra
    b0, b1, b2, b3 = rb
    c00 = c01 = c02 = c03 = vzero()
    c10 = c11 = c12 = c13 = vzero()
    c20 = c21 = c22 = c23 = vzero()
    c30 = c31 = c32 = c33 = vzero()
    for k in range(0, kk, 8):
        u0 = vload(a, a0 + k)
        u1 = vload(a, a1 + k)
        u2 = vload(a, a2 + k)
        u3 = vload(a, a3 + k)
        w = vload(b, b0 + k)
        c00 = vfma(u0, w, c00)
        c10 = vfma(u1, w, c10)
        c20 = vfma(u2, w, c20)
        c30 = vfma(u3, w, c30)
        w = vload(b, b1 + k)
        c01 = vfma(u0, w, c01)
        c11 = vfma(u1, w, c11)
        c21 = vfma(u2, w, c21)
        c31 = vfma(u3, w, c31)
        w = vload(b, b2 + k)
        c02 = vfma(u0, w, c02)
        c12 = vfma(u1, w, c12)
        c22 = vfma(u2, w, c22)
        c32 = vfma(u3, w, c32)
        w = vload(b, b3 + k)
        c03 = vfma(u0, w, c03)
        c13 = vfma(u1, w, c13)
        c23 = vfma(u2, w, c23)
        c33 = vfma(u3, w, c33)
    return (
        vsum(c00), vsum(c01), vsum(c02), vsum(c03),
        vsum(c10), vsum(c11), vsum(c12), vsum(c13),
        vsum(c20), vsum(c21), vsum(c22), vsum(c23),
        vsum(c30), vsum(c31), vsum(c32), vsum(c33),
    )  # fmt: skip


@lazy_njit(GROUP, cache=True, nogil=True, inline="always")
def sum_tile3(a, ra, b, rb, kk):  # pragma: no cover - compiled
    """``sum_tile`` for 3 rows × 4 columns (ra = (a0, a1, a2); 12 sums, row-major)."""
    a0, a1, a2 = ra
    b0, b1, b2, b3 = rb
    c00 = c01 = c02 = c03 = vzero()
    c10 = c11 = c12 = c13 = vzero()
    c20 = c21 = c22 = c23 = vzero()
    for k in range(0, kk, 8):
        u0 = vload(a, a0 + k)
        u1 = vload(a, a1 + k)
        u2 = vload(a, a2 + k)
        w = vload(b, b0 + k)
        c00 = vfma(u0, w, c00)
        c10 = vfma(u1, w, c10)
        c20 = vfma(u2, w, c20)
        w = vload(b, b1 + k)
        c01 = vfma(u0, w, c01)
        c11 = vfma(u1, w, c11)
        c21 = vfma(u2, w, c21)
        w = vload(b, b2 + k)
        c02 = vfma(u0, w, c02)
        c12 = vfma(u1, w, c12)
        c22 = vfma(u2, w, c22)
        w = vload(b, b3 + k)
        c03 = vfma(u0, w, c03)
        c13 = vfma(u1, w, c13)
        c23 = vfma(u2, w, c23)
    return (
        vsum(c00), vsum(c01), vsum(c02), vsum(c03),
        vsum(c10), vsum(c11), vsum(c12), vsum(c13),
        vsum(c20), vsum(c21), vsum(c22), vsum(c23),
    )  # fmt: skip


@lazy_njit(GROUP, cache=True, nogil=True)
def syrk(x, p4, kk, out):  # pragma: no cover - compiled
    """out[i, j] += Σ_{k<kk} x[i, k] x[j, k] on the 4 × 4 tiles on and above the diagonal
    (j ≥ i − i % 4; p4 a multiple of 4 rows, x C-contiguous, kk a multiple of 8)."""
    ld = x.shape[1]
    for i0 in range(0, p4, 4):
        ra = i0 * ld
        for j0 in range(i0, p4, 4):
            rb = j0 * ld
            rows_a = (ra, ra + ld, ra + 2 * ld, ra + 3 * ld)
            rows_b = (rb, rb + ld, rb + 2 * ld, rb + 3 * ld)
            t = sum_tile(x, rows_a, x, rows_b, kk)
            for r in range(4):
                for c in range(4):
                    out[i0 + r, j0 + c] += t[4 * r + c]


def gram_numpy(x: np.ndarray, out: np.ndarray) -> None:
    """out[:p, :p] += x xᵀ for columns x (p, m): one column at a time, a product and a sum per
    element, in column order (deterministic; BLAS would pick its order by CPU)."""
    p = x.shape[0]
    acc = out[:p, :p]
    tmp = np.empty((p, p))
    for k in range(x.shape[1]):
        col = x[:, k]
        np.multiply(col[:, None], col[None, :], out=tmp)
        acc += tmp


@lazy_njit(GROUP, cache=True, nogil=True)
def gram_in_order(xt, out):  # pragma: no cover - compiled
    """``gram_numpy`` compiled, the same bits: out[i, j] += xt[k, i] · xt[k, j] for k in order,
    the product and the sum each rounded (no FMA); rows xt (m, p) C-contiguous."""
    m, p = xt.shape
    for k in range(m):
        for i in range(p):
            xi = xt[k, i]
            for j in range(p):
                out[i, j] += xi * xt[k, j]


def gram_columns(x: np.ndarray, kernels: bool) -> np.ndarray:
    """The upper 4 × 4 tiles of x xᵀ for columns x (p, m), in a (padded(p), padded(p)) array:
    compiled (FMA, 8 lanes) when ``kernels``, else ``gram_numpy`` (full, other rounding) — run
    by its compiled twin when the kernels are loaded anyway (the same bits, 5× faster)."""
    p, m = x.shape
    p4 = padded(p)
    out = np.zeros((p4, p4))
    if not kernels:
        if compiled():
            gram_in_order(np.ascontiguousarray(x.T), out)
        else:
            gram_numpy(x, out)
        return out
    mm = lanes_padded(max(m, 1))
    xp = np.zeros((p4, mm))
    xp[:p, :m] = x
    syrk(xp, p4, mm, out)
    return out
