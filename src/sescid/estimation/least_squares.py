"""Least-squares identification of the SESC vectors from CoP measurements.

Each pose gives two equations ``cop − d_xy = Φ_xy(q) · vec(r)``. The regressor is rank deficient
(the OP2's has rank 42 of 63): the fit determines ``r`` only up to its null space. sescid solves
the least-squares problem in the eigenbasis of the normal matrix ``A = ΦᵀΦ`` and fills the
undetermined directions from the prior model (the model file's own SESC vectors ``r0``):

    r̂ = r0 + V_p Λ_p⁻¹ V_pᵀ (Φᵀy − A r0)

— the least-squares solution closest to ``r0``. CoP predictions do not depend on that choice;
CoM height does (partly), and the fit says how much. Rank: see ``identifiability``.

The normal equations are accumulated block by block, so a stream of chunks (``identify_stream``)
gives the same answer as the in-memory path without storing Φ.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator, Sequence

import numpy as np
from numpy.typing import ArrayLike

from sescid.base.threads import one_blas_thread
from sescid.errors import DataError
from sescid.estimation.fit import Fit
from sescid.estimation.identifiability import (
    DEFAULT_RTOL,
    base_combinations,
    check_enough_poses,
    check_rtol,
    eigen_descending,
    label_columns,
    rank_of,
    unidentifiable,
)
from sescid.estimation.normal_equations import (
    ACCUMULATE_BLOCK,
    NormalEquations,
    accumulate,
    check_cop,
)
from sescid.kinematics import as_poses
from sescid.robot import Robot


def solve(
    robot: Robot,
    ne: NormalEquations,
    *,
    rtol: float = DEFAULT_RTOL,
    r_prior: np.ndarray | None = None,
) -> Fit:
    """Least-squares fit from accumulated normal equations (see the module docstring)."""
    check_rtol(rtol)
    if ne.n_poses == 0:
        raise DataError("no poses to identify from")
    r0 = robot.sesc_vectors() if r_prior is None else np.asarray(r_prior, dtype=float)
    lam, vecs = eigen_descending(ne.ata)
    sv = np.sqrt(np.clip(lam, 0, None))
    p = rank_of(sv, rtol)
    vp, lp = vecs[:, :p], lam[:p]
    x0 = r0.reshape(-1)
    x = x0 + vp @ ((vp.T @ (ne.atb - ne.ata @ x0)) / lp)
    rss = max(ne.yty - 2 * x @ ne.atb + x @ ne.ata @ x, 0.0)
    dof = ne.n_rows - p
    sigma_hat = math.sqrt(rss / dof) if dof > 0 else float("nan")
    cov = (vp / lp) @ vp.T * (sigma_hat**2 if dof > 0 else np.nan)
    labels = label_columns(robot)
    r = x.reshape(-1, 3)
    return Fit(
        robot=robot,
        r=r,
        r_prior=r0.copy(),
        cov=cov,
        basis=vp,
        singular_values=sv,
        rank=p,
        n_poses=ne.n_poses,
        n_rows=ne.n_rows,
        sigma_hat=sigma_hat,
        rms=math.sqrt(rss / ne.n_rows),
        mae=float("nan"),
        rtol=rtol,
        method="ls",
        base=base_combinations(sv, vecs, p, labels, r, np.nan_to_num(cov)),
        unidentifiable=unidentifiable(robot, vp, labels),
    )


def residual_stats(fit: Fit, q: np.ndarray, cop: np.ndarray, gravity=None) -> None:
    """Set ``fit.mae`` and ``fit.rms`` (m) from the data, net of any estimated CoP offset."""
    resid = np.subtract(cop, fit.predict_cop(q, gravity))
    resid -= fit.cop_bias
    flat = resid.reshape(-1)
    fit.mae = float(np.abs(resid, out=resid).mean()) if flat.size else float("nan")
    fit.rms = math.sqrt(float(np.dot(flat, flat)) / flat.size) if flat.size else float("nan")


@one_blas_thread()
def identify_ls(
    robot: Robot,
    q: ArrayLike,
    cop: ArrayLike,
    *,
    sigma: ArrayLike | None = None,
    rtol: float = DEFAULT_RTOL,
    r_prior: np.ndarray | None = None,
    progress: Callable[[int, int], None] | None = None,
    gravity: ArrayLike | None = None,
) -> Fit:
    """Least-squares SESC vectors from poses q (n, nq) [rad] and measured CoPs (n, 2) [m].

    ``sigma``: optional per-pose CoP standard errors (n,) or (n, 2) [m] → weighted least squares.
    ``r_prior``: SESC vectors that fill the undetermined directions (default: the model's).
    ``gravity``: per-pose gravity directions (n, 3) in the support frame (None: along −z).
    """
    qq = as_poses(q, robot.nq)
    cc = check_cop(cop, qq.shape[0])
    check_enough_poses(robot, qq.shape[0])
    ne = accumulate(robot, [(qq, cc, sigma, gravity)], progress=progress, validated=True)
    fit = solve(robot, ne, rtol=rtol, r_prior=r_prior)
    fit.weighted = sigma is not None
    residual_stats(fit, qq, cc, gravity)
    return fit


@one_blas_thread()
def identify_stream(
    robot: Robot,
    chunks: Iterable[tuple],
    *,
    rtol: float = DEFAULT_RTOL,
    r_prior: np.ndarray | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Fit:
    """Same fit as ``identify`` from an iterable of chunks ``(q, cop[, sigma])``.

    Φ is never stored: memory stays at one block whatever the number of poses. The residual
    MAE needs a second pass over the data and is left as nan; the RMS is exact.
    """
    weighted = False

    def seen():
        nonlocal weighted
        for chunk in chunks:
            weighted = weighted or (len(chunk) > 2 and chunk[2] is not None)
            yield chunk

    ne = accumulate(robot, seen(), progress=progress)
    check_enough_poses(robot, ne.n_poses)
    fit = solve(robot, ne, rtol=rtol, r_prior=r_prior)
    fit.weighted = weighted
    return fit


@one_blas_thread()
def identify_chunks(
    robot: Robot,
    chunks: Sequence[tuple],
    *,
    rtol: float = DEFAULT_RTOL,
    r_prior: np.ndarray | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Fit:
    """``identify_ls`` over chunks ``(q, cop[, sigma[, gravity]])`` of one data set, as a
    streamed file gives them: the same fit, MAE and RMS (to rounding), the chunks never joined.

    Two passes over the chunks (normal equations, then residuals), so they are a sequence.
    """
    checked = []
    for c in chunks:
        q = as_poses(c[0], robot.nq)
        sigma = c[2] if len(c) > 2 else None
        gravity = c[3] if len(c) > 3 else None
        checked.append((q, check_cop(c[1], q.shape[0]), sigma, gravity))
    total = sum(c[0].shape[0] for c in checked)
    check_enough_poses(robot, total)
    done = 0

    def each():  # blocks of ACCUMULATE_BLOCK poses, as in memory: the same sums, bit for bit
        nonlocal done
        for c in _reblock(checked, ACCUMULATE_BLOCK):
            yield c
            done += c[0].shape[0]

    report = None if progress is None else (lambda d, _n: progress(done + d, total))
    ne = accumulate(robot, each(), progress=report)
    fit = solve(robot, ne, rtol=rtol, r_prior=r_prior)
    fit.weighted = any(c[2] is not None for c in checked)
    abs_sum = sq_sum = 0.0
    for q, cop, _sigma, gravity in checked:
        resid = cop - fit.predict_cop(q, gravity) - fit.cop_bias
        abs_sum += float(np.sum(np.abs(resid)))
        sq_sum += float(np.sum(resid**2))
    fit.mae = abs_sum / (2 * total)
    fit.rms = math.sqrt(sq_sum / (2 * total))
    return fit


def _reblock(chunks: Sequence[tuple], size: int) -> Iterator[tuple]:
    """The rows of consecutive chunks of arrays (or None) regrouped in blocks of ``size``."""
    parts: list[tuple] = []
    count = 0
    for c in chunks:
        start, n = 0, c[0].shape[0]
        while start < n:
            take = min(size - count, n - start)
            parts.append(tuple(None if a is None else a[start : start + take] for a in c))
            count, start = count + take, start + take
            if count == size:
                yield _cat(parts)
                parts, count = [], 0
    if parts:
        yield _cat(parts)


def _cat(parts: list[tuple]) -> tuple:
    if len(parts) == 1:
        return parts[0]
    return tuple(
        None if parts[0][i] is None else np.concatenate([p[i] for p in parts])
        for i in range(len(parts[0]))
    )
