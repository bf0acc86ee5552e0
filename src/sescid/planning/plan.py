"""The whole pose plan: candidates, D-optimal (or random) choice, an optional physics check
that replaces the chosen poses that do not stand, order, expected error."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from sescid.base.threads import one_blas_thread
from sescid.errors import OptionError, SescidError, check_choice
from sescid.estimation import min_poses, structural_rank
from sescid.kinematics import load_kernels
from sescid.planning.design import doptimal
from sescid.planning.feasibility.gantry import resolve_mount
from sescid.planning.plan_types import (
    PlanOptions,
    PosePlan,
    Select,
    checked_choice,
    default_candidates,
    options_with,
    plan_notes,
    pose_plan,
    sampling_range,
    standing_candidates,
)
from sescid.robot import Robot
from sescid.simulation import PAPER_NOISE


def _choose(
    a: np.ndarray, count: int, select: Select, seed: int, keep: np.ndarray
) -> doptimal.Selection:
    """``count`` of the pool rows where ``keep``: D-optimal, or random (seeded)."""
    idx = np.flatnonzero(keep)
    if len(idx) < count:
        raise SescidError(f"only {len(idx)} candidates left to choose {count} poses from")
    if select == "d-optimal":
        sel = doptimal.select_d_optimal(a[idx], count, seed)
        return dataclasses.replace(sel, index=idx[sel.index])
    pick = idx[np.random.default_rng(seed).choice(len(idx), count, replace=False)]
    sign, ld = np.linalg.slogdet(doptimal.information(a[pick]))
    return doptimal.Selection(index=pick, logdet=float(ld) if sign > 0 else -math.inf)


@one_blas_thread()
def plan_poses(
    robot: Robot,
    count: int = 38,
    select: Select = "d-optimal",
    seed: int = 0,
    options: PlanOptions | None = None,
    *,
    progress: Callable[[int, int], None] | None = None,
    **overrides,
) -> PosePlan:
    """Sample candidates, choose ``count`` poses (``select`` = "d-optimal" | "random"), order them.

    ``options`` (``PlanOptions``; keyword arguments override its fields): sampling, stability
    (the CoP box and, unless ``rigid``, the compliant-robot margin of ``compliance``), the
    physics ``check``. The expected error is computed on ``n_test`` further candidates.
    ModelError when the support frame is not level (``Robot.check_support_level``).
    """
    opt = options_with(options, overrides)
    check_choice("select", select, Select)
    load_kernels()  # the plan runs compiled kernels anyway: its small kinematics jobs too
    if opt.n_candidates is None:
        n_cand = default_candidates(robot, select, count, opt.kinds)
        opt = dataclasses.replace(opt, n_candidates=n_cand)
    assert opt.n_candidates is not None
    mount = resolve_mount(robot, opt.mount, opt.kinds)
    if opt.kinds != "cop" or mount == "gantry":
        from sescid.planning.plan_kinds import plan_kinds

        return plan_kinds(robot, count, select, seed, opt, mount, progress)
    need = min_poses(robot)
    if count < need:
        raise OptionError(
            "count",
            f"{count} poses are too few: {robot.name} has {structural_rank(robot)} identifiable "
            f"combinations, which need at least {need} poses (2 equations each)",
        )
    if count > opt.n_candidates:
        raise SescidError(f"cannot choose {count} poses from {opt.n_candidates} candidates")
    lim, free, free_range = sampling_range(robot, opt)
    cand = standing_candidates(
        robot, opt.n_candidates + opt.n_test, seed, opt, lim, progress, mount == "double"
    )
    model = cand.compliance
    n = opt.n_candidates
    pool_q, test_q = cand.q[:n], cand.q[n:]
    basis = doptimal.identifiable_basis(robot, pool_q)
    a_pool = doptimal.projected_regressor(robot, pool_q, basis)
    c_test = doptimal.per_row_information(doptimal.projected_regressor(robot, test_q, basis))
    sel, n_checked, n_failed = checked_choice(
        lambda keep: _choose(a_pool, count, select, seed, keep), pool_q, opt
    )
    rng = np.random.default_rng(seed)
    rand = doptimal.random_cop_error(a_pool, count, c_test, opt.sigma, opt.random_draws, rng)
    return pose_plan(
        robot,
        (cand, pool_q, sel),
        opt,
        (free, free_range),
        method=select,
        expected_error=doptimal.expected_cop_error(a_pool[sel.index], c_test, opt.sigma),
        random_error=float(np.median(rand)),
        rank=basis.shape[1],
        basis=basis,
        a_pool=a_pool,
        c_test=c_test,
        n_checked=n_checked,
        n_check_failed=n_failed,
        notes=plan_notes(free, free_range, opt, model, (n_checked, n_failed)) + cand.notes,
        mount=mount,
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
        sel = doptimal.select_d_optimal(a_pool, int(k), seed)
        dopt.append(doptimal.expected_cop_error(a_pool[sel.index], c_test, sigma))
        r = doptimal.random_cop_error(a_pool, int(k), c_test, sigma, draws, seed)
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
