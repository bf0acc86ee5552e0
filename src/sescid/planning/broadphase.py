"""Self-collision with a broad phase, for robots with many capsules (mesh coverings): a bounding
sphere per body is tested first, a body pair's capsule pairs only when the spheres meet.

Same answer as ``collision.collision_free_mask`` (the same capsule pairs and distance rule),
computed from body rotations/origins without forming every capsule's world ends.
"""

from __future__ import annotations

import numpy as np

from sescid.planning.capsule_kernels import _broad
from sescid.planning.collision import Capsules


def collision_free_mask_broad(cap: Capsules, rot: np.ndarray, org: np.ndarray) -> np.ndarray:
    """(n,) True where no checked capsule pair intersects; body spheres first (see module)."""
    n, nb = rot.shape[0], rot.shape[1]
    out = np.ones(n, dtype=bool)
    if not len(cap.pairs):
        return out
    _broad(np.ascontiguousarray(rot), np.ascontiguousarray(org), *_spheres(cap, nb), out)
    return out


def _spheres(cap: Capsules, nb: int) -> tuple:
    """The kernel's fixed arguments (body spheres, body pairs, capsule pairs grouped by body
    pair), built once per capsule set and kept on it."""
    kept = getattr(cap, "_broad_args", None)
    if kept is not None and kept[0] == (nb, len(cap.pairs)):
        return kept[1]
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
    args = (
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
    )
    cap._broad_args = ((nb, len(cap.pairs)), args)  # type: ignore[attr-defined]
    return args
