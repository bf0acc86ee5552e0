"""Visiting order of the chosen poses: nearest neighbour, then 2-opt on the joint-space path.

One compiled pass (``_order``): Euclidean joint-space distances [rad] between the start and the
poses, a nearest-neighbour path from the start, then 2-opt sweeps (each pair of path edges in
turn; an improving reversal is applied at once) until a sweep improves nothing or the sweeps
reach a work budget (``TWO_OPT_WORK`` pair evaluations: all of them for hundreds of poses, two
sweeps for 2000, which give most of the gain). No
``fastmath``, ties to the lower index: the same order on every CPU. Above ``TWO_OPT_MAX`` poses
the distance matrix would not fit comfortably in memory, and the order is nearest neighbour only.
"""

from __future__ import annotations

import numpy as np

from sescid.kinematics import lazy_njit

TWO_OPT_MAX = 4000  #: poses; beyond this the path is nearest neighbour only
TWO_OPT_SWEEPS = 200  #: at most this many 2-opt sweeps
TWO_OPT_WORK = 8_000_000  #: at most this many pair evaluations over all sweeps
_GAIN = 1e-12  #: rad, a reversal must shorten the path by more than this


def path_length(q, start=None) -> float:
    """Total joint-space (Euclidean, rad) length of the path start → q[0] → … → q[-1]."""
    q = np.asarray(q, dtype=float)
    pts = q if start is None else np.vstack([np.asarray(start, dtype=float)[None], q])
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())


@lazy_njit(cache=True, nogil=True)
def _distances(pts):  # pragma: no cover - compiled
    """(m, m) Euclidean distances between the rows of ``pts`` (m, nq), summed in column order."""
    m, nq = pts.shape
    d = np.zeros((m, m))
    for a in range(m):
        for b in range(a + 1, m):
            acc = 0.0
            for c in range(nq):
                t = pts[a, c] - pts[b, c]
                acc += t * t
            d[a, b] = np.sqrt(acc)
            d[b, a] = d[a, b]
    return d


@lazy_njit(cache=True, nogil=True)
def _nearest_path(pts):  # pragma: no cover - compiled
    """Nearest-neighbour path (m,) over the rows of ``pts`` from row 0 (ties: the lower row)."""
    m, nq = pts.shape
    path = np.empty(m, dtype=np.int64)
    free = np.ones(m, dtype=np.bool_)
    path[0] = 0
    free[0] = False
    for s in range(1, m):
        cur = path[s - 1]
        best = -1
        best_d = np.inf
        for b in range(m):
            if free[b]:
                acc = 0.0
                for c in range(nq):
                    t = pts[cur, c] - pts[b, c]
                    acc += t * t
                if acc < best_d:
                    best_d = acc
                    best = b
        path[s] = best
        free[best] = False
    return path


@lazy_njit(cache=True, nogil=True)
def _two_opt(path, d, sweeps, tol):  # pragma: no cover - compiled
    """2-opt on the open path ``path`` (m,) (node path[0] fixed) with distances ``d``, in place:
    reverse path[i..j] (1 ≤ i < j ≤ m − 1) when that shortens it by more than ``tol``."""
    last = path.shape[0] - 1
    for _ in range(sweeps):
        improved = False
        for i in range(1, last):
            for j in range(i + 1, last + 1):
                a = path[i - 1]
                b = path[i]
                c = path[j]
                gain = d[a, b] - d[a, c]
                if j < last:
                    e = path[j + 1]
                    gain += d[c, e] - d[b, e]
                if gain > tol:
                    lo = i
                    hi = j
                    while lo < hi:
                        t = path[lo]
                        path[lo] = path[hi]
                        path[hi] = t
                        lo += 1
                        hi -= 1
                    improved = True
        if not improved:
            return


def order_poses(q, start=None) -> np.ndarray:
    """Permutation of poses q (K, nq) [rad] that keeps consecutive poses close: nearest neighbour
    from ``start`` (default the all-zero pose), then 2-opt (open path, start fixed; up to
    ``TWO_OPT_MAX`` poses)."""
    q = np.asarray(q, dtype=float)
    start = np.zeros(q.shape[1]) if start is None else np.asarray(start, dtype=float)
    pts = np.ascontiguousarray(np.vstack([start[None], q]))  # node 0 = start
    path = _nearest_path(pts)
    if len(q) <= TWO_OPT_MAX:
        sweeps = min(TWO_OPT_SWEEPS, max(1, TWO_OPT_WORK // max(len(q) ** 2 // 2, 1)))
        _two_opt(path, _distances(pts), sweeps, _GAIN)
    return path[1:] - 1
