"""Sin θ and 1 − cos θ of every body's joint angle: a compiled polynomial kernel and its numpy twin
(the same operations in the same order: the same bits)."""

from __future__ import annotations

import numpy as np

from sescid.kinematics.compile import GROUP, lazy_njit
from sescid.kinematics.tree import Tree

# Cody–Waite split of π/2 (fdlibm) and Taylor coefficients: |error| ≤ 2 ulp for |θ| < 1e5.
PIO2_1 = 1.57079632673412561417e00


PIO2_2 = 6.07710050630396597660e-11


PIO2_2T = 2.02226624879595063154e-21


TWO_OVER_PI = 6.36619772367581382433e-01


MAX_ANGLE = 1e5  #: rad; beyond this the reduction loses accuracy and numpy's sin/cos is used


def reducible(q: np.ndarray) -> bool:
    """True when every angle of q is within ±MAX_ANGLE (no nan): the polynomial reduction
    applies. Two passes over q, no temporary (|q| of 10⁶ poses would be a 160 MB array)."""
    if q.size == 0:
        return True
    return bool(q.max() < MAX_ANGLE and q.min() > -MAX_ANGLE)


#: rad: below this |θ| the reduction is the identity (its quotient is 0 since θ·2/π + ½ < 1),
#: so the polynomials alone give ``sin_cos1m``'s bits for less work
SMALL_ANGLE = 0.78


@lazy_njit(GROUP, cache=True, nogil=True, inline="always")
def _sin_cm(r):
    """Sin r and cos r − 1 for |r| ≤ π/4 (Taylor, ≤ 2 ulp)."""
    z = r * r
    sp = r + r * z * (
        -1 / 6
        + z
        * (
            1 / 120
            + z * (-1 / 5040 + z * (1 / 362880 + z * (-1 / 39916800 + z * (1 / 6227020800))))
        )
    )
    sp += r * z**7 * (-1 / 1307674368000)
    cm = z * (
        -0.5 + z * (1 / 24 + z * (-1 / 720 + z * (1 / 40320 + z * (-1 / 3628800 + z / 479001600))))
    )
    cm += z**7 * (-1 / 87178291200 + z / 20922789888000)  # cm = cos r − 1
    return sp, cm


@lazy_njit(GROUP, cache=True, nogil=True, inline="always")
def sin_cos1m(x):
    """Sin x and 1 − cos x, branch-free enough for the compiler to vectorise across poses."""
    q = np.floor(x * TWO_OVER_PI + 0.5)
    r = ((x - q * PIO2_1) - q * PIO2_2) - q * PIO2_2T  # |r| ≤ π/4
    sp, cm = _sin_cm(r)
    return from_quadrant(q, sp, cm)


@lazy_njit(GROUP, cache=True, nogil=True, inline="always")
def from_quadrant(q, sp, cm):
    """Sin x and 1 − cos x from sin r and cos r − 1 of the reduced angle r = x − q·π/2."""
    qi = np.int64(q) & 3
    a = (1.0 + cm) if qi & 1 else sp
    c = sp if qi & 1 else (1.0 + cm)
    sn = -a if qi >= 2 else a
    cs = -c if (qi == 1 or qi == 2) else c
    return sn, (-cm if qi == 0 else 1.0 - cs)


@lazy_njit(GROUP, cache=True, nogil=True, inline="always")
def trig_row(qrow, cb, ob, w, s, c1):
    """s[:w], c1[:w] = sin θ, 1 − cos θ of θ = cb·qrow[:w] + ob: the polynomials alone when
    every |θ| < SMALL_ANGLE (the same bits), else with the reduction."""
    big = 0.0
    for k in range(w):
        big = max(big, abs(cb * qrow[k] + ob))
    if big < SMALL_ANGLE:
        for k in range(w):
            sp, cm = _sin_cm(cb * qrow[k] + ob)
            s[k] = sp
            c1[k] = -cm
    else:
        for k in range(w):
            s[k], c1[k] = sin_cos1m(cb * qrow[k] + ob)


@lazy_njit(GROUP, cache=True, nogil=True)
def joint_trig(qt, jcol, coef, off, s, c1):
    """s, c1 (N, m): sin θ and 1 − cos θ of each body's joint angle θ = coef·q[:, jcol] + off.

    ``qt`` is the block transposed, (nq, m) C-contiguous, so the pose loop reads contiguously
    and vectorises.
    """
    nb, m = s.shape
    for b in range(nb):
        j = jcol[b]
        if j < 0:
            for k in range(m):
                s[b, k] = 0.0
                c1[b, k] = 0.0
            continue
        cb = coef[b]
        ob = off[b]
        trig_row(qt[j], cb, ob, m, s[b], c1[b])


def trig_numpy(tree: Tree, q: np.ndarray, s: np.ndarray, c1: np.ndarray) -> None:
    """Sin θ and 1 − cos θ = 2 sin²(θ/2) of every body's joint angle, exact reduction (libm)."""
    moving = tree.jcol >= 0
    theta = np.zeros(s.shape)
    theta[moving] = tree.coef[moving, None] * q.T[tree.jcol[moving]] + tree.off[moving, None]
    s[:] = np.sin(theta)
    c1[:] = 2.0 * np.sin(0.5 * theta) ** 2


def _sin_cos1m_numpy(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``sin_cos1m`` in numpy, the same operations in the same order: the same bits."""
    q = np.floor(x * TWO_OVER_PI + 0.5)
    r = ((x - q * PIO2_1) - q * PIO2_2) - q * PIO2_2T
    z = r * r
    poly = 1 / 6227020800
    for c in (-1 / 39916800, 1 / 362880, -1 / 5040, 1 / 120, -1 / 6):
        poly = c + z * poly
    z7 = z**7
    sp = r + r * z * poly
    sp += r * z7 * (-1 / 1307674368000)
    poly = -1 / 3628800 + z / 479001600
    for c in (1 / 40320, -1 / 720, 1 / 24, -0.5):
        poly = c + z * poly
    cm = z * poly
    cm += z7 * (-1 / 87178291200 + z / 20922789888000)  # cos r − 1
    qi = q.astype(np.int64) & 3
    odd = (qi & 1).astype(bool)
    a = np.where(odd, 1.0 + cm, sp)
    c = np.where(odd, sp, 1.0 + cm)
    sn = np.where(qi >= 2, -a, a)
    cs = np.where((qi == 1) | (qi == 2), -c, c)
    return sn, np.where(qi == 0, -cm, 1.0 - cs)


def trig_poly_numpy(tree: Tree, q: np.ndarray, s: np.ndarray, c1: np.ndarray) -> None:
    """``joint_trig`` in numpy (|q| < ``MAX_ANGLE``): the kernel's sin θ and 1 − cos θ, bit
    for bit."""
    moving = tree.jcol >= 0
    theta = tree.coef[moving, None] * q.T[tree.jcol[moving]] + tree.off[moving, None]
    s[~moving] = 0.0
    c1[~moving] = 0.0
    s[moving], c1[moving] = _sin_cos1m_numpy(theta)
