"""Self-collision with a broad phase, for robots with many capsules (mesh coverings): a bounding
sphere per body is tested first, a body pair's capsule pairs only when the spheres meet.

Same answer as ``collision.collision_free_mask`` (the same capsule pairs and distance rule),
computed from body rotations/origins without forming every capsule's world ends. Body pairs are
tried in the order of how often they rejected poses so far (kept on the capsule set): a pose in
collision is found out sooner; the answer does not depend on the order.
"""

from __future__ import annotations

import numpy as np

from sescid.planning.feasibility.capsule_kernels import (
    BodyPairs,
    BodySpheres,
    BroadPhase,
    CapsuleEnds,
    broad_phase_kernel,
)
from sescid.planning.feasibility.collision import Capsules
from sescid.robot import Robot

BLOCK = 8192  #: poses per forward-kinematics block


def collision_free_mask_broad(cap: Capsules, rot: np.ndarray, org: np.ndarray) -> np.ndarray:
    """(n,) True where no checked capsule pair intersects; body spheres first (see module).

    ``rot`` (n, N, 3, 3), ``org`` (n, N, 3) from ``robot.forward``."""
    out = np.ones(rot.shape[0], dtype=bool)
    if rot.shape[0] and len(cap.pairs):
        _check(cap, np.ascontiguousarray(rot), np.ascontiguousarray(org), out)
    return out


def collision_free_poses(robot: Robot, cap: Capsules, q: np.ndarray) -> np.ndarray:
    """(n,) True where no checked capsule pair intersects at poses q (n, nq) [rad]; forward
    kinematics in blocks of ``BLOCK`` poses (many at once are bound by memory)."""
    out = np.ones(len(q), dtype=bool)
    if len(q) and len(cap.pairs):
        for s in range(0, len(q), BLOCK):
            rot, org = robot.forward(q[s : s + BLOCK])
            _check(cap, rot, org, out[s : s + BLOCK])
    return out


def _check(cap: Capsules, rot: np.ndarray, org: np.ndarray, out: np.ndarray) -> None:
    """The kernel on poses; then the body pairs re-ordered by how many poses they rejected."""
    phase = _phase(cap, rot.shape[1])
    broad_phase_kernel(rot, org, phase, out)
    order = np.argsort(-phase.body_pairs.hits, kind="stable")  # most rejecting first, next call
    for a in phase.body_pairs:
        a[:] = a[order]


def _phase(cap: Capsules, nb: int) -> BroadPhase:
    """The kernel's fixed arguments (body spheres, body pairs, capsule pairs grouped by body
    pair), built once per capsule set and kept on it."""
    kept = getattr(cap, "_broad_phase", None)
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
    phase = BroadPhase(
        capsules=CapsuleEnds(
            body=cap.body.astype(np.int64),
            p0=np.ascontiguousarray(cap.p0),
            p1=np.ascontiguousarray(cap.p1),
            radius=cap.radius.astype(float),
        ),
        spheres=BodySpheres(centre=sph_c, radius=sph_r),
        body_pairs=BodyPairs(
            i=(key[first] // nb).astype(np.int64),
            j=(key[first] % nb).astype(np.int64),
            lo=start[:-1].copy(),
            hi=start[1:].copy(),
            hits=np.zeros(len(first), dtype=np.int64),
        ),
        pair_i=np.ascontiguousarray(pairs[:, 0]),
        pair_j=np.ascontiguousarray(pairs[:, 1]),
    )
    cap._broad_phase = ((nb, len(cap.pairs)), phase)  # type: ignore[attr-defined]
    return phase
