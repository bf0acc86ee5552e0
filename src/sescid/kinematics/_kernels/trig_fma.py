"""Sin θ and 1 − cos θ with explicit fused multiply-adds, for the fused normal-equation passes.

The same polynomials and reduction as ``trig``, each multiply-add rounded once (``simd.fma``):
fewer operations, and the same bits on every CPU (the FMA is explicit, not a contraction the CPU
may or may not do). Only the fused passes use them: their sums have no numpy twin to match,
while ``trig``'s plain products and sums keep the chain's numpy twin bit for bit.
"""

from __future__ import annotations

import numpy as np

from sescid.kinematics._kernels.intrinsics import fma
from sescid.kinematics._kernels.trig import (
    PIO2_1,
    PIO2_2,
    PIO2_2T,
    SMALL_ANGLE,
    TWO_OVER_PI,
    from_quadrant,
)
from sescid.kinematics.compile import GROUP, lazy_njit


@lazy_njit(GROUP, cache=True, nogil=True, inline="always")
def _sin_cm_fma(r):  # pragma: no cover - compiled
    """Sin r and cos r − 1 for |r| ≤ π/4: Taylor polynomials by Horner's rule in FMAs."""
    z = r * r
    ps = fma(z, -1 / 1307674368000, 1 / 6227020800)
    ps = fma(z, ps, -1 / 39916800)
    ps = fma(z, ps, 1 / 362880)
    ps = fma(z, ps, -1 / 5040)
    ps = fma(z, ps, 1 / 120)
    ps = fma(z, ps, -1 / 6)
    pc = fma(z, 1 / 20922789888000, -1 / 87178291200)
    pc = fma(z, pc, 1 / 479001600)
    pc = fma(z, pc, -1 / 3628800)
    pc = fma(z, pc, 1 / 40320)
    pc = fma(z, pc, -1 / 720)
    pc = fma(z, pc, 1 / 24)
    pc = fma(z, pc, -0.5)
    return fma(r * z, ps, r), z * pc


@lazy_njit(GROUP, cache=True, nogil=True, inline="always")
def _sin_cos1m_fma(x):  # pragma: no cover - compiled
    """Sin x and 1 − cos x, with the Cody–Waite reduction in FMAs."""
    q = np.floor(x * TWO_OVER_PI + 0.5)
    r = fma(-q, PIO2_2T, fma(-q, PIO2_2, fma(-q, PIO2_1, x)))  # |r| ≤ π/4
    sp, cm = _sin_cm_fma(r)
    return from_quadrant(q, sp, cm)


@lazy_njit(GROUP, cache=True, nogil=True, inline="always")
def trig_row_fma(qrow, cb, ob, w, s, c1):  # pragma: no cover - compiled
    """s[:w], c1[:w] = sin θ, 1 − cos θ of θ = cb·qrow[:w] + ob: the polynomials alone when
    every |θ| < SMALL_ANGLE (the reduction is then the identity: the same bits)."""
    big = 0.0
    for k in range(w):
        big = max(big, abs(fma(cb, qrow[k], ob)))
    if big < SMALL_ANGLE:
        for k in range(w):
            sp, cm = _sin_cm_fma(fma(cb, qrow[k], ob))
            s[k] = sp
            c1[k] = -cm
    else:
        for k in range(w):
            s[k], c1[k] = _sin_cos1m_fma(fma(cb, qrow[k], ob))
