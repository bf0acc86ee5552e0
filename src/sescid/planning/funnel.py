"""The one candidate funnel of every pose plan: the sampling range, a stance's candidates
(standing on a foot, on both feet, held in a gantry), the physics check's choose-again loop and
the visiting order."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sescid.base.text import listed
from sescid.errors import ModelError, SescidError
from sescid.planning.design.doptimal import Selection
from sescid.planning.feasibility.candidates import CandidateOptions, Candidates, candidates
from sescid.planning.feasibility.compliance import compliance
from sescid.planning.feasibility.double import double_candidates
from sescid.planning.feasibility.gantry import GantryOptions, gantry_candidates
from sescid.planning.feasibility.limits import sampling_limits, unlimited_joints
from sescid.planning.ordering import order_poses, path_length
from sescid.planning.plan_types import PlanOptions
from sescid.robot import Robot
from sescid.stance import Mount


def sampling_range(robot: Robot, opt: PlanOptions) -> tuple[np.ndarray, list[str], float]:
    """The joint ranges (nq, 2) [rad] candidates are drawn in (``opt.limits`` or the robot's),
    the joints the model leaves unlimited, and the widest range given to them (rad; 0: none)."""
    lim = sampling_limits(robot) if opt.limits is None else np.asarray(opt.limits, dtype=float)
    free = unlimited_joints(robot)
    free_range = float(np.abs(lim[[robot.joint_names.index(j) for j in free]]).max()) if free else 0
    return lim, free, free_range


def stance_candidates(
    robot: Robot,
    mount: Mount,
    n: int,
    seed: int | np.random.Generator,
    opt: PlanOptions,
    lim: np.ndarray,
    progress,
) -> Candidates:
    """``n`` candidates of ``robot`` (rooted at the stance's frame) held as ``mount``: in a
    gantry (joint limits, floor, self-collision: ``gantry``), else standing on its support foot
    (``double``: on both feet) with a level support checked, the compliant-robot margin unless
    ``opt.rigid``, the floor and self-collision. ModelError when mesh files the model names
    are missing, unless ``opt.allow_missing_meshes`` (``check_meshes``)."""
    check_meshes(robot, opt)
    if mount == "gantry":
        held = GantryOptions(limits=lim, hang_height=opt.hang_height, clearance=opt.clearance)
        return gantry_candidates(robot, n, seed, held, progress=progress)
    robot.check_support_level()
    model = None if opt.rigid else compliance(robot)
    draw = CandidateOptions(
        limits=lim, half_extents=opt.half_extents, clearance=opt.clearance, compliance=model
    )
    if mount == "double":
        return double_candidates(robot, n, seed, draw, progress=progress)
    return candidates(robot, n, seed, draw, progress=progress)


def check_meshes(robot: Robot, opt: PlanOptions) -> None:
    """ModelError when mesh files the model names were not found or could not be read (the
    floor and self-collision checks would see those bodies by their origins only: a pose
    through the floor or through itself would pass), unless ``opt.allow_missing_meshes``."""
    missing = robot.unloaded_meshes
    if missing and not opt.allow_missing_meshes:
        how = (
            "add the folder holding each package to ROS_PACKAGE_PATH"
            if any(m.in_package and not m.found for m in missing)
            else "keep the model file where its mesh paths point"
        )
        files = listed(f"{m.link} ({m.mesh.rsplit('/', 1)[-1]})" for m in missing)
        raise ModelError(
            f"{robot.model_path}: {len(missing)} mesh file(s) it names are not found or cannot "
            f"be read ({files}): the floor and self-collision checks would not see those "
            f"shapes; {how}, or plan without them (--allow-missing-meshes)"
        )


def checked_choice(
    choose: Callable[[np.ndarray], Selection],
    n: int,
    check: Callable[[np.ndarray], np.ndarray] | None,
    opt: PlanOptions,
) -> tuple[Selection, int, int]:
    """(selection, poses checked, failed): ``choose(keep)`` among the ``n`` pool candidates
    where ``keep``, run ``check`` (pool indices → True where the pose stands) on the chosen
    ones not checked yet, drop those that fail from the pool and choose again, until all
    stand."""
    keep = np.ones(n, dtype=bool)
    sel = choose(keep)
    if check is None:
        return sel, 0, 0
    stands: dict[int, bool] = {}
    for _ in range(opt.max_check_rounds):
        new = [int(i) for i in sel.index if int(i) not in stands]
        if new:
            ok = np.asarray(check(np.asarray(new, dtype=np.int64)), dtype=bool)
            stands |= dict(zip(new, ok.tolist(), strict=True))
        bad = [int(i) for i in sel.index if not stands[int(i)]]
        if not bad:
            return sel, len(stands), sum(not v for v in stands.values())
        keep[bad] = False
        sel = choose(keep)
    raise SescidError(
        f"after {opt.max_check_rounds} rounds some chosen poses still fail the "
        f"{opt.check_name or 'physics'} check ({sum(not v for v in stands.values())} of "
        f"{len(stands)} checked failed): more candidates (--candidates) or a tighter box"
    )


def visiting_order(q_sel: np.ndarray) -> tuple[np.ndarray, float, float]:
    """The chosen poses (k, nq) in visiting order (``ordering.order_poses``), and the length of
    the joint-space path from the zero pose through them before and after ordering (rad)."""
    q_ord = q_sel[order_poses(q_sel)]
    zero = np.zeros(q_sel.shape[1])
    return q_ord, path_length(q_sel, zero), path_length(q_ord, zero)
