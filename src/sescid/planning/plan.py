"""The whole pose plan: candidates, D-optimal (or random) choice, order, expected error."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from sescid.base.threads import one_blas_thread
from sescid.errors import OptionError, SescidError
from sescid.estimation import min_poses, structural_rank
from sescid.planning.candidates import Candidates, candidates
from sescid.planning.com import level_cop
from sescid.planning.doptimal import (
    Selection,
    expected_cop_error,
    identifiable_basis,
    information,
    per_row_information,
    projected_regressor,
    random_cop_error,
    select_d_optimal,
)
from sescid.planning.ordering import order_poses, path_length
from sescid.planning.stability import DEFAULT_CLEARANCE
from sescid.robot import Robot
from sescid.simulation import PAPER_NOISE


@dataclass
class PosePlan:
    """K chosen poses in visiting order, with what the choice is expected to achieve."""

    q: np.ndarray  #: (K, nq) rad, ordered
    cop: np.ndarray  #: (K, 2) model CoP on a level floor, m (CPU-independent bits)
    method: str  #: "d-optimal" or "random"
    expected_error: float  #: m, expected noise-free CoP error of least squares on these poses
    random_error: float  #: m, the same for K random candidates (median over draws)
    sigma: float  #: m, CoP noise assumed
    rank: int  #: dimension p of the identifiable subspace
    logdet: float
    path_unordered: float  #: rad, joint-space path length in selection order
    path_ordered: float  #: rad, after ordering
    candidates: Candidates
    selection: Selection
    basis: np.ndarray  #: (3N, p)
    a_pool: np.ndarray = field(repr=False)  #: (n, 2, p)
    c_test: np.ndarray = field(repr=False)  #: (p, p)


@one_blas_thread()
def plan_poses(
    robot: Robot,
    count: int = 38,
    select: str = "d-optimal",
    seed: int = 0,
    *,
    n_candidates: int = 20_000,
    n_test: int = 2_000,
    sigma: float = PAPER_NOISE,
    limits: np.ndarray | None = None,
    half_extents=None,
    clearance: float = DEFAULT_CLEARANCE,
    random_draws: int = 50,
    progress: Callable[[int, int], None] | None = None,
) -> PosePlan:
    """Sample candidates, choose ``count`` poses (``select`` = "d-optimal" | "random"), order them.

    The expected error is computed on ``n_test`` further candidates (held out from the pool).
    """
    if select not in ("d-optimal", "random"):
        raise SescidError(f"unknown selection '{select}' (d-optimal or random)")
    need = min_poses(robot)
    if count < need:
        raise OptionError(
            "count",
            f"{count} poses are too few: {robot.name} has {structural_rank(robot)} identifiable "
            f"combinations, which need at least {need} poses (2 equations each)",
        )
    if count > n_candidates:
        raise SescidError(f"cannot choose {count} poses from {n_candidates} candidates")
    cand = candidates(
        robot,
        n_candidates + n_test,
        seed,
        limits=limits,
        half_extents=half_extents,
        clearance=clearance,
        progress=progress,
    )
    pool_q, test_q = cand.q[:n_candidates], cand.q[n_candidates:]
    basis = identifiable_basis(robot, pool_q)
    a_pool = projected_regressor(robot, pool_q, basis)
    c_test = per_row_information(projected_regressor(robot, test_q, basis))
    rng = np.random.default_rng(seed)
    if select == "d-optimal":
        sel = select_d_optimal(a_pool, count, seed)
    else:
        idx = rng.choice(n_candidates, count, replace=False)
        sign, ld = np.linalg.slogdet(information(a_pool[idx]))
        sel = Selection(index=idx, logdet=float(ld) if sign > 0 else -math.inf)
    q_sel = pool_q[sel.index]
    perm = order_poses(q_sel)
    rand = random_cop_error(a_pool, count, c_test, sigma, random_draws, rng)
    return PosePlan(
        q=q_sel[perm],
        cop=level_cop(robot, q_sel[perm]),
        method=select,
        expected_error=expected_cop_error(a_pool[sel.index], c_test, sigma),
        random_error=float(np.median(rand)),
        sigma=sigma,
        rank=basis.shape[1],
        logdet=sel.logdet,
        path_unordered=path_length(q_sel, np.zeros(robot.nq)),
        path_ordered=path_length(q_sel[perm], np.zeros(robot.nq)),
        candidates=cand,
        selection=sel,
        basis=basis,
        a_pool=a_pool,
        c_test=c_test,
    )


@one_blas_thread()
def design_curve(
    a_pool: np.ndarray,
    c_test: np.ndarray,
    ks,
    sigma: float = PAPER_NOISE,
    seed: int = 0,
    draws: int = 50,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, np.ndarray]:
    """Expected CoP error [m] vs K: D-optimal, and random (median, 10th/90th percentile)."""
    ks = np.asarray(ks, dtype=int)
    dopt, med, lo, hi = [], [], [], []
    for n_done, k in enumerate(ks):
        if progress is not None:
            progress(n_done, len(ks))
        sel = select_d_optimal(a_pool, int(k), seed)
        dopt.append(expected_cop_error(a_pool[sel.index], c_test, sigma))
        r = random_cop_error(a_pool, int(k), c_test, sigma, draws, seed)
        med.append(np.median(r))
        lo.append(np.percentile(r, 10))
        hi.append(np.percentile(r, 90))
    if progress is not None:
        progress(len(ks), len(ks))
    return {
        "k": ks,
        "d_optimal": np.array(dopt),
        "random_median": np.array(med),
        "random_p10": np.array(lo),
        "random_p90": np.array(hi),
    }
