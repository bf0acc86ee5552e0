"""Compiled capsule–capsule kernels of self-collision: one squared segment distance serves the
narrow phase (``collision.first_contact``) and the broad phase (``broadphase``).

They live in one module because a lazily compiled kernel calls other kernels through its own
module's globals (``kinematics.lazy_njit``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from sescid.kinematics import lazy_njit


class BodySpheres(NamedTuple):
    """A bounding sphere per body, in the body's frame."""

    centre: np.ndarray  #: (N, 3) m
    radius: np.ndarray  #: (N,) m


class CapsuleEnds(NamedTuple):
    """Capsules in their bodies' frames."""

    body: np.ndarray  #: (C,) int64 body of each capsule
    p0: np.ndarray  #: (C, 3) m, one end of the axis
    p1: np.ndarray  #: (C, 3) m, the other end
    radius: np.ndarray  #: (C,) m


class BodyPairs(NamedTuple):
    """Body pairs with capsule pairs to check: capsule pairs ``lo[m]:hi[m]`` belong to body pair
    m; ``hits[m]`` counts the poses it rejected (the order of the next call)."""

    i: np.ndarray  #: (B,) int64
    j: np.ndarray  #: (B,) int64
    lo: np.ndarray  #: (B,) int64
    hi: np.ndarray  #: (B,) int64
    hits: np.ndarray  #: (B,) int64


class BroadPhase(NamedTuple):
    """What the broad-phase kernel checks, built once per capsule set (``broadphase``)."""

    capsules: CapsuleEnds
    spheres: BodySpheres
    body_pairs: BodyPairs
    pair_i: np.ndarray  #: (P,) int64 first capsule of each checked pair, grouped by body pair
    pair_j: np.ndarray  #: (P,) int64 second capsule


@lazy_njit(cache=True, inline="always")
def _seg_dist2(a, b, c, d):  # pragma: no cover - compiled
    """Squared distance between segments a–b and c–d (clamped closest points); each end an
    (x, y, z) tuple [m]."""
    ax, ay, az = a
    bx, by, bz = b
    cx, cy, cz = c
    dx, dy, dz = d
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
def broad_phase_kernel(rot, org, phase, out):  # pragma: no cover - compiled
    """out[k] = True where no checked capsule pair of pose k intersects. ``rot`` (n, N, 3, 3),
    ``org`` (n, N, 3) from forward kinematics; ``phase`` a ``BroadPhase`` (its body pairs'
    ``hits`` counted)."""
    cbody, p0, p1, rad = phase.capsules
    sph_c, sph_r = phase.spheres
    pb_i, pb_j, pb_lo, pb_hi, hits = phase.body_pairs
    pi, pj = phase.pair_i, phase.pair_j
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
            for u in range(pb_lo[m], pb_hi[m]):
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
                    (w0[i, 0], w0[i, 1], w0[i, 2]),
                    (w1[i, 0], w1[i, 1], w1[i, 2]),
                    (w0[j, 0], w0[j, 1], w0[j, 2]),
                    (w1[j, 0], w1[j, 1], w1[j, 2]),
                )
                rr = rad[i] + rad[j]
                if d2 < rr * rr:
                    out[k] = False
                    hits[m] += 1
                    break
            if not out[k]:
                break


@lazy_njit(cache=True, nogil=True)
def first_contact_kernel(w0, w1, reach, pi, pj, out):  # pragma: no cover - compiled
    """out[k] = index of the first capsule pair closer than its reach in pose k, or −1.

    Closest points of two segments (clamped parameters, as in ``segment_distance``).
    """
    for k in range(w0.shape[0]):
        out[k] = -1
        for m in range(pi.shape[0]):
            i = pi[m]
            j = pj[m]
            d2 = _seg_dist2(
                (w0[k, i, 0], w0[k, i, 1], w0[k, i, 2]),
                (w1[k, i, 0], w1[k, i, 1], w1[k, i, 2]),
                (w0[k, j, 0], w0[k, j, 1], w0[k, j, 2]),
                (w1[k, j, 0], w1[k, j, 1], w1[k, j, 2]),
            )
            if d2 < reach[m] * reach[m]:
                out[k] = m
                break
