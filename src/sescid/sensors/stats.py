"""Per-pose statistics of raw samples, vectorised over groups (no loop over poses).

Samples carry a group index ``g ∈ [0, k)`` (their pose, in the log's order of first
appearance: ``PoseGroups``); means, standard errors, medians and the robust outlier rule
``|v − median| > k · max(1.4826 MAD, floor)`` are computed per group with ``bincount`` and one
sort.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PoseGroups:
    """Samples grouped by pose id, poses in the log's order of first appearance."""

    ids: np.ndarray  #: (k,) pose ids (text)
    g: np.ndarray  #: (m,) group index of each sample

    @classmethod
    def of(cls, pose: np.ndarray) -> PoseGroups:
        """Groups of the pose-id column ``pose`` (m,)."""
        ids, first, g = np.unique(pose, return_index=True, return_inverse=True)
        order = np.argsort(first)  # keep the log's order of poses
        rank = np.empty_like(order)
        rank[order] = np.arange(len(order))
        return cls(ids[order], rank[g].reshape(-1))

    @property
    def k(self) -> int:
        """Number of poses."""
        return len(self.ids)

    def count(self, ok: np.ndarray) -> np.ndarray:
        """(k,) samples with ``ok`` per pose."""
        return np.bincount(self.g[ok], minlength=self.k)

    def mean(self, values: np.ndarray, ok: np.ndarray) -> np.ndarray:
        """(k, c) mean of ``values`` (m, c) over the samples with ``ok`` (NaN for none)."""
        n = self.count(ok)
        sums = np.stack(
            [
                np.bincount(self.g[ok], values[ok, j], minlength=self.k)
                for j in range(values.shape[1])
            ],
            axis=1,
        ).reshape(self.k, values.shape[1])
        with np.errstate(invalid="ignore", divide="ignore"):
            return sums / n[:, None]

    def variance(self, values: np.ndarray, ok: np.ndarray, mean: np.ndarray) -> np.ndarray:
        """(k, c) sample variance (n − 1 in the denominator, at least 1) about ``mean`` (k, c)."""
        n = self.count(ok)
        dev = values[ok] - mean[self.g[ok]]
        ss = np.stack(
            [
                np.bincount(self.g[ok], dev[:, j] ** 2, minlength=self.k)
                for j in range(dev.shape[1])
            ],
            axis=1,
        ).reshape(self.k, values.shape[1])
        return ss / np.maximum(n - 1, 1)[:, None]

    def outliers(self, values: np.ndarray, ok: np.ndarray, kk: float, floor: float) -> np.ndarray:
        """(m,) True where ``ok`` and ``values`` (m,) is an outlier within its pose."""
        out = np.zeros(len(values), dtype=bool)
        if ok.any():
            out[ok] = outliers(values[ok], self.g[ok], self.k, kk, floor)
        return out


def group_median(v: np.ndarray, g: np.ndarray, k: int) -> np.ndarray:
    """Median of v within each group g ∈ [0, k) (NaN for empty groups), vectorised."""
    order = np.lexsort((v, g))
    vs = v[order]
    counts = np.bincount(g, minlength=k)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    has = counts > 0
    med = np.full(k, np.nan)
    lo = starts[has] + (counts[has] - 1) // 2
    hi = starts[has] + counts[has] // 2
    med[has] = 0.5 * (vs[lo] + vs[hi])
    return med


def outliers(values: np.ndarray, g: np.ndarray, k: int, kk: float, floor: float) -> np.ndarray:
    """Boolean (m,): |v − median| > kk · max(1.4826 MAD, floor) within each group."""
    med = group_median(values, g, k)
    dev = np.abs(values - med[g])
    scale = np.maximum(1.4826 * group_median(dev, g, k), floor)
    return dev > kk * scale[g]
