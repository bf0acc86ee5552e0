"""Distinct poses: a pose repeated (joint angles within ``SAME_POSE``) counts once, since an
error tied to a pose repeats with it."""

from __future__ import annotations

import math

import numpy as np

#: joint angles within this of a counted pose's, in every joint, are that pose again, rad: an
#: error tied to the pose (a CoP sensor's bias there, the foot's compliance, a servo's play)
#: repeats with it, so repeating a pose adds no information beyond its noise (a servo's play
#: scatters the readings of one commanded pose over ~1°: the OP2 bench, 30 repeats)
SAME_POSE = math.radians(2.0)


class DistinctPoses:
    """The distinct poses of a source (``SAME_POSE``), counted up to ``cap``: beyond it the
    count no longer matters (each pose adds at least one equation) and counting stops."""

    #: rows hashed at once, and compared at once
    BLOCK, COMPARE = 8192, 256

    def __init__(self, nq: int, cap: int):
        self.cap = cap
        self.kept = np.zeros((0, nq))
        self.mult = np.random.default_rng(0).integers(1, 2**62, nq, dtype=np.int64) | 1

    @property
    def count(self) -> int:
        """Distinct poses so far (at most ``cap``)."""
        return len(self.kept)

    def add(self, q: np.ndarray) -> None:
        """Count the poses q (n, nq) [rad]: each block's rows one per grid cell of
        ``SAME_POSE`` (a hash of the cell), those far from every kept pose, then, per new
        distinct pose, those far from it too."""
        q = np.asarray(q, dtype=float)
        for start in range(0, q.shape[0], self.BLOCK):
            if self.count >= self.cap:
                return
            blk = q[start : start + self.BLOCK]
            with np.errstate(over="ignore"):
                cell = np.floor(blk / SAME_POSE).astype(np.int64) @ self.mult  # wraps: a hash
            blk = blk[np.sort(np.unique(cell, return_index=True)[1])]
            for sub in range(0, blk.shape[0], self.COMPARE):
                if self.count >= self.cap:
                    return
                rest = blk[sub : sub + self.COMPARE]
                if self.count:
                    far = np.abs(rest[:, None, :] - self.kept[None]).max(axis=2) > SAME_POSE
                    rest = rest[far.all(axis=1)]
                while rest.shape[0] and self.count < self.cap:
                    self.kept = np.vstack([self.kept, rest[:1]])
                    rest = rest[1:][np.abs(rest[1:] - rest[0]).max(axis=1) > SAME_POSE]
