"""The pose plan for joint torques (``kinds`` "tau") or torques and the CoP ("both"), standing
on a foot or held in a gantry: candidates, the D-optimal (or random) choice over the rows of
those kinds (``kinds``, ``blocks``), the physics check, order, and the expected error of the
CoM x/y on fresh poses."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from sescid.errors import OptionError, SescidError
from sescid.planning.design import kinds
from sescid.planning.design.blocks import schur_logdet, select_blocks
from sescid.planning.design.doptimal import Selection, per_row_information, projected_regressor
from sescid.planning.feasibility.candidates import Candidates, Mount
from sescid.planning.feasibility.gantry import GantryOptions, gantry_candidates
from sescid.planning.plan_types import (
    PlanOptions,
    PosePlan,
    Select,
    checked_choice,
    plan_notes,
    pose_plan,
    sampling_range,
    standing_candidates,
)
from sescid.robot import Robot


def choose_blocks(
    rows: kinds.BlockRows, count: int, select: Select, seed: int, keep: np.ndarray
) -> Selection:
    """``count`` of the candidates where ``keep``: D-optimal over their rows, or random
    (seeded, as ``plan._choose``)."""
    idx = np.flatnonzero(keep)
    if len(idx) < count:
        raise SescidError(f"only {len(idx)} candidates left to choose {count} poses from")
    if select == "d-optimal":
        sel = select_blocks(rows.take(idx), count, seed)
        return dataclasses.replace(sel, index=idx[sel.index])
    pick = idx[np.random.default_rng(seed).choice(len(idx), count, replace=False)]
    return Selection(index=pick, logdet=schur_logdet(rows, pick))


def _candidates(
    robot: Robot, n: int, seed: int, opt: PlanOptions, mount: Mount, lim: np.ndarray, progress
) -> Candidates:
    """The pool and the test poses: held in a gantry, or standing as for a CoP design."""
    if mount == "gantry":
        if opt.check is not None:
            raise OptionError("check", "the physics check stands the robot on its foot, not held")
        held = GantryOptions(limits=lim, hang_height=opt.hang_height, clearance=opt.clearance)
        return gantry_candidates(robot, n, seed, held, progress=progress)
    if opt.hang_height is not None:
        raise OptionError("hang_height", "a hang height goes with a robot held in a gantry")
    return standing_candidates(robot, n, seed, opt, lim, progress)


def plan_kinds(
    robot: Robot,
    count: int,
    select: Select,
    seed: int,
    opt: PlanOptions,
    mount: Mount,
    progress: Callable[[int, int], None] | None = None,
) -> PosePlan:
    """``plan_poses`` for torque rows (module docstring); ``opt.n_candidates`` is set."""
    spec = kinds.design_kinds(robot, opt.kinds, opt.sigma, opt.tau_noise, opt.tau_joints)
    assert opt.n_candidates is not None
    if count < 2:
        raise OptionError("count", f"{count}: a torque offset needs at least 2 poses")
    if count > opt.n_candidates:
        raise SescidError(f"cannot choose {count} poses from {opt.n_candidates} candidates")
    lim, free, free_range = sampling_range(robot, opt)
    cand = _candidates(robot, opt.n_candidates + opt.n_test, seed, opt, mount, lim, progress)
    n = opt.n_candidates
    pool_q, test_q = cand.q[:n], cand.q[n:]
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
    c_test = per_row_information(projected_regressor(robot, test_q, basis))
    sel, n_checked, n_failed = checked_choice(
        lambda keep: choose_blocks(rows, count, select, seed, keep), pool_q, opt
    )
    rng = np.random.default_rng(seed)
    rand = kinds.random_com_error(rows, count, c_test, opt.random_draws, rng)
    notes = plan_notes(free, free_range, opt, cand.compliance, (n_checked, n_failed),
                       mount == "gantry")  # fmt: skip
    return pose_plan(
        robot,
        (cand, pool_q, sel),
        opt,
        (free, free_range),
        cop=mount == "stand",
        method=select,
        expected_error=kinds.expected_com_error(rows, sel.index, c_test),
        random_error=float(np.median(rand)),
        rank=basis.shape[1],
        basis=basis,
        a_pool=np.zeros((0, 2, basis.shape[1])),
        c_test=c_test,
        n_checked=n_checked,
        n_check_failed=n_failed,
        notes=notes + cand.notes + _kind_notes(spec, mount),
        kinds=spec.kinds,
        quantity="CoM x/y",
        mount=mount,
        rows=rows,
        determined=kinds.determined(rows, sel.index),
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
    if spec.kinds == "tau":
        held = "the held link's" if mount == "gantry" else "the support foot's"
        out.append(
            f"torques do not see {held} own horizontal moments: the expected CoM error is that of "
            "what they determine (a constant CoM shift is the model's)"
        )
    return out


def block_curve(
    rows: kinds.BlockRows,
    c_test: np.ndarray,
    ks,
    seed: int = 0,
    draws: int = 50,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, np.ndarray]:
    """Expected CoM x/y error [m] vs K for a torque design: D-optimal, and random (median,
    10th/90th percentile) — ``design_curve``'s for blocks of rows."""
    ks = np.asarray(ks, dtype=int)
    out: dict[str, list[float]] = {k: [] for k in ("d_optimal", "random_median", "random_p10",
                                                   "random_p90")}  # fmt: skip
    for n_done, k in enumerate(ks):
        if progress is not None:
            progress(n_done, len(ks))
        sel = select_blocks(rows, int(k), seed)
        out["d_optimal"].append(kinds.expected_com_error(rows, sel.index, c_test))
        r = kinds.random_com_error(rows, int(k), c_test, draws, seed)
        out["random_median"].append(float(np.median(r)))
        out["random_p10"].append(float(np.percentile(r, 10)))
        out["random_p90"].append(float(np.percentile(r, 90)))
    if progress is not None:
        progress(len(ks), len(ks))
    return {"k": ks} | {k: np.array(v) for k, v in out.items()}
