"""The whole pose plan: candidates, D-optimal (or random) choice, an optional physics check
that replaces the chosen poses that do not stand, order, expected error."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from sescid.base.threads import one_blas_thread
from sescid.errors import OptionError, SescidError
from sescid.estimation import min_poses, structural_rank
from sescid.planning.candidates import Candidates, candidates
from sescid.planning.com import level_cop
from sescid.planning.compliance import Compliance, compliance
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
from sescid.planning.limits import UNLIMITED_RANGE, sampling_limits, unlimited_joints
from sescid.planning.ordering import order_poses, path_length
from sescid.planning.stability import DEFAULT_CLEARANCE
from sescid.robot import Robot
from sescid.simulation import PAPER_NOISE

#: (k, nq) poses [rad] → (k,) True where the pose stands (a physics bench, ``bench.standing``)
PoseCheck = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class PlanOptions:
    """How ``plan_poses`` samples, checks and scores (SI units, radians)."""

    #: stable, collision-free candidates to choose from; None: ``default_candidates``
    n_candidates: int | None = None
    n_test: int = 2_000  #: further candidates on which the expected error is computed
    sigma: float = PAPER_NOISE  #: m, CoP noise assumed for the expected error
    limits: np.ndarray | None = None  #: (nq, 2) rad; None: ``sampling_limits(robot)``
    half_extents: np.ndarray | None = None  #: (2,) m CoP box; None: ``cop_half_extents``
    clearance: float = DEFAULT_CLEARANCE  #: m, free sole corners above the floor
    random_draws: int = 50  #: random sets drawn for the random-choice error
    rigid: bool = False  #: True: the CoP box only, no compliant-robot margin
    check: PoseCheck | None = None  #: keeps only chosen poses it passes (a physics bench)
    check_name: str = ""  #: what ``check`` is, for the notes
    max_check_rounds: int = 20  #: choose again at most this often after failed checks


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
    #: joints the model leaves unlimited, sampled within ±``unlimited_range``
    unlimited: list[str] = field(default_factory=list)
    unlimited_range: float = UNLIMITED_RANGE  #: rad (the default, or what ``limits`` gave)
    compliance: Compliance | None = None  #: the compliant-stability model (None: rigid)
    n_checked: int = 0  #: poses the physics check ran
    n_check_failed: int = 0  #: of which did not stand (replaced)
    notes: list[str] = field(default_factory=list)


def default_candidates(robot: Robot, select: str, count: int) -> int:
    """The pool a choice draws from by default: D-optimal, 20 000 candidates when the profile asks
    for uniform draws (the OP2), 5 000 for the CoM-Jacobian search (dearer per candidate); random,
    ``count`` (a random subset of random candidates is random)."""
    if select == "random":
        return count
    return 20_000 if robot.profile.pose_sampler == "uniform" else 5_000


def _options(options: PlanOptions | None, overrides: dict) -> PlanOptions:
    """``options`` with keyword overrides (OptionError naming an unknown one)."""
    opt = options or PlanOptions()
    names = {f.name for f in dataclasses.fields(PlanOptions)}
    bad = sorted(set(overrides) - names)
    if bad:
        raise OptionError(bad[0], f"not an option of plan_poses ({', '.join(sorted(names))})")
    return dataclasses.replace(opt, **overrides)


def _choose(a: np.ndarray, count: int, select: str, seed: int, keep: np.ndarray) -> Selection:
    """``count`` of the pool rows where ``keep``: D-optimal, or random (seeded)."""
    idx = np.flatnonzero(keep)
    if len(idx) < count:
        raise SescidError(f"only {len(idx)} candidates left to choose {count} poses from")
    if select == "d-optimal":
        sel = select_d_optimal(a[idx], count, seed)
        return dataclasses.replace(sel, index=idx[sel.index])
    pick = idx[np.random.default_rng(seed).choice(len(idx), count, replace=False)]
    sign, ld = np.linalg.slogdet(information(a[pick]))
    return Selection(index=pick, logdet=float(ld) if sign > 0 else -math.inf)


def _checked(
    a: np.ndarray, q: np.ndarray, count: int, select: str, seed: int, opt: PlanOptions
) -> tuple[Selection, int, int]:
    """(selection, poses checked, failed): choose, run ``opt.check`` on the chosen poses not
    checked yet, drop those that fail from the pool and choose again, until all stand."""
    keep = np.ones(len(a), dtype=bool)
    sel = _choose(a, count, select, seed, keep)
    if opt.check is None:
        return sel, 0, 0
    stands: dict[int, bool] = {}
    for _ in range(opt.max_check_rounds):
        new = [int(i) for i in sel.index if int(i) not in stands]
        if new:
            ok = np.asarray(opt.check(q[new]), dtype=bool)
            stands |= dict(zip(new, ok.tolist(), strict=True))
        bad = [int(i) for i in sel.index if not stands[int(i)]]
        if not bad:
            return sel, len(stands), sum(not v for v in stands.values())
        keep[bad] = False
        sel = _choose(a, count, select, seed, keep)
    raise SescidError(
        f"after {opt.max_check_rounds} rounds some chosen poses still fail the "
        f"{opt.check_name or 'physics'} check ({sum(not v for v in stands.values())} of "
        f"{len(stands)} checked failed): more candidates (--candidates) or a tighter box"
    )


@one_blas_thread()
def plan_poses(
    robot: Robot,
    count: int = 38,
    select: str = "d-optimal",
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
    opt = _options(options, overrides)
    if select not in ("d-optimal", "random"):
        raise SescidError(f"unknown selection '{select}' (d-optimal or random)")
    if opt.n_candidates is None:
        opt = dataclasses.replace(opt, n_candidates=default_candidates(robot, select, count))
    assert opt.n_candidates is not None
    need = min_poses(robot)
    if count < need:
        raise OptionError(
            "count",
            f"{count} poses are too few: {robot.name} has {structural_rank(robot)} identifiable "
            f"combinations, which need at least {need} poses (2 equations each)",
        )
    if count > opt.n_candidates:
        raise SescidError(f"cannot choose {count} poses from {opt.n_candidates} candidates")
    robot.check_support_level()
    model = None if opt.rigid else compliance(robot)
    lim = sampling_limits(robot) if opt.limits is None else np.asarray(opt.limits, dtype=float)
    free = unlimited_joints(robot)
    free_range = float(np.abs(lim[[robot.joint_names.index(j) for j in free]]).max()) if free else 0
    cand = candidates(
        robot,
        opt.n_candidates + opt.n_test,
        seed,
        limits=lim,
        half_extents=opt.half_extents,
        clearance=opt.clearance,
        progress=progress,
        compliance=model,
    )
    n = opt.n_candidates
    pool_q, test_q = cand.q[:n], cand.q[n:]
    basis = identifiable_basis(robot, pool_q)
    a_pool = projected_regressor(robot, pool_q, basis)
    c_test = per_row_information(projected_regressor(robot, test_q, basis))
    sel, n_checked, n_failed = _checked(a_pool, pool_q, count, select, seed, opt)
    q_sel = pool_q[sel.index]
    perm = order_poses(q_sel)
    rng = np.random.default_rng(seed)
    rand = random_cop_error(a_pool, count, c_test, opt.sigma, opt.random_draws, rng)
    return PosePlan(
        q=q_sel[perm],
        cop=level_cop(robot, q_sel[perm]),
        method=select,
        expected_error=expected_cop_error(a_pool[sel.index], c_test, opt.sigma),
        random_error=float(np.median(rand)),
        sigma=opt.sigma,
        rank=basis.shape[1],
        logdet=sel.logdet,
        path_unordered=path_length(q_sel, np.zeros(robot.nq)),
        path_ordered=path_length(q_sel[perm], np.zeros(robot.nq)),
        candidates=cand,
        selection=sel,
        basis=basis,
        a_pool=a_pool,
        c_test=c_test,
        unlimited=free,
        unlimited_range=free_range if free else UNLIMITED_RANGE,
        compliance=model,
        n_checked=n_checked,
        n_check_failed=n_failed,
        notes=_notes(free, free_range, opt, model, (n_checked, n_failed)),
    )


def _notes(
    free: list[str],
    free_range: float,
    opt: PlanOptions,
    model: Compliance | None,
    checked: tuple[int, int],
) -> list[str]:
    """What the plan assumed and checked, one line each."""
    out = []
    if free:
        out.append(
            f"{len(free)} joint(s) without limits sampled within "
            f"±{math.degrees(free_range):.4g}°: {', '.join(free[:6])}"
            + (" …" if len(free) > 6 else "")
        )
    if model is None:
        out.append("stability: the CoP box only (rigid robot)")
    else:
        out.append(f"compliant-robot margin: {model.source}")
    if opt.check is not None:
        out.append(
            f"{opt.check_name or 'physics'} check: {checked[0]} poses simulated, {checked[1]} "
            "did not stand and were replaced"
        )
    return out


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
