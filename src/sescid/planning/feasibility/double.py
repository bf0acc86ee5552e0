"""Candidate poses on both feet (double support): the free foot's sole flat on the floor at a
reachable placement, the whole robot's CoP inside the support of both feet, clear of the floor
and of itself.

Per draw: the joints within the sampling limits (the loop's joints, both legs, at half their
drawn angles: toward the zero pose, where the feet stand side by side), a placement of the free
sole on the floor within ``PLACE_SHARE`` of its length and width and ±``PLACE_YAW`` of its
zero-pose placement, then the loop closed by inverse kinematics (``closure``: the free sole frame
on the floor plane, z up, at the placement, to ``closure.CLOSE_TOL``). A closed pose is kept when

1. the loop's joints stay within the limits;
2. it is stable: the whole robot's CoP (the CoM's projection, in the reference foot's frame)
   lies strictly inside the convex hull of both feet's CoP boxes (each foot's box: the
   stability box of ``CandidateOptions.half_extents`` around its sole's centre, turned with the
   foot) and, on a compliant robot (``CandidateOptions.compliance``), its dynamic CoP (servo
   sag, the soles' tilt on the contacts of both feet, the load's overshoot: ``compliance``)
   inside the hull of both feet's contacts by the backlash term along each edge's normal and
   ``compliance.EDGE_MARGIN``;
3. every body but the two feet clears the floor (as on one foot, ``ground``), and the bodies
   beyond the free foot (toes) do not reach below it;
4. no two collision capsules touch (``collision``; the feet against each other too); pairs that
   closing the loop cannot move apart (both hanging from one body of the loop: head and arms
   on the trunk) are checked on the draws first (``rigid_pairs``).

The draws are uniform within the limits when the profile asks for them (the OP2), handing over
to draws near accepted poses (``adjust.draw``) when fewer than ``DOUBLE_SWITCH_RATE`` are kept; else
(a humanoid whose uniform draws almost never clear themselves) draws near the zero pose and
near accepted ones from the start. The candidates' ``cop`` is the CoM's projection, the CoP of
the whole robot on both feet: the same rows as on one foot, in the reference foot's frame.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from sescid.errors import SescidError
from sescid.planning.feasibility.adjust import draw
from sescid.planning.feasibility.broadphase import collision_free_mask_broad, collision_free_poses
from sescid.planning.feasibility.candidates import (
    CandidateOptions,
    Candidates,
    Sampling,
    first_empty,
)
from sescid.planning.feasibility.closure import (
    Loop,
    close_chain,
    free_sole_frame,
    loop_of,
    placements,
)
from sescid.planning.feasibility.collision import Capsules, collision_capsules
from sescid.planning.feasibility.com import com_state, level_cop
from sescid.planning.feasibility.compliance import (
    BACKLASH_SIGMAS,
    EDGE_MARGIN,
    Compliance,
    dynamic_cop,
    sensor_pads,
)
from sescid.planning.feasibility.ground import beyond_free_foot, clear_above, ground_checks
from sescid.planning.feasibility.limits import sampling_limits
from sescid.robot import Robot

#: the free sole's placement: within this share of its length (x) and width (y) of the zero
#: pose's placement ...
PLACE_SHARE = (0.5, 0.5)
#: ... and turned within ± this about the vertical
PLACE_YAW = math.radians(15.0)
START_SHARE = 0.5  #: the loop's joints start at this share of their drawn angles
DOUBLE_SWITCH_AFTER = 20_000  #: uniform draws before the draws near accepted poses may take over
DOUBLE_SWITCH_RATE = 0.02  #: accepted share of uniform draws below which they do
DOUBLE_GIVE_UP = 200_000  #: draws without one accepted pose
_CHUNK = 20_000  #: draws per batch at most


def free_contacts(robot: Robot, loop: Loop) -> np.ndarray:
    """(k, 2) the free foot's contacts in its sole frame (x, y, m): its pads in the profile's
    sensor layout, else its sole's corners."""
    pads = sensor_pads(robot, loop.free)
    if pads is not None and robot.model.link_frames[loop.free][0] == loop.body:
        x = robot.model.link_frames[loop.free][1]
        p3 = np.concatenate([pads, np.zeros((len(pads), 1))], axis=1)
        pts = p3 @ x[:3, :3].T + x[:3, 3]  # body frame
    else:
        sole = robot.free_sole
        assert sole is not None
        pts = sole.corners
    return ((pts - loop.centre) @ loop.rot)[:, :2]


def place_points(points: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(n, k, 2) sole-frame points (k, 2) [m] at the placements ``target`` (n, 4)."""
    c, s = target[:, 2:3], target[:, 3:4]
    x = target[:, 0:1] + c * points[None, :, 0] - s * points[None, :, 1]
    y = target[:, 1:2] + s * points[None, :, 0] + c * points[None, :, 1]
    return np.stack([x, y], axis=2)


def hull_edges(points: np.ndarray, tol: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """(normals (n, E, 2), offsets (n, E)): the edges of the convex hull of ``points`` (n, k, 2)
    [m] as outward unit normals u and offsets u·p_i, so a point x lies inside by
    min_E (offset − u·x); E = k (k − 1) point pairs, those that are no edge with offset +inf."""
    n, k, _ = points.shape
    i, j = np.nonzero(~np.eye(k, dtype=bool))
    e = points[:, j] - points[:, i]  # (n, E, 2)
    length = np.hypot(e[..., 0], e[..., 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.stack([e[..., 1], -e[..., 0]], axis=2) / length[..., None]
    off = np.einsum("nea,nea->ne", u, points[:, i])
    side = np.einsum("nea,nka->nek", u, points) - off[..., None]  # ≤ 0 for every point: an edge
    edge = (length > tol) & np.all(side <= tol, axis=2)
    u = np.where(edge[..., None], u, 0.0)
    return u, np.where(edge, off, np.inf)


def hull_margin(points: np.ndarray, x: np.ndarray, shrink=None) -> np.ndarray:
    """(n,) how far [m] ``x`` (n, 2) lies inside the convex hull of ``points`` (n, k, 2)
    (negative: outside), each edge moved in by ``shrink(u)`` (n, E) for its normals u."""
    u, off = hull_edges(points)
    d = off - np.einsum("nea,na->ne", u, x)
    if shrink is not None:
        d = d - shrink(u)
    return d.min(axis=1)


def double_margin(model: Compliance, st, contacts: np.ndarray) -> np.ndarray:
    """(n,) the compliant margin [m] of poses on both feet: the dynamic CoP (``compliance``'s
    sag, tilt on the contacts (n, k, 2) [m] of both feet, overshoot) inside their convex hull
    less ``BACKLASH_SIGMAS`` standard deviations of the backlash's CoM shift along each edge's
    normal and ``EDGE_MARGIN``; −inf where the pose has no stable equilibrium on them."""
    jac = st.jac
    e_dyn = dynamic_cop(model, st, contacts)
    sigma = BACKLASH_SIGMAS * model.backlash / math.sqrt(3)

    def shrink(u: np.ndarray) -> np.ndarray:  # (n, E, 2) normals → (n, E) m
        along = u[..., 0:1] * jac[:, None, 0, :] + u[..., 1:2] * jac[:, None, 1, :]
        return sigma * np.sqrt(np.sum(along * along, axis=2)) + EDGE_MARGIN

    out = hull_margin(contacts, e_dyn, shrink)
    return np.where(np.isfinite(out), out, -np.inf)


def rigid_pairs(robot: Robot, loop: Loop, cap: Capsules) -> Capsules | None:
    """The capsules with only the pairs whose relative pose the loop's joints do not change
    (both bodies hang from the same body of the loop, or from the support side), so a draw
    that collides there collides after closing the loop too; None without such pairs."""
    on_path = set(loop.path.tolist()) | {0}
    anchor = np.zeros(len(robot.model.bodies), dtype=np.int64)
    for b, body in enumerate(robot.model.bodies):  # parents come first
        anchor[b] = b if b in on_path else anchor[body.parent]
    a = anchor[cap.body[cap.pairs[:, 0]]]
    keep = a == anchor[cap.body[cap.pairs[:, 1]]]
    if not keep.any():
        return None
    return dataclasses.replace(cap, pairs=cap.pairs[keep])


class _Double:
    """State of one double-support candidate search."""

    def __init__(self, robot: Robot, opt: CandidateOptions, lim: np.ndarray):
        self.robot, self.opt, self.lim = robot, opt, lim
        self.loop = loop_of(robot)
        self.half = opt.half(robot)
        h = self.half
        box = np.array([[h[0], h[1]], [h[0], -h[1]], [-h[0], h[1]], [-h[0], -h[1]]])
        self.box_ref = robot.sole_centre + box
        self.box_free = box  # around the free sole frame's origin, its sole's centre
        self.contacts_free = free_contacts(robot, self.loop)
        self.cap = collision_capsules(robot)
        self.rigid = rigid_pairs(robot, self.loop, self.cap)
        self.ground = ground_checks(robot, self.cap)
        self.toes, self.toe_floor = beyond_free_foot(robot)
        size = self.loop.size
        self.reach = np.array([PLACE_SHARE[0] * size[0], PLACE_SHARE[1] * size[1], PLACE_YAW])
        self.qs: list[np.ndarray] = []
        self.targets: list[np.ndarray] = []
        #: drawn, closed within limits, stable, clear of the floor, free of self-collision
        self.counts = np.zeros(5, dtype=np.int64)

    def keep(self, q: np.ndarray, target: np.ndarray) -> None:
        """Close the draws ``q`` onto the placements ``target``; keep those that pass."""
        robot, lim, c = self.robot, self.lim, self.counts
        c[0] += len(q)
        if self.rigid is not None:  # collisions closing the loop cannot undo: before it
            ok = collision_free_poses(robot, self.rigid, q)
            q, target = q[ok], target[ok]
        q, closed = close_chain(robot, self.loop, q, target)
        ok = closed & np.all((q >= lim[:, 0]) & (q <= lim[:, 1]), axis=1)
        q, target = q[ok], target[ok]
        c[1] += len(q)
        if not len(q):
            return
        model = self.opt.compliance
        st = com_state(robot, q, jacobian=model is not None)
        boxes = np.concatenate(
            [np.broadcast_to(self.box_ref, (len(q), 4, 2)), place_points(self.box_free, target)], 1
        )
        ok = hull_margin(boxes, st.com[:, :2]) > 0
        if model is not None:
            feet = np.concatenate(
                [
                    np.broadcast_to(model.contacts, (len(q), len(model.contacts), 2)),
                    place_points(self.contacts_free, target),
                ],
                axis=1,
            )
            ok &= double_margin(model, st, feet) > 0
        q, target = q[ok], target[ok]
        c[2] += len(q)
        if not len(q):
            return
        rot, org = robot.forward(q)
        ok = clear_above(self.ground, rot, org, robot.floor)
        if self.toes is not None:
            ok &= clear_above(self.toes, rot, org, self.toe_floor)
        q, target, rot, org = q[ok], target[ok], rot[ok], org[ok]
        c[3] += len(q)
        free = collision_free_mask_broad(self.cap, rot, org)
        c[4] += int(free.sum())
        self.qs.append(q[free])
        self.targets.append(target[free])

    def nothing(self) -> str:
        """Why no draw was kept: the first check that stops them all."""
        c = self.counts
        stage = first_empty(c, ("the loop does not close within the joint limits",
                                "stability (the CoP inside both feet's support)",
                                "the floor check", "self-collision"))  # fmt: skip
        return (
            f"no pose of {self.robot.name} on both feet passes every check: of {c[0]} draws "
            f"{c[1]} closed the loop onto the floor within the limits, {c[2]} were stable, "
            f"{c[3]} cleared the floor, {c[4]} were free of self-collision: {stage} stops them"
        )


def double_candidates(
    robot: Robot,
    n: int,
    seed: int | np.random.Generator = 0,
    options: CandidateOptions | None = None,
    *,
    progress: Callable[[int, int], None] | None = None,
) -> Candidates:
    """``n`` accepted poses of ``robot`` standing on its support foot and its free foot
    (module docstring; ``CandidateOptions``: limits, CoP box, compliant model; the rest of its
    fields are a single stance's), reporting ``progress(accepted, n)``; ``mount`` "double".
    SescidError when the free foot is unknown or no pose passes, saying which check stops them.
    """
    opt = options or CandidateOptions()
    if n < 1:
        raise SescidError(f"number of candidates must be ≥ 1, got {n}")
    robot.check_support_level()
    rng = np.random.default_rng(seed)
    lim = sampling_limits(robot) if opt.limits is None else np.asarray(opt.limits, dtype=float)
    run = _Double(robot, opt, lim)
    cols = run.loop.cols
    width = lim[:, 1] - lim[:, 0]
    # the profile's uniform draws (the OP2), else draws near the zero pose and accepted ones
    sampler: Sampling = (
        "uniform" if (opt.sampler or robot.profile.pose_sampler) == "uniform" else "near"
    )
    size = min(_CHUNK, max(1_000, 4 * n))
    while run.counts[4] < n:
        if sampler == "uniform":
            q = rng.random((size, robot.nq)) * width + lim[:, 0]
            q[:, cols] *= START_SHARE
        else:
            q = draw(lim, size, rng, np.concatenate(run.qs) if run.counts[4] else None)
        run.keep(q, placements(run.loop, size, rng, run.reach))
        done, drawn = int(run.counts[4]), int(run.counts[0])
        if progress is not None:
            progress(min(done, n), n)
        if not done and drawn >= DOUBLE_GIVE_UP:
            raise SescidError(run.nothing())
        if (
            sampler == "uniform"
            and done
            and drawn >= DOUBLE_SWITCH_AFTER
            and done < DOUBLE_SWITCH_RATE * drawn
        ):
            sampler = "uniform+near"  # the draws near accepted poses take over
        rate = done / drawn
        want = 1.05 * (n - done) / rate + 500 if rate > 0 else _CHUNK
        size = int(min(_CHUNK, max(1_000, want)))
    q = np.concatenate(run.qs)[:n]
    out = Candidates.counted(
        run.counts,
        q=q,
        cop=level_cop(robot, q),
        limits=lim,
        half_extents=run.half,
        capsules=run.cap,
        sampler=sampler,
        centre=robot.sole_centre,
        compliance=opt.compliance,
        mount="double",
    )
    rot, pos = free_sole_frame(robot, run.loop, q)
    out.placement = np.concatenate([pos[:, :2], rot[:, :2, 0]], axis=1)
    out.notes.append(
        f"double support: free sole '{run.loop.free}' flat on the floor within "
        f"±{run.reach[0] * 1e3:.0f} mm (x), ±{run.reach[1] * 1e3:.0f} mm (y), "
        f"±{math.degrees(PLACE_YAW):g}° of its zero-pose placement; the legs ({len(cols)} "
        "joints) closed onto it by inverse kinematics"
    )
    return out
