"""The one pose planner: ``plan_poses`` over one stance or several, through one candidate funnel
(``funnel``) and one D-optimal engine (``design.engine``).

One stance (the robot's support, or a one-element ``stances``): candidates, the D-optimal (or
random) choice over the rows of the planned kinds (the CoP's two; joint torques with an offset
per joint, alone or with the CoP: ``design.kinds``), the physics check that replaces chosen
poses that do not stand, order, and the expected error of least squares on fresh poses: of the
CoP for a CoP design, else of the CoM x/y (``PosePlan``). Several stances: one design over the
body parameters they share (``pooled``, ``StancePlan``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np

from sescid.base.threads import one_blas_thread
from sescid.errors import OptionError, check_choice
from sescid.estimation import min_poses, structural_rank
from sescid.kinds import COP, TORQUE, Kinds, parse_kinds
from sescid.kinematics import load_kernels
from sescid.planning.design import engine, kinds
from sescid.planning.design.doptimal import (
    identifiable_basis,
    per_row_information,
    projected_regressor,
)
from sescid.planning.design.stances import stance_robot
from sescid.planning.feasibility.com import level_cop
from sescid.planning.feasibility.gantry import resolve_mount
from sescid.planning.feasibility.limits import UNLIMITED_RANGE
from sescid.planning.funnel import checked_choice, sampling_range, stance_candidates, visiting_order
from sescid.planning.plan_types import (
    PlanOptions,
    PosePlan,
    Select,
    StancePlan,
    default_candidates,
    options_with,
    plan_notes,
)
from sescid.planning.pooled import DEFAULT_STANCE_COST, plan_pooled
from sescid.robot import Robot
from sescid.stance import Mount, Stance, parse_stances


@one_blas_thread()
def plan_poses(
    robot: Robot,
    count: int = 38,
    select: Select = "d-optimal",
    seed: int = 0,
    options: PlanOptions | None = None,
    *,
    stances: str | Sequence[Stance] | None = None,
    cost: float = DEFAULT_STANCE_COST,
    progress: Callable[[int, int], None] | None = None,
    **overrides,
) -> PosePlan | StancePlan:
    """Sample candidates, choose ``count`` poses (``select`` = "d-optimal" | "random"), order them.

    ``options`` (``PlanOptions``; keyword arguments override its fields): the kinds planned
    for (``kinds``: "cop", "tau", "both", "cop,tau" or a tuple of kinds, read by
    ``sescid.kinds.parse_kinds``; the plan's ``kinds`` is the tuple), sampling, stability (the
    CoP box and, unless ``rigid``, the compliant-robot margin of ``compliance``), the physics
    ``check``. ``stances`` (``parse_stances``' text, or stances):
    one, the robot rooted there (as ``support`` and ``mount``); several, one D-optimal design
    over them, a stance change costing ``cost`` poses (``StancePlan``; ``n_candidates`` per
    stance). The expected error is computed on ``n_test`` further candidates. ModelError when a
    standing support frame is not level (``Robot.check_support_level``).
    """
    opt = options_with(options, overrides)
    check_choice("select", select, Select)
    planned = parse_kinds(opt.kinds)
    if isinstance(stances, str):
        stances = parse_stances(stances, robot)
    stances = tuple(stances or ())
    if stances and opt.mount is not None:
        raise OptionError("mount", "--stances names each stance's mount (gantry:<link>, double)")
    if len(stances) == 1:
        robot, opt = (
            stance_robot(robot, stances[0]),
            dataclasses.replace(opt, mount=stances[0].mount),
        )
    if opt.n_candidates is None:  # several stances share the pool
        n = default_candidates(robot, select, count, planned) // max(len(stances), 1)
        opt = dataclasses.replace(opt, n_candidates=n)
    load_kernels()  # the plan runs compiled kernels anyway: its small kinematics jobs too
    if len(stances) > 1:
        if select != "d-optimal":
            raise OptionError("stances", "several stances are planned D-optimally")
        return plan_pooled(robot, stances, count, seed, opt, cost, progress)
    return _one_stance(robot, count, select, seed, opt, planned, progress)


def _one_stance(robot: Robot, count: int, select: Select, seed: int, opt: PlanOptions,
                planned: Kinds, progress):  # fmt: skip
    """``plan_poses`` in the robot's own stance (module docstring) for the ``planned`` kinds
    (``opt.kinds`` parsed); ``opt.n_candidates`` set."""
    assert opt.n_candidates is not None
    n = opt.n_candidates
    mount = resolve_mount(robot, opt.mount, planned)
    spec = kinds.design_kinds(robot, planned, opt.sigma, opt.tau_noise, opt.tau_joints)
    cop = spec.kinds == (COP,)
    if cop and count < min_poses(robot):
        raise OptionError(
            "count",
            f"{count} poses are too few: {robot.name} has {structural_rank(robot)} identifiable "
            f"combinations, which need at least {min_poses(robot)} poses (2 equations each)",
        )
    if not cop and count < 2:
        raise OptionError("count", f"{count}: a torque offset needs at least 2 poses")
    if count > n:
        raise OptionError("count", f"must not exceed --candidates ({n})")
    if mount == "gantry" and opt.check is not None:
        raise OptionError("check", "the physics check stands the robot on its foot, not held")
    if mount != "gantry" and opt.hang_height is not None:
        raise OptionError("hang_height", "a hang height goes with a robot held in a gantry")
    stance_check = None if opt.check is None else opt.check(Stance(robot.support, mount), robot)
    lim, free, free_range = sampling_range(robot, opt)
    cand = stance_candidates(robot, mount, n + opt.n_test, seed, opt, lim, progress)
    pool_q, test_q = cand.q[:n], cand.q[n:]
    if cop:
        basis = identifiable_basis(robot, pool_q)
        rows = kinds.BlockRows.plain(projected_regressor(robot, pool_q, basis))
        need = min_poses(robot)
    else:
        torques = kinds.TorqueRows(robot, pool_q, spec) if spec.has_tau else None
        basis = kinds.kind_basis(robot, pool_q, spec, torques=torques)
        need = kinds.min_block_poses(spec.rows, basis.shape[1], spec.n_nuisance)
        if count < need:
            raise OptionError(
                "count",
                f"{count} poses are too few: {spec.rows} rows per pose must determine the "
                f"{basis.shape[1]} combinations these kinds see and {spec.n_nuisance} sensor "
                f"offsets: at least {need} poses",
            )
        rows = kinds.block_rows(robot, pool_q, spec, basis, torques)
        del torques
    scale = opt.sigma if cop else 1.0
    c_test = per_row_information(projected_regressor(robot, test_q, basis))
    sel, n_checked, n_failed = checked_choice(
        lambda keep: engine.choose(rows, count, select, seed, keep),
        n,
        None if stance_check is None else (lambda idx: stance_check(pool_q[idx])),
        opt,
    )
    rand = engine.random_errors(rows, count, c_test, opt.random_draws,
                                np.random.default_rng(seed), scale)  # fmt: skip
    checked = None if stance_check is None else (n_checked, n_failed)
    notes = plan_notes(free, free_range, opt, cand.compliance, checked, mount == "gantry")
    q_ord, path_unordered, path_ordered = visiting_order(pool_q[sel.index])
    return PosePlan(
        q=q_ord,
        cop=np.full((len(q_ord), 2), np.nan) if mount == "gantry" else level_cop(robot, q_ord),
        kinds=spec.kinds,
        rank=basis.shape[1],
        logdet=sel.logdet,
        selection=sel,
        notes=notes + cand.notes + ([] if cop else _kind_notes(spec, mount)),
        n_checked=n_checked,
        n_check_failed=n_failed,
        method=select,
        expected_error=engine.expected_error(rows, sel.index, c_test, scale),
        random_error=float(np.median(rand)),
        sigma=opt.sigma,
        path_unordered=path_unordered,
        path_ordered=path_ordered,
        candidates=cand,
        basis=basis,
        c_test=c_test,
        unlimited=free,
        unlimited_range=free_range if free else UNLIMITED_RANGE,
        compliance=cand.compliance,
        quantity="CoP" if cop else "CoM x/y",
        mount=mount,
        rows=rows,
        min_count=need,
        determined=None if cop else kinds.determined(rows, sel.index),
    )


def _kind_notes(spec: kinds.DesignKinds, mount: Mount) -> list[str]:
    """What the torque design assumed, one line each."""
    joints = spec.tau_joints
    out = [
        f"torque rows: {len(joints)} joint(s) ({', '.join(joints[:4])}"
        + (" …" if len(joints) > 4 else "")
        + f"), noise {spec.tau_noise:g} N·m per pose, an unknown offset per joint"
        + (f"; CoP noise {spec.cop_noise * 1e3:g} mm" if spec.has_cop else "")
    ]
    if spec.kinds == (TORQUE,):
        held = "the held link's" if mount == "gantry" else "the support foot's"
        out.append(
            f"torques do not see {held} own horizontal moments: the expected CoM error is that of "
            "what they determine (a constant CoM shift is the model's)"
        )
    return out


def design_curve(
    plan: PosePlan,
    ks=None,
    seed: int = 0,
    draws: int = 50,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, np.ndarray]:
    """The plan's expected error (``PosePlan.quantity``) vs K for D-optimal and random choices
    from its pool (``engine.error_curve``), at the pose counts ``ks`` (None: from its fewest
    poses to its count)."""
    if ks is None:
        count, pool = len(plan.q), plan.rows.x.shape[0]
        ks = [plan.min_count, 25, 30, 38, 50, 70, 100, 150, 200, count]
        ks = sorted({k for k in ks if plan.min_count <= k <= min(pool, max(200, count))})
    return engine.error_curve(plan.rows, plan.c_test, ks, seed, draws, plan.error_scale, progress)
