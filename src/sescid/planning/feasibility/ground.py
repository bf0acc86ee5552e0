"""Ground clearance for any robot: every body above the floor, the free foot above it by a
clearance.

Every body but the support body is checked, on the best geometry it has: its collision shapes;
its visual shapes where it has no collision shape (a model whose collision geometry is only
the feet, as MuJoCo Playground models are); as a last resort (no geometry, or only mesh files
that could not be read) its origin and the origins of the frames on it (a sole frame). Each
shape's lowest point is exact: a sphere or capsule is its segment less its radius, a cylinder
its end discs' lowest rim points, a box its corners, a mesh its hull vertices (checked only in
the poses where the capsules that cover it dip below the floor, ``collision.mesh_capsules``).
The floor is ``Robot.floor`` (z = 0 of a sole frame, or the plane under a foot frame derived
from the foot's geometry). A body other than the free foot
that already reaches below the floor at the zero pose (a conservative covering of an ankle link)
is not checked, with a note — as self-collision skips pairs that touch at the zero pose —
unless it lies beyond the support foot (toes on a joint of the support foot: they touch the
floor the foot stands on, so they must stay above it whatever they do at the zero pose). The
free foot (``Robot.free_sole``) and the bodies beyond it (toes) must clear the floor by the
foot clearance on all of their geometry, and its sole's corners too: a foot that grazes the
floor is not single support on a real robot.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from sescid.model.geometry import BOX, CAPSULE, CYLINDER, MESH, SPHERE
from sescid.model.sole import beyond_support, profile_sole
from sescid.planning.feasibility.collision import Capsules, mesh_capsules
from sescid.robot import Robot

_TOUCH = 1e-6  #: m, below the floor at the zero pose by more than this counts as touching
_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)


@dataclass
class Segments:
    """Segments p0–p1 in body frames with a radius: capsules and spheres (round: the lowest
    point is the lower end less the radius), cylinders (flat: less r·√(1 − a_z²)), points."""

    body: np.ndarray  #: (S,)
    p0: np.ndarray  #: (S, 3) m
    p1: np.ndarray  #: (S, 3) m
    radius: np.ndarray  #: (S,) m
    flat: np.ndarray  #: (S,) bool: a cylinder (flat ends)

    def lowest(self, rot: np.ndarray, org: np.ndarray) -> np.ndarray:
        """(n, S) lowest z [m] of each segment in poses with body ``rot``, ``org``."""
        b = self.body
        zrow = rot[:, b, 2, :]  # (n, S, 3): only heights are needed
        z0 = org[:, b, 2] + np.einsum("nsj,sj->ns", zrow, self.p0)
        z1 = org[:, b, 2] + np.einsum("nsj,sj->ns", zrow, self.p1)
        length = np.linalg.norm(self.p1 - self.p0, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            az = np.where(length > 0, (z1 - z0) / length, 0.0)
        down = np.where(self.flat, self.radius * np.sqrt(np.clip(1.0 - az * az, 0.0, 1.0)),
                        self.radius)  # fmt: skip
        return np.minimum(z0, z1) - down

    def subset(self, keep: np.ndarray) -> Segments:
        """The segments where ``keep``."""
        return Segments(self.body[keep], self.p0[keep], self.p1[keep], self.radius[keep],
                        self.flat[keep])  # fmt: skip


@dataclass
class GroundChecks:
    """What ``ground_clear`` checks on a robot."""

    segments: Segments  #: spheres, capsules, cylinders, origins
    corner_body: np.ndarray  #: (B,) body of each box corner
    corners: np.ndarray  #: (B, 3) box corners, body frames, m
    mesh_cover: Capsules  #: capsules covering each checked mesh (a pre-check)
    vert_body: np.ndarray  #: (V,) body index of each checked mesh vertex
    vertices: np.ndarray  #: (V, 3) checked mesh hull vertices, body frames, m
    source: dict[str, str] = field(default_factory=dict)  #: body → collision/visual/origin
    exempt: list[str] = field(default_factory=list)  #: bodies below the floor at q = 0
    notes: list[str] = field(default_factory=list)
    #: the free foot and the bodies beyond it, checked above the floor by the foot clearance
    free: GroundChecks | None = None
    free_bodies: list[str] = field(default_factory=list)  #: their names


def _body_shapes(robot: Robot, b: int) -> tuple[list, str]:
    """The shapes a body is checked with and their role: collision, else visual, else none."""
    for role in ("collision", "visual"):
        shapes = [s for s in robot.shapes if s.body == b and s.role == role]
        usable = [s for s in shapes if s.kind != MESH or s.vertices is not None]
        if usable:
            return usable, role
    return [], "origin"


def _origin_points(robot: Robot, bodies: list[int]) -> list[tuple[int, np.ndarray]]:
    """(body, point (3,) [m] in its frame): the origin of each body in ``bodies`` and of every
    frame on it (a sole frame, a link welded to it): what a body without geometry is checked by."""
    out: list[tuple[int, np.ndarray]] = []
    for b in bodies:
        pts = [np.zeros(3)]
        pts += [x[:3, 3] for bb, x in robot.model.link_frames.values() if bb == b]
        out += [(b, p) for p in np.unique(np.round(np.array(pts), 12), axis=0)]
    return out


def _build(shapes: list, origins: list[tuple[int, np.ndarray]]) -> GroundChecks:
    """The exact lowest-point representation of ``shapes`` and of the points ``origins``
    ((body, point in its frame), ``_origin_points``)."""
    sb, p0, p1, rad, flat = [], [], [], [], []
    cb, cv, vb, vv, mb, m0, m1, mr = [], [], [], [], [], [], [], []
    for s in shapes:
        r, t = s.pose[:3, :3], s.pose[:3, 3]
        if s.kind in (SPHERE, CAPSULE, CYLINDER):
            half = 0.0 if s.kind == SPHERE else float(s.size[1]) / 2
            sb.append(s.body)
            p0.append(t - half * r[:, 2])
            p1.append(t + half * r[:, 2])
            rad.append(float(s.size[0]))
            flat.append(s.kind == CYLINDER)
        elif s.kind == BOX:
            cb += [s.body] * 8
            cv.append((_CORNERS * (0.5 * s.size)) @ r.T + t)
        elif s.kind == MESH and s.vertices is not None:
            vb.append(np.full(len(s.vertices), s.body))
            vv.append(s.vertices)
            e0, e1, rr = mesh_capsules((s.vertices - t) @ r)
            mb += [s.body] * len(e0)
            m0.append(e0 @ r.T + t)
            m1.append(e1 @ r.T + t)
            mr += [rr] * len(e0)
    for b, pt in origins:
        sb.append(b)
        p0.append(pt)
        p1.append(pt)
        rad.append(0.0)
        flat.append(False)
    seg = Segments(
        np.array(sb, dtype=np.int64),
        np.array(p0).reshape(-1, 3),
        np.array(p1).reshape(-1, 3),
        np.array(rad),
        np.array(flat, dtype=bool),
    )

    def stack(parts, width=3):
        return np.vstack(parts) if parts else np.zeros((0, width))

    cover = Capsules(np.array(mb, dtype=np.int64), stack(m0), stack(m1), np.array(mr), [],
                     np.zeros((0, 2), dtype=np.int64))  # fmt: skip
    vert_body = np.concatenate(vb).astype(np.int64) if vb else np.zeros(0, dtype=np.int64)
    return GroundChecks(seg, np.array(cb, dtype=np.int64), stack(cv), cover, vert_body, stack(vv))


def ground_checks(robot: Robot, cap: Capsules | None = None, exempt: bool = True) -> GroundChecks:
    """What ``ground_clear`` checks, with notes; ``cap`` (the self-collision capsules) only
    keeps the result for the next call. ``exempt=False``: every body but the support is
    checked (a robot hanging in a gantry: nothing touches the floor at the zero pose)."""
    key = "_ground" if exempt else "_ground_all"
    cached = getattr(cap, key, None)
    if cached is not None and cached[0] is robot:
        return cached[1]
    names = robot.body_names
    feet = _free_foot_bodies(robot) if exempt else set()
    shapes, source, origins = [], {}, []
    foot_shapes, foot_origins = [], []
    for b in range(1, len(names)):
        use, role = _body_shapes(robot, b)
        source[names[b]] = role
        if b in feet:
            foot_shapes += use
            foot_origins += [b] if role == "origin" else []
            continue
        shapes += use
        if role == "origin":
            origins.append(b)
    g = _build(shapes, _origin_points(robot, origins))
    if feet:
        g.free = _build(foot_shapes, _origin_points(robot, foot_origins))
        g.free_bodies = [names[b] for b in sorted(feet)]
    below = _exempt(robot, g) if exempt else set()
    if below:
        out = list(below)
        g.segments = g.segments.subset(~np.isin(g.segments.body, out))
        keep = ~np.isin(g.corner_body, out)
        g.corner_body, g.corners = g.corner_body[keep], g.corners[keep]
        keep = ~np.isin(g.vert_body, out)
        g.vert_body, g.vertices = g.vert_body[keep], g.vertices[keep]
    g.source, g.exempt = source, sorted(names[b] for b in below)
    g.notes = _notes(robot, g)
    if cap is not None:
        setattr(cap, key, (robot, g))
    return g


def _free_foot_bodies(robot: Robot) -> set[int]:
    """The free foot's body and the bodies beyond it (away from the support); empty when the
    free foot is unknown."""
    free = robot.free_sole
    if free is None or free.body <= 0:
        return set()
    out = {free.body}
    for i, bd in enumerate(robot.model.bodies):  # children follow their parents
        if bd.parent in out:
            out.add(i)
    return out


def _exempt(robot: Robot, g: GroundChecks) -> set[int]:
    """Bodies other than the free foot that reach below the floor at the zero pose."""
    rot, org = robot.forward(np.zeros((1, robot.nq)))
    below = robot.floor - _TOUCH
    out = {int(b) for b in g.segments.body[g.segments.lowest(rot, org)[0] < below]}
    for body, pts in ((g.corner_body, g.corners), (g.vert_body, g.vertices)):
        if len(pts):
            z = org[0, body, 2] + np.einsum("vj,vj->v", rot[0, body, 2, :], pts)
            out |= {int(b) for b in body[z < below]}
    free = robot.free_sole
    out.discard(-1 if free is None else free.body)
    return out - set(_beyond_support(robot))


def _beyond_support(robot: Robot) -> list[int]:
    """The bodies beyond the support foot (its toes: ``model.sole.beyond_support``)."""
    return beyond_support([bd.parent for bd in robot.model.bodies], robot.masses)


def _notes(robot: Robot, g: GroundChecks) -> list[str]:
    """What the floor check covers and leaves out."""
    by = {r: [n for n, s in g.source.items() if s == r] for r in ("collision", "visual", "origin")}
    notes = [
        f"floor check on every body but the support: {len(by['collision'])} by their collision "
        f"shapes, {len(by['visual'])} by their visual shapes (no collision shape), "
        f"{len(by['origin'])} by their origin and frames only (no usable geometry)"
    ]
    if by["origin"]:
        notes.append(
            "bodies checked by their origin and frames only: " + ", ".join(by["origin"][:6])
        )
    toes = [robot.body_names[b] for b in _beyond_support(robot)]
    if toes:
        notes.append(
            f"{len(toes)} body(ies) beyond the support foot held above the floor too: "
            + ", ".join(toes[:6])
            + (" …" if len(toes) > 6 else "")
        )
    if g.exempt:
        notes.append(
            f"{len(g.exempt)} body(ies) reach below the floor at q = 0 and are not checked "
            f"against it: {', '.join(g.exempt)}"
        )
    if robot.free_sole is None:
        notes.append("free foot unknown: no body is held above the floor by the foot clearance")
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


def lowest_heights(
    robot: Robot, rot: np.ndarray, org: np.ndarray, exempt: bool = True
) -> np.ndarray:
    """(n,) the lowest checked point [m] (support-frame z) over every checked body, per pose
    (every mesh vertex, no pre-check); ``exempt=False``: over every body but the support."""
    g = ground_checks(robot, exempt=exempt)
    low = np.full(rot.shape[0], np.inf)
    for part in (g, g.free):
        if part is not None:
            low = np.minimum(low, _lowest(part, rot, org))
    return low


def _lowest(g: GroundChecks, rot: np.ndarray, org: np.ndarray) -> np.ndarray:
    """(n,) the lowest point [m] ``g`` checks (every mesh vertex), per pose."""
    low = np.full(rot.shape[0], np.inf)
    if len(g.segments.body):
        low = np.minimum(low, g.segments.lowest(rot, org).min(axis=1))
    for body, pts in ((g.corner_body, g.corners), (g.vert_body, g.vertices)):
        if len(pts):
            z = org[:, body, 2] + np.einsum("nvj,vj->nv", rot[:, body, 2, :], pts)
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
    """(n,) True where every checked body is above the floor and the free foot (its bodies and
    its sole's corners) above it by ``clearance`` [m]; ``rot``, ``org`` from ``robot.forward``."""
    g = ground_checks(robot, cap)
    ok = clear_above(g, rot, org, robot.floor)
    if g.free is not None:
        ok &= clear_above(g.free, rot, org, robot.floor + clearance)
    corners = free_sole_corners(robot, rot, org, sole_size)
    if corners is not None:
        ok &= np.all(corners[..., 2] > robot.floor + clearance, axis=1)
    return ok


def clear_above(g: GroundChecks, rot: np.ndarray, org: np.ndarray, floor: float) -> np.ndarray:
    """(n,) True where every point ``g`` checks lies above the plane z = ``floor`` [m]."""
    ok = np.ones(rot.shape[0], dtype=bool)
    if len(g.segments.body):
        ok &= np.all(g.segments.lowest(rot, org) > floor, axis=1)
    if len(g.corners):
        b = g.corner_body
        z = org[:, b, 2] + np.einsum("ncj,cj->nc", rot[:, b, 2, :], g.corners)
        ok &= np.all(z > floor, axis=1)
    c = g.mesh_cover
    for b in np.unique(g.vert_body):
        idx = np.flatnonzero(ok)
        mc = np.flatnonzero(c.body == b)  # the capsules cover the hull: exact where they dip
        zrow = rot[idx, b, 2, :]
        low = np.minimum(zrow @ c.p0[mc].T, zrow @ c.p1[mc].T) - c.radius[mc]
        idx = idx[(org[idx, b, 2] + low.min(axis=1)) <= floor]
        v = g.vertices[g.vert_body == b]
        z = org[idx, b, 2:3] + rot[idx, b, 2, :] @ v.T
        ok[idx] = z.min(axis=1) > floor
    return ok


def beyond_free_foot(robot: Robot) -> tuple[GroundChecks | None, float]:
    """(checks, floor [m]): the bodies beyond the free foot (toes), when the free foot stands on
    the floor beside the support foot (double support), and the plane they must stay above: the
    floor, or their lowest point at the zero pose where that lies below it, less ``_TOUCH``.
    None when the free foot has no body beyond it."""
    free = robot.free_sole
    feet = _free_foot_bodies(robot)
    beyond = sorted(feet - {free.body}) if free is not None else []
    if not beyond:
        return None, robot.floor
    shapes, origins = [], []
    for b in beyond:
        use, role = _body_shapes(robot, b)
        shapes += use
        origins += [b] if role == "origin" else []
    g = _build(shapes, _origin_points(robot, origins))
    rot, org = robot.forward(np.zeros((1, robot.nq)))
    low = float(_lowest(g, rot, org)[0])
    return g, min(robot.floor, low) - _TOUCH
