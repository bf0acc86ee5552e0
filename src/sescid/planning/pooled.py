"""``plan_poses`` over a set of stances: each stance's own candidates, one D-optimal design over
their union in the body parameters every stance shares, a cost per stance change.

Candidates per stance (``funnel``): standing on a foot, the single-support rules (CoP box,
compliant margin, floor, self-collision); on both feet, ``double``; held, ``gantry`` (no
balance). Each candidate's rows over [θ̃; o] (``stances.StanceRows``) are projected on the
pooled identifiable subspace of θ̃ (the union's information, the torque offsets marginalised:
``estimation``'s rank rule); the design maximises the log-determinant there (``design.engine``;
the offsets are columns of the design).

A stance change costs ``cost`` poses: a plan using m stances chooses K − cost (m − 1) poses. Every
subset of the stances that determines the whole pooled subspace is tried with its pose count
and the subset of largest log det is kept (a stance that adds no direction is used only when
its poses are worth the change). The poses are visited stance by stance, in the order given,
each group ordered from the zero pose (``ordering``).

What pooling gains is reported against the reference stance alone (the one standing on the
reference robot's support, else the first) with all K poses: the rank over θ of each stance
alone and what each adds to the pool, and the expected RMS error of the whole-body CoM (3-D
and x/y) on fresh poses in the reference frame of a MAP fit with the per-body CAD prior at
``PRIOR_TAU`` (``estimation.map``'s "bodies" prior), CoP noise ``sigma``, torque noise
``tau_noise``.
"""

from __future__ import annotations

import itertools
import math
from typing import cast

import numpy as np

from sescid.errors import OptionError, SescidError
from sescid.estimation import DEFAULT_RTOL, identifiable_eigen
from sescid.planning.design import engine
from sescid.planning.design.doptimal import Selection
from sescid.planning.design.kinds import BlockRows, DesignKinds, design_kinds, min_block_poses
from sescid.planning.design.stances import (
    Stance,
    StanceRows,
    stance_robot,
    theta_information,
    theta_scale,
)
from sescid.planning.feasibility.candidates import Candidates
from sescid.planning.feasibility.com import level_cop
from sescid.planning.funnel import checked_choice, sampling_range, stance_candidates, visiting_order
from sescid.planning.plan_types import PlanOptions, StancePlan, StanceReport
from sescid.robot import Robot

#: poses a stance change costs by default (moving the robot to another foot or into a gantry)
DEFAULT_STANCE_COST = 5.0
#: relative prior std of the body parameters for the expected errors (masses ±10 %, CoMs ±5 mm
#: per unit mass: ``estimation.map``'s "bodies" prior)
PRIOR_TAU = 0.1


def _check_kinds(stances: tuple[Stance, ...], spec: DesignKinds) -> None:
    """OptionError for a stance that gives none of the planned kinds' rows."""
    for st in stances:
        if st.mount == "gantry" and not spec.has_tau:
            why = "held in a gantry no foot is loaded: no CoP to plan for (--kinds tau or both)"
        elif st.mount == "double" and not spec.has_cop:
            why = (
                "on both feet the joint torques depend on how the load splits between the "
                "feet: plan the CoP (--kinds cop or both)"
            )
        else:
            continue
        raise OptionError("kinds", f"{st.label}: {why}")


def _choose(x: np.ndarray, count: int, seed: int, keep: np.ndarray) -> Selection:
    """``count`` of the rows x (n, r, p) where ``keep``, D-optimal (offsets are columns of x)."""
    return engine.choose(BlockRows.plain(x), count, "d-optimal", seed, keep)


def _logdet(x: np.ndarray, p: int) -> float:
    """Log det of the information of rows x (K, r, p + J) on its first p columns, the rest
    (offsets) marginalised; −inf when singular."""
    flat = x.reshape(-1, x.shape[2])
    sign, ld = np.linalg.slogdet(theta_information(flat.T @ flat, p))
    return float(ld) if sign > 0 else -math.inf


class _Pool:
    """Every stance's candidates, rows and information."""

    def __init__(self, robot: Robot, stances, spec, opt, seed, progress):
        self.robot, self.stances, self.spec = robot, stances, spec
        lim = sampling_range(robot, opt)[0]
        n = opt.n_candidates
        mass = robot.total_mass
        self.rows = [StanceRows(robot, st, spec, mass) for st in stances]
        self.n_theta = self.rows[0].e.shape[1]
        self.cand: list[Candidates] = []
        total = n * len(stances) + opt.n_test
        for k, st in enumerate(stances):
            extra = opt.n_test if k == 0 else 0

            def part(done, _n, k=k):
                if progress is not None:
                    progress(k * n + done, total)

            rng = np.random.default_rng([seed, k])
            rb = stance_robot(robot, st)
            self.cand.append(stance_candidates(rb, st.mount, n + extra, rng, opt, lim, part))
        self.test_q = self.cand[0].q[n:]
        self.q = [c.q[:n] for c in self.cand]
        self.info = [r.information(q) for r, q in zip(self.rows, self.q, strict=True)]
        self.basis = identifiable_eigen(
            theta_information(cast(np.ndarray, sum(self.info)), self.n_theta), DEFAULT_RTOL
        )[1]
        self.x = [r.projected(q, self.basis) for r, q in zip(self.rows, self.q, strict=True)]
        self.x_all = np.concatenate(self.x)
        self.owner = np.concatenate([np.full(len(q), k) for k, q in enumerate(self.q)])
        self.local = np.concatenate([np.arange(len(q)) for q in self.q])

    def rank(self, subset) -> int:
        info = cast(np.ndarray, sum(self.info[k] for k in subset))
        return identifiable_eigen(theta_information(info, self.n_theta), DEFAULT_RTOL)[1].shape[1]

    def full_rows(self, idx: np.ndarray) -> np.ndarray:
        """(K, r, 4N + J) the rows of the union's candidates ``idx``."""
        parts = []
        for k, rows in enumerate(self.rows):
            mine = idx[self.owner[idx] == k]
            if len(mine):
                parts.append(
                    np.concatenate([x for _, x in rows.blocks(self.q[k][self.local[mine]])])
                )
        return np.concatenate(parts)


def expected_com_errors(pool: _Pool, rows: np.ndarray) -> tuple[float, float]:
    """(3-D, x/y) expected RMS CoM errors [m] on the test poses of a MAP fit of ``rows``."""
    robot = pool.robot
    e = robot.sesc_matrix(robot) * theta_scale(robot)[None, :] / robot.total_mass
    phi = robot.regressor(pool.test_q, (0, 1, 2)) @ e  # (n, 3, 4N)
    flat = rows.reshape(-1, rows.shape[2])
    f = theta_information(flat.T @ flat, pool.n_theta)
    cov = np.linalg.inv(f + np.eye(pool.n_theta) / PRIOR_TAU**2)
    g3 = np.einsum("nri,nrj->ij", phi, phi) / len(phi)
    g2 = np.einsum("nri,nrj->ij", phi[:, :2], phi[:, :2]) / len(phi)
    return math.sqrt(max(float(np.sum(cov * g3)), 0.0)), math.sqrt(
        max(float(np.sum(cov * g2)), 0.0)
    )


def plan_pooled(
    robot: Robot,
    stances: tuple[Stance, ...],
    count: int,
    seed: int,
    opt: PlanOptions,
    cost: float,
    progress=None,
) -> StancePlan:
    """``plan_poses`` over several ``stances`` (module docstring); ``robot`` is the reference
    (its support the frame results are reported in); ``opt.n_candidates`` (set): per stance;
    ``opt.half_extents``: every standing stance's CoP box (None: each its own); ``opt.check``
    gives each stance's physics check."""
    assert opt.n_candidates is not None
    if count > opt.n_candidates:
        raise OptionError("count", f"must not exceed --candidates ({opt.n_candidates})")
    if not (math.isfinite(cost) and cost >= 0):
        raise OptionError("stance_cost", f"must be a number of poses ≥ 0, got {cost}")
    spec = design_kinds(robot, opt.kinds, opt.sigma, opt.tau_noise, opt.tau_joints)
    _check_kinds(stances, spec)
    pool = _Pool(robot, stances, spec, opt, seed, progress)
    p, full = pool.basis.shape[1], len(stances)
    subsets, best = [], None
    for size in range(1, full + 1):
        for sub in itertools.combinations(range(full), size):
            k = int(math.floor(count - cost * (size - 1)))
            need = min_block_poses(spec.rows, p, spec.n_nuisance)
            if k < need or pool.rank(sub) < p:
                continue
            keep = np.isin(pool.owner, sub)
            sel = _choose(pool.x_all, k, seed, keep)
            ld = _logdet(pool.x_all[sel.index], p)
            subsets.append((tuple(stances[s].label for s in sub), k, ld))
            if best is None or ld > best[2] + 1e-9:
                best = (sub, k, ld, sel)
    if best is None:
        raise SescidError(
            f"{count} poses are too few for these stances: together they determine {p} "
            f"directions of the body parameters, which need at least "
            f"{min_block_poses(spec.rows, p, spec.n_nuisance)} poses, and each stance change "
            f"costs {cost:g} poses"
        )
    sub, k, _, sel = best
    check = opt.check
    checks = {s: (check(stances[s], stance_robot(robot, stances[s])) if check else None)
              for s in sub}  # fmt: skip
    n_checked = n_failed = 0
    if any(c is not None for c in checks.values()):
        q_all = np.concatenate(pool.q)

        def by_index(idx: np.ndarray) -> np.ndarray:
            ok = np.ones(len(idx), dtype=bool)
            for s, chk in checks.items():
                mine = pool.owner[idx] == s
                if chk is not None and mine.any():
                    ok[mine] = chk(q_all[idx[mine]])
            return ok

        keep0 = np.isin(pool.owner, sub)
        sel, n_checked, n_failed = checked_choice(
            lambda keep: _choose(pool.x_all, k, seed, keep & keep0), len(q_all), by_index, opt
        )
    return _result(pool, sel, (sub, k, cost, seed), subsets, (n_checked, n_failed))


def _result(pool: _Pool, sel: Selection, chosen, subsets, checked) -> StancePlan:
    """The plan of the chosen poses ``sel`` (``chosen``: the stances' subset, its pose count,
    the cost per change, the seed) with its comparison against the reference stance alone."""
    sub, k, cost, seed = chosen
    robot, stances = pool.robot, pool.stances
    p = pool.basis.shape[1]
    qs, labels, cops, path = [], [], [], 0.0
    for s, st in enumerate(stances):
        mine = sel.index[pool.owner[sel.index] == s]
        if not len(mine):
            continue
        q_ord, _, length = visiting_order(pool.q[s][pool.local[mine]])
        path += length
        qs.append(q_ord)
        labels += [st.label] * len(q_ord)
        cops.append(level_cop(stance_robot(robot, st), q_ord) if st.mount != "gantry"
                    else np.full((len(q_ord), 2), np.nan))  # fmt: skip
    ref = next((s for s, st in enumerate(stances) if st.mount == "stand"
                and st.support == robot.support), 0)  # fmt: skip
    count = int(math.floor(k + cost * (len(sub) - 1)))
    own = identifiable_eigen(theta_information(pool.info[ref], pool.n_theta), DEFAULT_RTOL)[1]
    x_ref = pool.rows[ref].projected(pool.q[ref], own)
    sel_ref = _choose(x_ref, min(count, len(x_ref)), seed, np.ones(len(x_ref), bool))
    ref_rows = np.concatenate([x for _, x in pool.rows[ref].blocks(pool.q[ref][sel_ref.index])])
    com, com_xy = expected_com_errors(pool, pool.full_rows(sel.index))
    ref_com, ref_xy = expected_com_errors(pool, ref_rows)
    reports = []
    for s, st in enumerate(stances):
        others = [t for t in range(len(stances)) if t != s]
        without = pool.rank(others) if others else 0
        reports.append(StanceReport(st, int(np.sum(pool.owner[sel.index] == s)),
                                    pool.rank([s]), p - without, pool.cand[s]))  # fmt: skip
    used = [stances[s].label for s in sub]
    notes = [
        f"body parameters θ: {pool.n_theta} (mass and first moment of {pool.n_theta // 4} "
        f"bodies); the stances together determine {p} directions",
        f"a stance change costs {cost:g} poses: {len(used)} stance(s) used ({', '.join(used)}), "
        f"{k} poses",
        f"expected errors: MAP with the per-body CAD prior (masses ±{PRIOR_TAU:.0%}, CoMs "
        f"±{PRIOR_TAU * 50:g} mm) on {len(pool.test_q)} fresh poses of {stances[0].label}, "
        f"reference frame {robot.support}",
    ]
    return StancePlan(
        q=np.concatenate(qs),
        stance=np.array(labels),
        cop=np.concatenate(cops),
        stances=stances,
        reports=reports,
        reference=stances[ref],
        kinds=pool.spec.kinds,
        rank=p,
        n_theta=pool.n_theta,
        cost=cost,
        changes=len(qs) - 1,
        logdet=_logdet(pool.x_all[sel.index], p),
        expected_com=com,
        expected_com_xy=com_xy,
        reference_com=ref_com,
        reference_com_xy=ref_xy,
        path_length=path,
        subsets=subsets,
        selection=sel,
        test_q=pool.test_q,
        notes=notes,
        n_checked=checked[0],
        n_check_failed=checked[1],
    )
