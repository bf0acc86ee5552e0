"""Normal equations ΦᵀWΦ, ΦᵀWy accumulated block by block, and the data checks they need.

The x/y regressor is accumulated in reduced coordinates (``Robot.reduction``: the structural
null directions removed in closed form) and expanded exactly, so a stream of chunks gives the
same sums as one array without storing Φ.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from sescid.base.threads import one_blas_thread, ordered_map
from sescid.errors import DataError
from sescid.kinematics import (
    Workspace,
    as_poses,
    compiled,
    gram_reduced,
    gram_upper,
    padded,
    reduced_columns,
)
from sescid.robot import Robot

#: poses per block when accumulating normal equations
ACCUMULATE_BLOCK = 2048


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
        """Add rows given as columns: phi_t = Φᵀ (P, m), y (m,), optional weights w (m,) = 1/σ²."""
        if w is not None:
            sw = np.sqrt(w)
            phi_t = phi_t * sw
            y = y * sw
        self.ata += phi_t @ phi_t.T
        self.atb += phi_t @ y
        self.yty += float(y @ y)
        self.n_rows += phi_t.shape[1]


def add_columns(acc: NormalEquations, x: np.ndarray, y: np.ndarray, sw: np.ndarray | None) -> None:
    """Add a block given as columns x = Φᵀ (P, m) ≤ acc's padded size, targets y (m,) and
    square-root weights sw (m,) or None: compiled (one core) once the kernels are loaded,
    BLAS for the few small blocks before."""
    if sw is not None:
        x, y = x * sw, y * sw
    if compiled():
        acc.yty += gram_upper(x, y, acc.ata, acc.atb)
    else:
        p = x.shape[0]
        acc.ata[:p, :p] += x @ x.T
        acc.atb[:p] += x @ y
        acc.yty += float(y @ y)
    acc.n_rows += x.shape[1]


def upper_to_full(a: np.ndarray) -> np.ndarray:
    """The symmetric matrix whose upper triangle ``a`` holds."""
    return np.triu(a) + np.triu(a, 1).T


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


def add_cop_tilted(robot, ne: NormalEquations, q, cop, sw, gravity, progress=None) -> None:
    """Add the tilted x/y rows of validated poses under per-pose gravity (n, 3) to ``ne`` (full
    Φ); ``sw`` (n, 2) square-root weights or None."""
    g = np.asarray(gravity, dtype=float)
    d = robot.d_tilted(g, q.shape[0])
    block = ACCUMULATE_BLOCK
    for s in range(0, q.shape[0], block):
        blk = slice(s, s + block)
        phi = robot.regressor_tilted(q[blk], g[blk])  # (m, 2, P)
        y = (cop[blk] - d[blk]).reshape(-1)
        ne.add(phi.reshape(-1, phi.shape[2]).T, y, None if sw is None else sw[blk].reshape(-1) ** 2)
        if progress is not None:
            progress(min(s + block, q.shape[0]), q.shape[0])


def add_cop_reduced(robot, acc: NormalEquations, q, y, sw, ws: Workspace, progress) -> None:
    """Add a validated chunk's reduced sums to ``acc``, block by block: each block's sums on
    their own, added in block order (the same bits on any number of threads)."""
    red = robot.reduction
    starts = range(0, q.shape[0], ws.block)

    def block_sums(s: int, ws: Workspace | None = ws) -> NormalEquations:
        """One block's sums; ``ws`` None on a worker thread (the shared one is not safe)."""
        part = NormalEquations.empty(acc.ata.shape[0])
        blk = slice(s, s + ACCUMULATE_BLOCK)
        sw_b = None if sw is None else sw[blk]
        yty = gram_reduced(robot.tree, red, q[blk], y[blk], sw_b, part.ata, part.atb)
        if yty is None:  # kernels not loaded yet, or huge angles: columns, then product
            x = reduced_columns(robot.tree, red, q[blk], ws)  # (P_red, 2m): x rows, y rows
            add_columns(part, x, y[blk].T.reshape(-1), None if sw_b is None else sw_b.T.reshape(-1))
        else:
            part.yty, part.n_rows = yty, 2 * y[blk].shape[0]
        return part

    if not starts:
        return
    first = block_sums(starts[0])  # alone: it may load the kernels
    rest = starts[1:]
    if compiled() and len(rest) > 1:  # then on every core: the kernels release the GIL
        parts: Iterable[NormalEquations] = ordered_map(lambda s: block_sums(s, None), rest)
    else:
        parts = map(block_sums, rest)
    for k, part in enumerate(itertools.chain([first], parts)):
        acc.ata += part.ata
        acc.atb += part.atb
        acc.yty += part.yty
        acc.n_rows += part.n_rows
        if progress is not None:
            progress(min(starts[k] + ws.block, q.shape[0]), q.shape[0])


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
    ``(q, cop, sigma, gravity)``.

    ``gravity`` (n, 3): per-pose gravity direction in the support frame; its rows are the tilted
    ones Φx − (gx/gz) Φz, Φy − (gy/gz) Φz (accumulated in full coordinates: z information
    breaks the x/y reduction). ``progress(done, total)`` is called after each block.
    ``validated``: q and cop already passed ``as_poses``/``check_cop`` (not checked again).
    """
    ne = ne or NormalEquations.empty(3 * len(robot.body_names))
    d_xy = robot.d[:2]
    ws = Workspace(robot.tree, ACCUMULATE_BLOCK)
    red = robot.reduction
    p_red = red.g.shape[0]
    acc = NormalEquations.empty(padded(p_red))  # in reduced coordinates β = G r (zero-padded)
    for chunk in chunks:
        q, cop = chunk[0], chunk[1]
        sigma = chunk[2] if len(chunk) > 2 else None
        gravity = chunk[3] if len(chunk) > 3 else None
        if not validated:
            q = as_poses(q, robot.nq)
            cop = check_cop(cop, q.shape[0])
        w = row_weights(sigma, q.shape[0])
        if gravity is not None:
            sw_t = None if w is None else np.sqrt(w).reshape(-1, 2)
            add_cop_tilted(robot, ne, q, cop, sw_t, gravity, progress)
            ne.n_poses += q.shape[0]
            continue
        y = cop - d_xy
        sw = None if w is None else np.sqrt(w).reshape(-1, 2)
        add_cop_reduced(robot, acc, q, y, sw, ws, progress)
        ne.n_poses += q.shape[0]
    ne.ata += red.g.T @ upper_to_full(acc.ata)[:p_red, :p_red] @ red.g
    ne.atb += red.g.T @ acc.atb[:p_red]
    ne.yty += acc.yty
    ne.n_rows += acc.n_rows
    return ne
