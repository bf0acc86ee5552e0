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
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from sescid.base.threads import one_blas_thread, ordered_map
from sescid.errors import DataError
from sescid.kinematics import (
    Workspace,
    as_poses,
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


def cop_work(robot: Robot, n: int) -> int:
    """Work units (``kinematics.NUMPY_JOB``) of n CoP poses: the chain and two rows of reduced
    columns."""
    return n * (len(robot.body_names) + 2 * robot.reduction.g.shape[0])


def check_cop(cop: ArrayLike, n: int, what: str = "cop") -> np.ndarray:
    """Validate CoP measurements (n, 2), finite metres."""
    arr = np.asarray(cop, dtype=float)
    if arr.shape != (n, 2):
        raise DataError(f"{what}: expected shape ({n}, 2) in metres, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        row = int(np.argwhere(~np.isfinite(arr))[0, 0])
        raise DataError(f"{what}: non-finite CoP at pose {row}")
    return arr


def row_weights(sigma: ArrayLike | None, n: int) -> np.ndarray | None:
    """Per-pose CoP standard errors (n,) or (n, 2) in m → row weights (2n,) = 1/σ²."""
    if sigma is None:
        return None
    s = np.asarray(sigma, dtype=float)
    if s.ndim == 1:
        s = np.repeat(s[:, None], 2, axis=1)
    if s.shape != (n, 2):
        raise DataError(f"sigma: expected shape ({n},) or ({n}, 2) in metres, got {s.shape}")
    if not np.all(np.isfinite(s) & (s > 0)):
        row = int(np.argwhere(~(np.isfinite(s) & (s > 0)))[0, 0])
        raise DataError(f"sigma: standard error at pose {row} must be finite and > 0")
    return (1.0 / s**2).reshape(-1)


def tilted_sums(robot, q, cop, sw, gravity, kernels: bool) -> NormalEquations:
    """The tilted x/y rows' sums (full Φ) of one block of validated poses under per-pose
    gravity (n, 3); ``sw`` (n, 2) square-root weights or None."""
    ne = NormalEquations.empty(3 * len(robot.body_names))
    phi = robot.regressor_tilted(q, gravity)  # (m, 2, P), rows (pose, row)
    y = (cop - robot.d_tilted(gravity, q.shape[0])).reshape(-1)
    add_columns(ne, phi.reshape(-1, phi.shape[2]).T, y, None if sw is None else sw.reshape(-1),
                kernels)  # fmt: skip
    return ne


def add_cop_tilted(robot, ne: NormalEquations, q, cop, sw, gravity, kernels: bool) -> None:
    """Add the tilted x/y rows of validated poses, block by block, to ``ne`` (full Φ)."""
    g = np.asarray(gravity, dtype=float)
    for s in range(0, q.shape[0], ACCUMULATE_BLOCK):
        blk = slice(s, s + ACCUMULATE_BLOCK)
        ne.add_sums(tilted_sums(robot, q[blk], cop[blk], None if sw is None else sw[blk], g[blk],
                                kernels))  # fmt: skip


def reduced_sums(robot, q, y, sw, kernels: bool, ws: Workspace | None) -> NormalEquations:
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


def add_cop_reduced(robot, acc: NormalEquations, q, y, sw, kernels: bool, progress=None) -> None:
    """Add a validated chunk's reduced sums to ``acc``, block by block: each block's sums on
    their own, added in block order (the same bits on any number of threads)."""
    starts = range(0, q.shape[0], ACCUMULATE_BLOCK)

    def block_sums(s: int) -> NormalEquations:
        blk = slice(s, s + ACCUMULATE_BLOCK)
        return reduced_sums(robot, q[blk], y[blk], None if sw is None else sw[blk], kernels, None)

    parts: Iterable[NormalEquations]
    if kernels and len(starts) > 1:  # on every core: the kernels release the GIL
        parts = ordered_map(block_sums, starts)
    else:
        parts = map(block_sums, starts)
    for k, part in enumerate(parts):
        acc.add_sums(part)
        if progress is not None:
            progress(min(starts[k] + ACCUMULATE_BLOCK, q.shape[0]), q.shape[0])


@one_blas_thread()
def accumulate(
    robot: Robot,
    chunks: Iterable[tuple],
    ne: NormalEquations | None = None,
    progress: Callable[[int, int], None] | None = None,
    *,
    validated: bool = False,
) -> NormalEquations:
    """Accumulate normal equations from chunks ``(q, cop)``, ``(q, cop, sigma)`` or
    ``(q, cop, sigma, gravity)``; each chunk is one job (its size picks the path).

    ``gravity`` (n, 3): per-pose gravity direction in the support frame; its rows are the tilted
    ones Φx − (gx/gz) Φz, Φy − (gy/gz) Φz (accumulated in full coordinates: z information
    breaks the x/y reduction). ``progress(done, total)`` is called after each block.
    ``validated``: q and cop already passed ``as_poses``/``check_cop`` (not checked again).
    """
    ne = ne or NormalEquations.empty(3 * len(robot.body_names))
    red = robot.reduction
    acc = NormalEquations.empty(red.g.shape[0])  # in reduced coordinates β = G r
    for chunk in chunks:
        q, cop = chunk[0], chunk[1]
        sigma = chunk[2] if len(chunk) > 2 else None
        gravity = chunk[3] if len(chunk) > 3 else None
        if not validated:
            q = as_poses(q, robot.nq)
            cop = check_cop(cop, q.shape[0])
        w = row_weights(sigma, q.shape[0])
        sw = None if w is None else np.sqrt(w).reshape(-1, 2)
        kernels = use_kernels(cop_work(robot, q.shape[0]))
        if gravity is not None:
            add_cop_tilted(robot, ne, q, cop, sw, gravity, kernels)
            if progress is not None:
                progress(q.shape[0], q.shape[0])
        else:
            add_cop_reduced(robot, acc, q, cop - robot.d[:2], sw, kernels, progress)
        ne.n_poses += q.shape[0]
    ata, atb = expand(red.g, acc)
    ne.ata += ata
    ne.atb += atb
    ne.yty += acc.yty
    ne.n_rows += acc.n_rows
    return ne
