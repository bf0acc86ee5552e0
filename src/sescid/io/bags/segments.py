"""Which pose each output row belongs to: a pose-id topic, or runs of still joint samples.

Without a pose topic the poses are **segmented by stationarity**: a joint sample is still when
every joint's speed, its change over ``window`` seconds, is below ``max_speed``; runs of still
samples lasting at least ``dwell`` seconds are poses 0, 1, 2, … in time order, or, given the
planned pose list, the id of the planned pose nearest to each run's mean joint angles (largest
joint difference within ``match_deg``; runs matching no planned pose are dropped as
``unmatched_pose``). Joint samples lacking a joint take no part (their rows are dropped as
``missing_joint``, not counted as moving).
"""

from __future__ import annotations

import numpy as np

from sescid.errors import DataError
from sescid.io.bags.mapping import BagMapping


def still_segments(t: np.ndarray, q: np.ndarray, mp: BagMapping) -> np.ndarray:
    """Segment number (0, 1, …) of each joint sample (sorted stamps ``t`` ns, angles ``q``
    (n, nq) rad), −1 while moving or when a joint is missing (NaN)."""
    n = len(t)
    seg = np.full(n, -1)
    full = np.flatnonzero(~np.isnan(q).any(axis=1))
    if len(full) == 0:
        return seg
    t, q = t[full], q[full]
    m = len(t)
    half = int(round(mp.window * 5e8))
    lo = np.searchsorted(t, t - half, side="left")
    hi = np.searchsorted(t, t + half, side="right") - 1
    same = hi <= lo
    lo = np.where(same, np.maximum(np.arange(m) - 1, 0), lo)
    hi = np.where(same, np.minimum(np.arange(m) + 1, m - 1), hi)
    dt = (t[hi] - t[lo]) * 1e-9
    with np.errstate(invalid="ignore", divide="ignore"):
        speed = np.abs(q[hi] - q[lo]).max(axis=1) / dt
    still = (speed < mp.max_speed) & (dt > 0)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], still.astype(int), [0]])))
    k = 0
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        if (t[b - 1] - t[a]) * 1e-9 >= mp.dwell:
            seg[full[a:b]] = k
            k += 1
    return seg


def match_poses(seg, q, poses, mp: BagMapping, notes: list[str]) -> np.ndarray:
    """Per segment, the id of the nearest planned pose (max joint difference ≤ match_deg; ""
    for none)."""
    ids, q_plan = np.asarray(poses[0]).astype(str), np.asarray(poses[1], dtype=float)
    if q_plan.ndim != 2 or q_plan.shape != (len(ids), q.shape[1]):
        raise DataError(
            f"read_bag: the pose list has {q_plan.shape} angles for {len(ids)} ids and "
            f"{q.shape[1]} joints"
        )
    k = int(seg.max()) + 1
    labels = np.full(k, "", dtype=object)
    tol = np.radians(mp.match_deg)
    for i in range(k):
        mean = np.nanmean(q[seg == i], axis=0)
        d = np.abs(q_plan - mean).max(axis=1)
        j = int(np.argmin(d)) if len(d) else -1
        if j >= 0 and d[j] <= tol:
            labels[i] = ids[j]
        else:
            near = f" (nearest {ids[j]}: {np.degrees(d[j]):.1f}°)" if j >= 0 else ""
            notes.append(f"segment {i} matches no planned pose within {mp.match_deg:g}°{near}")
    return labels.astype(str)


def segment_labels(
    ij: np.ndarray, tj: np.ndarray, q: np.ndarray, mp: BagMapping, poses, notes: list[str]
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Pose id of each row (its joint sample ``ij``, −1 for none) from still segments, and the
    rows dropped by reason (boolean masks: moving, unmatched_pose)."""
    seg = still_segments(tj, q, mp)
    has = ij >= 0
    s = np.where(has, seg[np.maximum(ij, 0)], -1)
    labels = np.arange(seg.max() + 1).astype(str)
    drop = {"moving": has & (s < 0)}
    if poses is not None:
        labels = match_poses(seg, q, poses, mp, notes)
    if len(labels) == 0:
        return np.full(len(ij), ""), drop
    pose = np.where(s >= 0, labels[np.maximum(s, 0)], "")
    if poses is not None:
        drop["unmatched_pose"] = has & (s >= 0) & (pose == "")
    return pose, drop


def topic_labels(
    tp: np.ndarray, ids: np.ndarray, t_clock: np.ndarray
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Pose id of each row from a pose topic (the latest id at or before the row; −1 or ""
    mark moving), and the rows dropped by reason (no_pose: before the first id; moving)."""
    o = np.argsort(tp, kind="stable")
    tp, ids = tp[o], ids[o]
    ip = np.searchsorted(tp, t_clock, side="right") - 1
    before = ip < 0
    pose = np.where(before, "", ids[np.maximum(ip, 0)])
    moving = ~before & np.isin(pose, ["", "-1"])
    return pose, {"no_pose": before, "moving": moving}
