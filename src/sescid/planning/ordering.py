"""Visiting order of the chosen poses: nearest neighbour then 2-opt on the joint-space path."""

from __future__ import annotations

import numpy as np


def path_length(q, start=None) -> float:
    """Total joint-space (Euclidean, rad) length of the path start → q[0] → … → q[-1]."""
    q = np.asarray(q, dtype=float)
    pts = q if start is None else np.vstack([np.asarray(start, dtype=float)[None], q])
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())


def order_poses(q, start=None) -> np.ndarray:
    """Permutation of poses q (K, nq) that keeps consecutive poses close: nearest neighbour from
    ``start`` (default the all-zero pose), then 2-opt (open path, start fixed)."""
    q = np.asarray(q, dtype=float)
    k = len(q)
    start = np.zeros(q.shape[1]) if start is None else np.asarray(start, dtype=float)
    pts = np.vstack([start[None], q])  # node 0 = start
    d = np.linalg.norm(pts[:, None, :] - pts[None, :, :], axis=2)
    seq = [0]
    free = np.ones(k + 1, dtype=bool)
    free[0] = False
    for _ in range(k):
        dist = np.where(free, d[seq[-1]], np.inf)
        nxt = int(np.argmin(dist))
        seq.append(nxt)
        free[nxt] = False
    path = np.array(seq)
    # 2-opt: reverse path[i..j] (1 ≤ i < j ≤ k); the open end has no edge after path[k].
    ii, jj = np.triu_indices(k + 1, k=1)
    sel = ii >= 1
    ii, jj = ii[sel], jj[sel]
    for _ in range(50 * k):
        prev, first, last = path[ii - 1], path[ii], path[jj]
        nxt_ok = jj < k
        after = path[np.minimum(jj + 1, k)]
        old = d[prev, first] + np.where(nxt_ok, d[last, after], 0.0)
        new = d[prev, last] + np.where(nxt_ok, d[first, after], 0.0)
        gain = old - new
        best = int(np.argmax(gain))
        if gain[best] <= 1e-12:
            break
        i, j = ii[best], jj[best]
        path[i : j + 1] = path[i : j + 1][::-1].copy()
    return path[1:] - 1
