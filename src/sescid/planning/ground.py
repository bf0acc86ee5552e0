"""Ground clearance for any robot: every body above the floor, the free sole above it by a
clearance.

The floor is ``Robot.floor`` (z = 0 of a sole frame, or the plane under a foot frame derived
from the foot's geometry). Primitive shapes are checked through their collision capsules; mesh
shapes through their exact hull vertices (``Robot.shapes``); meshes whose file is missing are
not checked and named in the notes. A body other than the support body and the free foot that
already reaches below the floor at the zero pose (a conservative covering of an ankle link) is
not checked, with a note — as self-collision skips pairs that touch at the zero pose.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from sescid.model.geometry import MESH
from sescid.model.sole import profile_sole
from sescid.planning.collision import Capsules
from sescid.robot import Robot

_TOUCH = 1e-6  #: m, below the floor at the zero pose by more than this counts as touching


@dataclass
class GroundChecks:
    """What ``ground_clear`` checks on a robot."""

    capsules: np.ndarray  #: (C,) bool: capsules checked (primitive shapes, not exempt)
    vert_body: np.ndarray  #: (V,) body index of each checked mesh vertex
    vertices: np.ndarray  #: (V, 3) checked mesh hull vertices, body frames, m
    exempt: list[str] = field(default_factory=list)  #: bodies below the floor at q = 0
    notes: list[str] = field(default_factory=list)


def ground_checks(robot: Robot, cap: Capsules) -> GroundChecks:
    """The capsules and mesh vertices that ``ground_clear`` checks, with notes."""
    floor = robot.floor
    free = robot.free_sole
    free_body = -1 if free is None else free.body
    mesh_cap = cap.from_mesh if cap.from_mesh is not None else np.zeros(len(cap.body), bool)
    chk = (cap.body != 0) & ~mesh_cap
    vb, vv = [], []
    n_missing = 0
    for s in robot.shapes:
        if s.role != "collision" or s.kind != MESH or s.body == 0:
            continue
        if s.vertices is None:
            n_missing += 1
            continue
        vb.append(np.full(len(s.vertices), s.body))
        vv.append(s.vertices)
    vert_body = np.concatenate(vb) if vb else np.zeros(0, dtype=np.int64)
    verts = np.vstack(vv) if vv else np.zeros((0, 3))
    rot, org = robot.forward(np.zeros((1, robot.nq)))
    names = robot.body_names
    exempt: set[int] = set()
    if chk.any():
        w0, w1 = cap.world(rot, org)
        low = np.minimum(w0[0, :, 2], w1[0, :, 2]) - cap.radius
        exempt |= {int(b) for b in cap.body[chk & (low < floor - _TOUCH)]}
    if len(verts):
        z = org[0, vert_body, 2] + np.einsum("vj,vj->v", rot[0, vert_body, 2, :], verts)
        exempt |= {int(b) for b in vert_body[z < floor - _TOUCH]}
    exempt.discard(free_body)
    if exempt:
        chk &= ~np.isin(cap.body, list(exempt))
        keep = ~np.isin(vert_body, list(exempt))
        vert_body, verts = vert_body[keep], verts[keep]
    notes = []
    if exempt:
        notes.append(
            f"{len(exempt)} body(ies) reach below the floor at q = 0 and are not checked "
            f"against it: {', '.join(names[b] for b in sorted(exempt))}"
        )
    if n_missing:
        notes.append(
            f"{n_missing} mesh collision shape(s) not loaded: not checked against the floor"
        )
    if free is None:
        notes.append("free foot unknown: its sole is not checked against the floor")
    if not chk.any() and not len(verts):
        notes.append("no collision shapes on the moving bodies: none is checked against the floor")
    return GroundChecks(
        chk, vert_body.astype(np.int64), verts, sorted(names[b] for b in exempt), notes
    )


def free_sole_corners(
    robot: Robot, rot: np.ndarray, org: np.ndarray, sole_size: ArrayLike | None = None
) -> np.ndarray | None:
    """(n, 4, 3) free sole corners [m] in the support frame, None when the free foot is unknown.

    ``sole_size`` resizes a sole that comes from the profile (around its frame)."""
    sole = robot.free_sole
    if sole is None:
        return None
    if sole_size is not None and not sole.derived:
        b, x = robot.model.link_frames[sole.link]
        ss = np.asarray(sole_size, dtype=float)
        size = (float(ss[0]), float(ss[1]))
        sole = profile_sole(sole.link, b, x, size, sole.note)
    b = sole.body
    return org[:, None, b] + np.einsum("nij,cj->nci", rot[:, b], sole.corners)


def ground_clear(
    robot: Robot,
    cap: Capsules,
    rot: np.ndarray,
    org: np.ndarray,
    clearance: float,
    sole_size: ArrayLike | None = None,
) -> np.ndarray:
    """(n,) True where every checked body is above the floor and the free sole's corners are
    above it by ``clearance`` [m]; ``rot``, ``org`` from ``robot.forward``."""
    g = _cache(robot, cap)
    floor = robot.floor
    ok = np.ones(rot.shape[0], dtype=bool)
    if g.capsules.any():
        b = cap.body[g.capsules]
        zrow = rot[:, b, 2, :]  # (n, C, 3): only heights are needed
        z0 = org[:, b, 2] + np.einsum("ncj,cj->nc", zrow, cap.p0[g.capsules])
        z1 = org[:, b, 2] + np.einsum("ncj,cj->nc", zrow, cap.p1[g.capsules])
        ok &= np.all(np.minimum(z0, z1) - cap.radius[g.capsules] > floor, axis=1)
    mesh_cap = cap.from_mesh if cap.from_mesh is not None else np.zeros(len(cap.body), bool)
    for b in np.unique(g.vert_body):
        idx = np.flatnonzero(ok)
        mc = np.flatnonzero(mesh_cap & (cap.body == b))
        if len(mc):  # the body's mesh capsules cover its hull: exact check only where they dip
            zrow = rot[idx, b, 2, :]
            low = np.minimum(zrow @ cap.p0[mc].T, zrow @ cap.p1[mc].T) - cap.radius[mc]
            idx = idx[(org[idx, b, 2] + low.min(axis=1)) <= floor]
        v = g.vertices[g.vert_body == b]
        z = org[idx, b, 2:3] + rot[idx, b, 2, :] @ v.T
        ok[idx] = z.min(axis=1) > floor
    corners = free_sole_corners(robot, rot, org, sole_size)
    if corners is not None:
        ok &= np.all(corners[..., 2] > floor + clearance, axis=1)
    return ok


def _cache(robot: Robot, cap: Capsules) -> GroundChecks:
    """The ground checks, kept on the capsules object (built once per capsule set)."""
    g = getattr(cap, "_ground", None)
    if g is None or g[0] is not robot:
        g = (robot, ground_checks(robot, cap))
        cap._ground = g  # type: ignore[attr-defined]
    return g[1]
