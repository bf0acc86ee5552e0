"""Normal equations ΦᵀWΦ, ΦᵀWy accumulated block by block, and the data checks they need.

The x/y regressor is accumulated in reduced coordinates (``Robot.reduction``: the structural
null directions removed in closed form) and expanded exactly, so a stream of chunks gives the
same sums as one array without storing Φ. Every sum runs in a fixed order, never BLAS's (whose
order follows the CPU): the compiled product (``kinematics.gram_columns``: FMAs in 8 lanes) for
a large job, numpy one column at a time for a small one (``kinematics.use_kernels``: the job's size
alone decides), so the same data give the same bits on every machine.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from sescid.errors import DataError
from sescid.kinematics import (
    Workspace,
    gram_columns,
    gram_reduced,
    reduced_columns,
    split_augmented,
    use_kernels,
)
from sescid.robot import Robot

#: poses per block when accumulating normal equations
ACCUMULATE_BLOCK = 2048


def poses_needed(combinations: int, rows_per_pose: float = 2.0) -> int:
    """Fewest poses whose equations (``rows_per_pose`` each: 2 for a CoP) determine
    ``combinations`` and leave one degree of freedom to estimate the noise: the one rule
    behind every minimum (least squares refuses fewer, the planners ask for at least these)."""
    return max(math.ceil((combinations + 1) / rows_per_pose), 1)


@dataclass
class NormalEquations:
    """Running sums of a (weighted) least-squares problem y ≈ Φ x, Φ with P columns."""

    ata: np.ndarray  #: (P, P) ΦᵀWΦ
    atb: np.ndarray  #: (P,) ΦᵀWy
    yty: float = 0.0  #: yᵀWy
    n_rows: int = 0
    n_poses: int = 0

    @classmethod
    def empty(cls, n_params: int) -> NormalEquations:
        """Zero sums for ``n_params`` unknowns."""
        return cls(np.zeros((n_params, n_params)), np.zeros(n_params))

    def add(self, phi_t: np.ndarray, y: np.ndarray, w: np.ndarray | None = None) -> None:
        """Add rows given as columns: phi_t = Φᵀ (P, m), y (m,), optional weights w (m,) = 1/σ²
        (in a fixed order: ``add_columns`` on the job's path)."""
        sw = None if w is None else np.sqrt(w)
        add_columns(self, phi_t, y, sw, use_kernels(phi_t.shape[0] * phi_t.shape[1]))

    def add_sums(self, other: NormalEquations) -> None:
        """Add another block's sums (its rows; the poses are counted by the caller)."""
        self.ata += other.ata
        self.atb += other.atb
        self.yty += other.yty
        self.n_rows += other.n_rows

    def rss(self, theta: np.ndarray) -> float:
        """yᵀWy − 2θᵀΦᵀWy + θᵀΦᵀWΦθ: the weighted residual sum of squares at θ (from the sums
        alone; round-off may leave it slightly negative)."""
        return float(self.yty - 2 * theta @ self.atb + theta @ self.ata @ theta)


def add_columns(
    acc: NormalEquations, x: np.ndarray, y: np.ndarray, sw: np.ndarray | None, kernels: bool
) -> None:
    """Add a block given as columns x = Φᵀ (P, m), P ≤ acc's size, targets y (m,) and
    square-root weights sw (m,) or None: the augmented product [x; y][x; y]ᵀ compiled (FMAs in
    8 lanes) when ``kernels``, else numpy one column at a time (``kinematics.gram_columns``)."""
    if sw is not None:
        x, y = x * sw, y * sw
    p = x.shape[0]
    aug = np.empty((p + 1, x.shape[1]))
    aug[:p] = x
    aug[p] = y
    ata, atb, yty = split_augmented(gram_columns(aug, kernels), p)
    acc.ata[:p, :p] += ata
    acc.atb[:p] += atb
    acc.yty += yty
    acc.n_rows += x.shape[1]


def matmul_fixed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A (m, k) @ b (k, n) [or (k,)] summed over k in order, each product and sum rounded on its
    own: the same bits on every CPU (BLAS picks its order and FMAs by CPU)."""
    vec = b.ndim == 1
    b2 = b[:, None] if vec else b
    out = np.zeros((a.shape[0], b2.shape[1]))
    tmp = np.empty_like(out)
    for k in range(a.shape[1]):
        np.multiply(a[:, k, None], b2[None, k, :], out=tmp)
        out += tmp
    return out[:, 0] if vec else out


def expand(g: np.ndarray, ne: NormalEquations) -> tuple[np.ndarray, np.ndarray]:
    """(Gᵀ A G, Gᵀ b) of reduced sums (A, b) over β = G θ, in a fixed order."""
    gt = np.ascontiguousarray(g.T)
    return matmul_fixed(matmul_fixed(gt, ne.ata), g), matmul_fixed(gt, ne.atb)


def check_cop(cop: ArrayLike, n: int, what: str = "cop") -> np.ndarray:
    """Validate CoP measurements (n, 2), finite metres."""
    arr = np.asarray(cop, dtype=float)
    if arr.shape != (n, 2):
        raise DataError(f"{what}: expected shape ({n}, 2) in metres, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        row = int(np.argwhere(~np.isfinite(arr))[0, 0])
        raise DataError(f"{what}: non-finite CoP at pose {row}")
    return arr


def cop_errors(sigma: ArrayLike, n: int) -> np.ndarray:
    """Per-pose CoP standard errors (n,) or (n, 2) in m as validated (n, 2) errors."""
    s = np.asarray(sigma, dtype=float)
    if s.ndim == 1:
        s = np.repeat(s[:, None], 2, axis=1)
    if s.shape != (n, 2):
        raise DataError(f"sigma: expected shape ({n},) or ({n}, 2) in metres, got {s.shape}")
    if not np.all(np.isfinite(s) & (s > 0)):
        row = int(np.argwhere(~(np.isfinite(s) & (s > 0)))[0, 0])
        raise DataError(f"sigma: standard error at pose {row} must be finite and > 0")
    return s


def tilted_sums(robot: Robot, q, cop, sw, gravity, kernels: bool) -> NormalEquations:
    """The tilted x/y rows' sums (full Φ) of one block of validated poses under per-pose
    gravity (n, 3); ``sw`` (n, 2) square-root weights or None."""
    ne = NormalEquations.empty(3 * len(robot.body_names))
    phi = robot.regressor_tilted(q, gravity)  # (m, 2, P), rows (pose, row)
    y = (cop - robot.d_tilted(gravity, q.shape[0])).reshape(-1)
    add_columns(ne, phi.reshape(-1, phi.shape[2]).T, y, None if sw is None else sw.reshape(-1),
                kernels)  # fmt: skip
    return ne


def reduced_sums(robot: Robot, q, y, sw, kernels: bool, ws: Workspace | None) -> NormalEquations:
    """One block's reduced CoP sums (P_red): the fused kernel when ``kernels`` (numpy's exact
    reduction and the compiled product for angles beyond its range), else numpy."""
    red = robot.reduction
    p = red.g.shape[0]
    part = NormalEquations.empty(p)
    if kernels:
        sums = gram_reduced(robot.tree, red, q, y, sw)
        if sums is not None:
            part.ata, part.atb, part.yty = sums
            part.n_rows = y.shape[0] * y.shape[1]
            return part
    x = reduced_columns(robot.tree, red, q, ws, kernels)  # (P_red, 2m): x rows, y rows
    add_columns(part, x, y.T.reshape(-1), None if sw is None else sw.T.reshape(-1), kernels)
    return part
