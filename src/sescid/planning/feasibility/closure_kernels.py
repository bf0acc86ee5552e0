"""The compiled Newton step of ``closure``: per pose, the free sole frame's placement error, its
Jacobian over the loop's joints and the minimum-norm step, in one pass.

No ``fastmath`` and no BLAS or libm beyond ``sqrt``: every sum runs in the written order with
correctly rounded operations, so the closed poses have the same bits on every CPU (the target's
yaw comes as its cosine and sine, the rotation error as the skew part of R R_targetᵀ).
"""

from __future__ import annotations

import math

import numpy as np

from sescid.kinematics import lazy_njit


@lazy_njit(cache=True, nogil=True)
def newton_kernel(rot, org, body, frame, centre, path, jcol, axis, target, floor, damp, err, step,
            up):  # fmt: skip  # pragma: no cover - compiled
    """For each pose k: ``err[k]`` (6,) the free sole frame's position error [m] and rotation
    error (the skew part of R R_tᵀ: sin θ · axis) from ``target[k]`` (x, y, cos ψ, sin ψ) on the
    floor z = ``floor``; ``up[k]`` the trace of R R_tᵀ (3 at the target); ``step[k]`` (c,) the
    step −Jᵀ (J Jᵀ + damp I)⁻¹ err of the loop's columns (``jcol[b]`` of each body b of
    ``path``, numbered in ``jcol``'s order by the caller: ``axis`` (N, 3) scaled by sign × mimic,
    ``jcol`` (N,) the loop column index of each body's joint, −1: none)."""
    n = rot.shape[0]
    nc = step.shape[1]
    jac = np.zeros((6, nc))
    a = np.zeros((6, 6))
    x = np.zeros(6)
    for k in range(n):
        rb = rot[k, body]
        r = np.zeros((3, 3))
        p = np.zeros(3)
        for i in range(3):
            p[i] = org[k, body, i] + (rb[i, 0] * centre[0] + rb[i, 1] * centre[1]
                                      + rb[i, 2] * centre[2])  # fmt: skip
            for j in range(3):
                r[i, j] = rb[i, 0] * frame[0, j] + rb[i, 1] * frame[1, j] + rb[i, 2] * frame[2, j]
        c = target[k, 2]
        s = target[k, 3]
        # E = R R_tᵀ, R_t = [[c, −s, 0], [s, c, 0], [0, 0, 1]]: column j of R_tᵀ is row j of R_t
        e = np.zeros((3, 3))
        for i in range(3):
            e[i, 0] = r[i, 0] * c - r[i, 1] * s
            e[i, 1] = r[i, 0] * s + r[i, 1] * c
            e[i, 2] = r[i, 2]
        err[k, 0] = p[0] - target[k, 0]
        err[k, 1] = p[1] - target[k, 1]
        err[k, 2] = p[2] - floor
        err[k, 3] = (e[2, 1] - e[1, 2]) * 0.5
        err[k, 4] = (e[0, 2] - e[2, 0]) * 0.5
        err[k, 5] = (e[1, 0] - e[0, 1]) * 0.5
        up[k] = e[0, 0] + e[1, 1] + e[2, 2]
        for i in range(6):
            for j in range(nc):
                jac[i, j] = 0.0
        for t in range(path.shape[0]):
            b = path[t]
            col = jcol[b]
            if col < 0:
                continue
            w0 = (
                rot[k, b, 0, 0] * axis[b, 0]
                + rot[k, b, 0, 1] * axis[b, 1]
                + rot[k, b, 0, 2] * axis[b, 2]
            )
            w1 = (
                rot[k, b, 1, 0] * axis[b, 0]
                + rot[k, b, 1, 1] * axis[b, 1]
                + rot[k, b, 1, 2] * axis[b, 2]
            )
            w2 = (
                rot[k, b, 2, 0] * axis[b, 0]
                + rot[k, b, 2, 1] * axis[b, 1]
                + rot[k, b, 2, 2] * axis[b, 2]
            )
            d0 = p[0] - org[k, b, 0]
            d1 = p[1] - org[k, b, 1]
            d2 = p[2] - org[k, b, 2]
            jac[0, col] += w1 * d2 - w2 * d1
            jac[1, col] += w2 * d0 - w0 * d2
            jac[2, col] += w0 * d1 - w1 * d0
            jac[3, col] += w0
            jac[4, col] += w1
            jac[5, col] += w2
        for i in range(6):  # A = J Jᵀ + damp I, lower Cholesky factor in place
            for j in range(i + 1):
                v = 0.0
                for m in range(nc):
                    v += jac[i, m] * jac[j, m]
                a[i, j] = v
            a[i, i] += damp
        ok = True
        for j in range(6):
            v = a[j, j]
            for m in range(j):
                v -= a[j, m] * a[j, m]
            if not v > 0.0:
                ok = False
                break
            a[j, j] = math.sqrt(v)
            for i in range(j + 1, 6):
                w = a[i, j]
                for m in range(j):
                    w -= a[i, m] * a[j, m]
                a[i, j] = w / a[j, j]
        if not ok:
            for j in range(nc):
                step[k, j] = np.nan
            continue
        for i in range(6):  # L y = err, then Lᵀ x = y
            v = err[k, i]
            for m in range(i):
                v -= a[i, m] * x[m]
            x[i] = v / a[i, i]
        for i in range(5, -1, -1):
            v = x[i]
            for m in range(i + 1, 6):
                v -= a[m, i] * x[m]
            x[i] = v / a[i, i]
        for j in range(nc):
            v = 0.0
            for i in range(6):
                v += jac[i, j] * x[i]
            step[k, j] = -v
