"""Self-collision with a broad phase, for robots with many capsules (mesh coverings): a bounding
sphere per body is tested first, a body pair's capsule pairs only when the spheres meet.

Same answer as ``collision.collision_free_mask`` (the same capsule pairs and distance rule),
computed from body rotations/origins without forming every capsule's world ends.
"""

from __future__ import annotations

import numpy as np

from ...kinematics import lazy_njit
from .collision import Capsules


@lazy_njit(cache=True, inline="always")
def _seg_dist2(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz):  # pragma: no cover - compiled
    """Squared distance between segments a–b and c–d (clamped closest points)."""
    eps = 1e-18
    d1x, d1y, d1z = bx - ax, by - ay, bz - az
    d2x, d2y, d2z = dx - cx, dy - cy, dz - cz
    rx, ry, rz = ax - cx, ay - cy, az - cz
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    c = d1x * rx + d1y * ry + d1z * rz
    b = d1x * d2x + d1y * d2y + d1z * d2z
    denom = a * e - b * b
    s = 0.0
    if a > eps and denom > 1e-12 * max(a * e, eps):
        s = min(max((b * f - c * e) / denom, 0.0), 1.0)
    if e <= eps:
        s = min(max(-c / a, 0.0), 1.0) if a > eps else 0.0
    t = (b * s + f) / e if e > eps else 0.0
    if t < 0.0:
        t = 0.0
        s = min(max(-c / a, 0.0), 1.0) if a > eps else 0.0
    elif t > 1.0:
        t = 1.0
        s = min(max((b - c) / a, 0.0), 1.0) if a > eps else 0.0
    ux = rx + d1x * s - d2x * t
    uy = ry + d1y * s - d2y * t
    uz = rz + d1z * s - d2z * t
    return ux * ux + uy * uy + uz * uz


@lazy_njit(cache=True, nogil=True)
def _broad(rot, org, cbody, p0, p1, rad, sph_c, sph_r, pb_i, pb_j, pb_start, pi, pj, out):
    """out[k] = True where no checked capsule pair of pose k intersects."""  # pragma: no cover
    w0 = np.empty((p0.shape[0], 3))
    w1 = np.empty((p0.shape[0], 3))
    done = np.empty(p0.shape[0], dtype=np.bool_)
    sc = np.empty((sph_c.shape[0], 3))
    for k in range(rot.shape[0]):
        out[k] = True
        for b in range(sph_c.shape[0]):
            for r in range(3):
                sc[b, r] = org[k, b, r] + (
                    rot[k, b, r, 0] * sph_c[b, 0]
                    + rot[k, b, r, 1] * sph_c[b, 1]
                    + rot[k, b, r, 2] * sph_c[b, 2]
                )
        done[:] = False
        for m in range(pb_i.shape[0]):
            bi = pb_i[m]
            bj = pb_j[m]
            dx = sc[bi, 0] - sc[bj, 0]
            dy = sc[bi, 1] - sc[bj, 1]
            dz = sc[bi, 2] - sc[bj, 2]
            reach = sph_r[bi] + sph_r[bj]
            if dx * dx + dy * dy + dz * dz >= reach * reach:
                continue
            for u in range(pb_start[m], pb_start[m + 1]):
                for c in (pi[u], pj[u]):
                    if not done[c]:
                        b = cbody[c]
                        for r in range(3):
                            w0[c, r] = org[k, b, r] + (
                                rot[k, b, r, 0] * p0[c, 0]
                                + rot[k, b, r, 1] * p0[c, 1]
                                + rot[k, b, r, 2] * p0[c, 2]
                            )
                            w1[c, r] = org[k, b, r] + (
                                rot[k, b, r, 0] * p1[c, 0]
                                + rot[k, b, r, 1] * p1[c, 1]
                                + rot[k, b, r, 2] * p1[c, 2]
                            )
                        done[c] = True
                i = pi[u]
                j = pj[u]
                d2 = _seg_dist2(
                    w0[i, 0], w0[i, 1], w0[i, 2], w1[i, 0], w1[i, 1], w1[i, 2],
                    w0[j, 0], w0[j, 1], w0[j, 2], w1[j, 0], w1[j, 1], w1[j, 2],
                )  # fmt: skip
                rr = rad[i] + rad[j]
                if d2 < rr * rr:
                    out[k] = False
                    break
            if not out[k]:
                break


def collision_free_mask_broad(cap: Capsules, rot: np.ndarray, org: np.ndarray) -> np.ndarray:
    """(n,) True where no checked capsule pair intersects; body spheres first (see module)."""
    n, nb = rot.shape[0], rot.shape[1]
    out = np.ones(n, dtype=bool)
    if not len(cap.pairs):
        return out
    sph_c = np.zeros((nb, 3))
    sph_r = np.zeros(nb)
    for b in np.unique(cap.body):
        m = cap.body == b
        ends = np.vstack([cap.p0[m], cap.p1[m]])
        c = (ends.min(axis=0) + ends.max(axis=0)) / 2
        sph_c[b] = c
        rr = np.concatenate([cap.radius[m], cap.radius[m]])
        sph_r[b] = float(np.max(np.linalg.norm(ends - c, axis=1) + rr))
    bi, bj = cap.body[cap.pairs[:, 0]], cap.body[cap.pairs[:, 1]]
    key = np.minimum(bi, bj) * nb + np.maximum(bi, bj)
    order = np.argsort(key, kind="stable")
    key = key[order]
    pairs = cap.pairs[order]
    first = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    start = np.r_[first, len(key)].astype(np.int64)
    _broad(
        np.ascontiguousarray(rot),
        np.ascontiguousarray(org),
        cap.body.astype(np.int64),
        np.ascontiguousarray(cap.p0),
        np.ascontiguousarray(cap.p1),
        cap.radius.astype(float),
        sph_c,
        sph_r,
        (key[first] // nb).astype(np.int64),
        (key[first] % nb).astype(np.int64),
        start,
        np.ascontiguousarray(pairs[:, 0]),
        np.ascontiguousarray(pairs[:, 1]),
        out,
    )
    return out
