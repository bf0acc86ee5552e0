"""Ground clearance for any robot: every body above the floor, the free sole above it by a
clearance.

Every body but the support body is checked, on the best geometry it has: its collision shapes;
its visual shapes where it has no collision shape (a model whose collision geometry is only
the feet, as MuJoCo Playground models are); its origin as a last resort (no geometry, or only
mesh files that could not be read). Primitive shapes are checked through capsules that cover
them (``collision.shape_capsules``); meshes through their exact hull vertices, where their
covering capsules dip below the floor. The floor is ``Robot.floor`` (z = 0 of a sole frame, or
the plane under a foot frame derived from the foot's geometry). A body other than the free foot
that already reaches below the floor at the zero pose (a conservative covering of an ankle link)
is not checked, with a note — as self-collision skips pairs that touch at the zero pose.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from sescid.model.geometry import MESH
from sescid.model.sole import profile_sole
from sescid.planning.collision import Capsules, shape_capsules
from sescid.robot import Robot

_TOUCH = 1e-6  #: m, below the floor at the zero pose by more than this counts as touching


@dataclass
class GroundChecks:
    """What ``ground_clear`` checks on a robot: covering capsules and mesh vertices per body."""

    capsules: Capsules  #: covering capsules (and radius-0 points at origins) of the checked bodies
    vert_body: np.ndarray  #: (V,) body index of each checked mesh vertex
    vertices: np.ndarray  #: (V, 3) checked mesh hull vertices, body frames, m
    source: dict[str, str] = field(default_factory=dict)  #: body → collision/visual/origin
    exempt: list[str] = field(default_factory=list)  #: bodies below the floor at q = 0
    notes: list[str] = field(default_factory=list)


def _body_shapes(robot: Robot, b: int) -> tuple[list, str]:
    """The shapes a body is checked with and their role: collision, else visual, else none."""
    for role in ("collision", "visual"):
        shapes = [s for s in robot.shapes if s.body == b and s.role == role]
        usable = [s for s in shapes if s.kind != MESH or s.vertices is not None]
        if usable:
            return usable, role
    return [], "origin"


def ground_checks(robot: Robot, cap: Capsules | None = None) -> GroundChecks:
    """The capsules, points and mesh vertices that ``ground_clear`` checks, with notes.

    ``cap`` (the self-collision capsules) only keeps the result for the next call."""
    cached = getattr(cap, "_ground", None)
    if cached is not None and cached[0] is robot:
        return cached[1]
    names = robot.body_names
    shapes, source, origins = [], {}, []
    for b in range(1, len(names)):
        use, role = _body_shapes(robot, b)
        shapes += use
        source[names[b]] = role
        if role == "origin":
            origins.append(b)
    caps = shape_capsules(shapes)[0]
    n0 = len(origins)
    caps.body = np.concatenate([caps.body, np.array(origins, dtype=np.int64)])
    caps.p0 = np.vstack([caps.p0, np.zeros((n0, 3))])
    caps.p1 = np.vstack([caps.p1, np.zeros((n0, 3))])
    caps.radius = np.concatenate([caps.radius, np.zeros(n0)])
    caps.from_mesh = np.concatenate([caps.from_mesh, np.zeros(n0, dtype=bool)])
    caps.link += [names[b] for b in origins]
    meshes = [s for s in shapes if s.kind == MESH]
    parts = [np.full(len(s.vertices), s.body) for s in meshes if s.vertices is not None]
    vert_body = np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)
    verts = np.vstack([s.vertices for s in meshes] or [np.zeros((0, 3))])
    vert_body = vert_body.astype(np.int64)
    exempt = _exempt(robot, caps, vert_body, verts)
    keep = ~np.isin(caps.body, list(exempt))
    for k in ("body", "p0", "p1", "radius", "from_mesh"):
        setattr(caps, k, getattr(caps, k)[keep])
    caps.link = [n for n, k in zip(caps.link, keep, strict=True) if k]
    vkeep = ~np.isin(vert_body, list(exempt))
    gone = sorted(names[b] for b in exempt)
    out = GroundChecks(caps, vert_body[vkeep], verts[vkeep], source, gone)
    out.notes = _notes(robot, out)
    if cap is not None:
        cap._ground = (robot, out)  # type: ignore[attr-defined]
    return out


def _exempt(robot: Robot, caps: Capsules, vert_body: np.ndarray, verts: np.ndarray) -> set[int]:
    """Bodies other than the free foot that reach below the floor at the zero pose."""
    rot, org = robot.forward(np.zeros((1, robot.nq)))
    floor = robot.floor
    w0, w1 = caps.world(rot, org)
    low = np.minimum(w0[0, :, 2], w1[0, :, 2]) - caps.radius
    out = {int(b) for b in caps.body[low < floor - _TOUCH]}
    if len(verts):
        z = org[0, vert_body, 2] + np.einsum("vj,vj->v", rot[0, vert_body, 2, :], verts)
        out |= {int(b) for b in vert_body[z < floor - _TOUCH]}
    free = robot.free_sole
    out.discard(-1 if free is None else free.body)
    return out


def _notes(robot: Robot, g: GroundChecks) -> list[str]:
    """What the floor check covers and leaves out."""
    by = {r: [n for n, s in g.source.items() if s == r] for r in ("collision", "visual", "origin")}
    notes = [
        f"floor check on every body but the support: {len(by['collision'])} by their collision "
        f"shapes, {len(by['visual'])} by their visual shapes (no collision shape), "
        f"{len(by['origin'])} by their origin only (no usable geometry)"
    ]
    if by["origin"]:
        notes.append("bodies checked by their origin only: " + ", ".join(by["origin"][:6]))
    if g.exempt:
        notes.append(
            f"{len(g.exempt)} body(ies) reach below the floor at q = 0 and are not checked "
            f"against it: {', '.join(g.exempt)}"
        )
    if robot.free_sole is None:
        notes.append("free foot unknown: its sole is not checked against the floor")
    return notes


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


def lowest_heights(robot: Robot, rot: np.ndarray, org: np.ndarray) -> np.ndarray:
    """(n,) the lowest checked point [m] (support-frame z) over every checked body, per pose."""
    g = ground_checks(robot)
    low = np.full(rot.shape[0], np.inf)
    c = g.capsules
    if len(c.body):
        zrow = rot[:, c.body, 2, :]
        z0 = org[:, c.body, 2] + np.einsum("ncj,cj->nc", zrow, c.p0)
        z1 = org[:, c.body, 2] + np.einsum("ncj,cj->nc", zrow, c.p1)
        low = np.minimum(low, (np.minimum(z0, z1) - c.radius).min(axis=1, initial=np.inf))
    if len(g.vertices):
        z = org[:, g.vert_body, 2] + np.einsum("nvj,vj->nv", rot[:, g.vert_body, 2, :], g.vertices)
        low = np.minimum(low, z.min(axis=1))
    return low


def ground_clear(
    robot: Robot,
    cap: Capsules | None,
    rot: np.ndarray,
    org: np.ndarray,
    clearance: float,
    sole_size: ArrayLike | None = None,
) -> np.ndarray:
    """(n,) True where every checked body is above the floor and the free sole's corners are
    above it by ``clearance`` [m]; ``rot``, ``org`` from ``robot.forward``."""
    g = ground_checks(robot, cap)
    floor = robot.floor
    ok = np.ones(rot.shape[0], dtype=bool)
    c = g.capsules
    assert c.from_mesh is not None
    prim = ~c.from_mesh
    if prim.any():
        b = c.body[prim]
        zrow = rot[:, b, 2, :]  # (n, C, 3): only heights are needed
        z0 = org[:, b, 2] + np.einsum("ncj,cj->nc", zrow, c.p0[prim])
        z1 = org[:, b, 2] + np.einsum("ncj,cj->nc", zrow, c.p1[prim])
        ok &= np.all(np.minimum(z0, z1) - c.radius[prim] > floor, axis=1)
    for b in np.unique(g.vert_body):
        idx = np.flatnonzero(ok)
        mc = np.flatnonzero(c.from_mesh & (c.body == b))
        if len(mc):  # the body's mesh capsules cover its hull: exact check only where they dip
            zrow = rot[idx, b, 2, :]
            low = np.minimum(zrow @ c.p0[mc].T, zrow @ c.p1[mc].T) - c.radius[mc]
            idx = idx[(org[idx, b, 2] + low.min(axis=1)) <= floor]
        v = g.vertices[g.vert_body == b]
        z = org[idx, b, 2:3] + rot[idx, b, 2, :] @ v.T
        ok[idx] = z.min(axis=1) > floor
    corners = free_sole_corners(robot, rot, org, sole_size)
    if corners is not None:
        ok &= np.all(corners[..., 2] > floor + clearance, axis=1)
    return ok
