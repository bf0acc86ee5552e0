"""Soles for any robot: the floor plane and the sole rectangle of a foot, from a profile or
derived from the foot's lowest geometry; whether the support frame is level; which body is the
other (free) foot.

The support frame's z axis is taken as vertical once ``level_check`` has found it along the
normal of the support foot's sole. A foot's sole is derived from its body's collision shapes
(visual ones when it has none) at the zero pose, in the support frame's orientation: the lowest
points of every box (corners), cylinder (rim), sphere and capsule (bottom points) and mesh
(hull vertices) are collected, the floor is the lowest of them, and the rectangle is the x/y
extent of the points within ``CONTACT_TOL`` of it. A foot whose frame is a sole (its geometry at
or above z = 0) keeps z = 0 as the floor; a foot frame above the geometry (G1 stands on its
ankle frame) gets the derived floor below it.

The free foot (``free_foot``) is found from the tree and the geometry, not from names: of the
bodies off the supporting leg, the one whose geometry reaches lowest at the zero pose, when that
is within ``FREE_FOOT_SHARE`` of the robot's height of the floor (a humanoid's other foot
stands beside the support foot at the zero pose; hands and knees are far higher); else (a
motion-capture model whose zero pose lifts a leg) the supporting leg's mirror: on the branch
off the trunk that weighs most like the supporting leg, the body as many joints from the trunk
as the support foot (``mirror_foot``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal, get_args

import numpy as np

from sescid.model.geometry import BOX, CAPSULE, CYLINDER, MESH, SPHERE, Shape

CONTACT_TOL = 0.003  #: m, points this close to the lowest one touch the floor
MIN_SOLE = 0.01  #: m, a derived side shorter than this is widened to the foot's x/y extent
#: a support frame is level when the foot's lowest face under its −z covers at least this share
#: of the foot's largest flat face (a heel frame with a horizontal z sees the heel's end face)
LEVEL_SHARE = 0.5
#: the free foot's lowest point lies within this share of the robot's height of the floor
FREE_FOOT_SHARE = 0.1
#: the supporting leg goes on past side branches lighter than this share of the robot's mass
LEG_SIDE_SHARE = 0.05
#: ... and ends where what lies beyond weighs less than this share (a chain robot: the legs
#: hang from a trunk that carries nothing else, so the mass never splits into branches)
TRUNK_SHARE = 0.5
#: a mirror leg weighs within this factor of the supporting leg
MIRROR_MASS = 2.0


@dataclass(frozen=True)
class Sole:
    """A foot's sole rectangle, fixed in its body frame.

    ``corners`` (4, 3) and ``centre`` (3,) are in the frame of body ``body`` (m); the rectangle
    lies in the floor plane when the robot stands at the zero pose. ``size`` = (length along the
    support frame's x, width along y) at the zero pose, m.
    """

    link: str  #: the link or frame the sole belongs to (support frame or free foot link)
    body: int  #: sescid body that carries it
    centre: np.ndarray
    corners: np.ndarray
    size: tuple[float, float]
    derived: bool  #: True when derived from geometry, False when from the profile
    note: str  #: one line saying where it came from


def lowest_points(
    shape: Shape, rot: np.ndarray, org: np.ndarray, down: np.ndarray | None = None
) -> np.ndarray | None:
    """(k, 3) candidate contact points [m] of a shape in the reference frame in which its body
    has rotation ``rot`` and origin ``org``: every point that can be the shape's extreme along
    ``down`` (unit, default −z); None for an unloaded mesh."""
    t_rot = rot @ shape.pose[:3, :3]
    t_org = org + rot @ shape.pose[:3, 3]
    d = np.array([0.0, 0.0, -1.0]) if down is None else np.asarray(down, dtype=float)
    if shape.kind == BOX:
        h = 0.5 * shape.size
        loc = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * h
    elif shape.kind == CYLINDER:
        rad, length = float(shape.size[0]), float(shape.size[1])
        a = np.linspace(0, 2 * math.pi, 32, endpoint=False)
        ring = np.column_stack([rad * np.cos(a), rad * np.sin(a), np.zeros_like(a)])
        loc = np.vstack([ring + [0, 0, -length / 2], ring + [0, 0, length / 2]])
    elif shape.kind in (SPHERE, CAPSULE):
        rad = float(shape.size[0])
        half = 0.0 if shape.kind == SPHERE else float(shape.size[1]) / 2
        ends = np.array([[0, 0, -half], [0, 0, half]]) @ t_rot.T + t_org
        return ends + rad * d
    elif shape.kind == MESH and shape.vertices is not None:
        return shape.vertices @ rot.T + org
    else:
        return None
    return loc @ t_rot.T + t_org


def body_points(
    shapes: list[Shape], body: int, rot: np.ndarray, org: np.ndarray, down=None
) -> tuple[np.ndarray | None, str]:
    """(points (k, 3) or None, role): ``lowest_points`` of a body's collision shapes, else its
    visual shapes ("collision"/"visual"); (None, "none") without either."""
    for role in ("collision", "visual"):
        pts = [
            p
            for s in shapes
            if s.body == body and s.role == role
            for p in [lowest_points(s, rot, org, down)]
            if p is not None
        ]
        if pts:
            return np.vstack(pts), role
    return None, "none"


def derive_sole(
    link: str,
    body: int,
    shapes: list[Shape],
    rot: np.ndarray,
    org: np.ndarray,
    frame_floor: float | None = None,
) -> Sole | None:
    """The sole of body ``body`` from its shapes (collision, else visual), None without any.

    ``rot``, ``org``: the body's rotation and origin in a z-up reference frame at the zero pose
    (the support frame). ``frame_floor``: the floor height of a sole frame (z = 0 of the
    support frame); the floor is the lower of it and the geometry's lowest point.
    """
    allp, role = body_points(shapes, body, rot, org)
    if allp is None:
        return None
    low = float(allp[:, 2].min())
    touch = allp[allp[:, 2] < low + CONTACT_TOL]
    lo, hi = touch[:, :2].min(axis=0), touch[:, :2].max(axis=0)
    small = hi - lo < MIN_SOLE
    if np.any(small):  # one contact point or line: use the foot's footprint on that side
        lo = np.where(small, allp[:, :2].min(axis=0), lo)
        hi = np.where(small, allp[:, :2].max(axis=0), hi)
    floor = low if frame_floor is None else min(frame_floor, low)
    centre_ref = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, floor])
    hx, hy = (hi - lo) / 2
    corners_ref = centre_ref + np.array(
        [[hx, hy, 0.0], [hx, -hy, 0.0], [-hx, hy, 0.0], [-hx, -hy, 0.0]]
    )
    kinds = sorted({s.kind for s in shapes if s.body == body and s.role == role})
    note = (
        f"sole of '{link}' derived from its {role} {'/'.join(kinds)} geometry: "
        f"{hi[0] - lo[0]:.3f} x {hi[1] - lo[1]:.3f} m, centre ({centre_ref[0]:+.3f}, "
        f"{centre_ref[1]:+.3f}) m, floor {floor:+.3f} m in the support frame"
    )
    return Sole(
        link=link,
        body=body,
        centre=(centre_ref - org) @ rot,
        corners=(corners_ref - org) @ rot,
        size=(float(hi[0] - lo[0]), float(hi[1] - lo[1])),
        derived=True,
        note=note,
    )


def point_sole(link: str, body: int, point: np.ndarray, note: str) -> Sole:
    """A sole shrunk to one point (body frame, m): a foot without geometry."""
    p = np.asarray(point, dtype=float)
    return Sole(link, body, p.copy(), np.tile(p, (4, 1)), (0.0, 0.0), True, note)


def profile_sole(
    link: str, body: int, frame: np.ndarray, size: tuple[float, float], note: str
) -> Sole:
    """A sole rectangle of ``size`` centred on the frame ``frame`` (4×4 in the body frame)."""
    hx, hy = size[0] / 2, size[1] / 2
    local = np.array([[hx, hy, 0.0], [hx, -hy, 0.0], [-hx, hy, 0.0], [-hx, -hy, 0.0]])
    return Sole(
        link=link,
        body=body,
        centre=frame[:3, 3].copy(),
        corners=local @ frame[:3, :3].T + frame[:3, 3],
        size=(float(size[0]), float(size[1])),
        derived=False,
        note=note,
    )


# --- is the support frame level? ----------------------------------------------------------
#: an axis of a frame with its sign, in the order the level check tries them
Axis = Literal["+z", "-z", "+x", "-x", "+y", "-y"]


@dataclass(frozen=True)
class LevelCheck:
    """Whether a frame's z is along the normal of its foot's sole (the foot's largest flat face)."""

    level: bool  #: True when level, or when it cannot be told (``share`` nan)
    share: float  #: footprint under −z / the largest footprint (nan: no flat face to compare)
    frames: list[str] = field(default_factory=list)  #: frames on the foot's body that are level
    up: Axis = "+z"  #: the checked frame's axis nearest the sole's normal (pointing up)


def footprint(shapes: list[Shape], body: int, rot: np.ndarray) -> float:
    """Area [m²] of the bounding rectangle (in the x/y axes of ``rot``) of a body's points within
    ``CONTACT_TOL`` of its lowest along −z of the frame whose rotation in the body is ``rot``."""
    r = np.asarray(rot, dtype=float).T  # body → frame
    pts, _ = body_points(shapes, body, r, np.zeros(3))
    if pts is None:
        return 0.0
    touch = pts[pts[:, 2] < pts[:, 2].min() + CONTACT_TOL]
    ext = touch[:, :2].max(axis=0) - touch[:, :2].min(axis=0)
    return float(ext[0] * ext[1])


_UP: tuple[Axis, ...] = get_args(Axis)  #: the axis of ``rot`` pointing up in each turn


def _turns(rot: np.ndarray) -> list[np.ndarray]:
    """The six frames whose −z is along −z, +z, −x, +x, −y, +y of ``rot`` (right-handed)."""
    x, y, z = rot[:, 0], rot[:, 1], rot[:, 2]
    return [np.column_stack(c) for c in ((x, y, z), (x, -y, -z), (y, z, x), (z, y, -x),
                                         (z, x, y), (x, z, -y))]  # fmt: skip


def largest_footprint(shapes: list[Shape], body: int, rotations: list[np.ndarray]) -> float:
    """Area [m²] of a body's largest flat face: the largest ``footprint`` along ±x, ±y, ±z of
    each rotation (3, 3) in ``rotations`` and of each of its shapes."""
    dirs = [*rotations, *(s.pose[:3, :3] for s in shapes if s.body == body)]
    return max((footprint(shapes, body, t) for r in dirs for t in _turns(r)), default=0.0)


def level_check(
    shapes: list[Shape], body: int, frame: np.ndarray, frames: dict[str, np.ndarray]
) -> LevelCheck:
    """Is the frame ``frame`` (4×4 in body ``body``'s frame) level on that foot's geometry?

    Its −z footprint is compared with the largest footprint along ±x, ±y, ±z of it, of every
    frame in ``frames`` (name → 4×4 in the same body) and of every shape of the body; the
    frames whose own footprint passes are listed as fixes."""
    dirs = [frame[:3, :3], *(f[:3, :3] for f in frames.values())]
    largest = largest_footprint(shapes, body, dirs)
    if not largest > 0:
        return LevelCheck(True, math.nan)
    own = [footprint(shapes, body, t) for t in _turns(frame[:3, :3])]
    share = own[0] / largest
    up = _UP[int(np.argmax(own))]
    good = [
        n for n, f in frames.items() if footprint(shapes, body, f[:3, :3]) >= LEVEL_SHARE * largest
    ]
    return LevelCheck(share >= LEVEL_SHARE, share, good, up)


# --- the free foot -------------------------------------------------------------------------
def subtree_mass(parents: list[int], masses: np.ndarray) -> np.ndarray:
    """(N,) mass [kg] of each body and everything beyond it (away from the support)."""
    sub = np.asarray(masses, dtype=float).copy()
    for i in range(len(parents) - 1, 0, -1):  # children follow their parents
        sub[parents[i]] += sub[i]
    return sub


def _children(parents: list[int]) -> dict[int, list[int]]:
    out: dict[int, list[int]] = {}
    for i, p in enumerate(parents):
        out.setdefault(p, []).append(i)
    return out


def supporting_leg(parents: list[int], masses: np.ndarray) -> tuple[list[int], int]:
    """(bodies of the supporting leg, the body it ends at): from the support body (0) up the
    tree while the other branches are light (each below ``LEG_SIDE_SHARE`` of the mass: a toe,
    a sensor board), to the first body where the mass splits (the pelvis of a humanoid), or
    beyond which less than ``TRUNK_SHARE`` of the mass lies (the trunk of a chain robot: two
    legs and a torso, nothing else)."""
    sub = subtree_mass(parents, masses)
    children = _children(parents)
    total = sub[0] if sub[0] > 0 else 1.0
    leg, cur = [0], 0
    while children.get(cur):
        kids = sorted(children[cur], key=lambda c: (-sub[c], c))
        if any(sub[c] >= LEG_SIDE_SHARE * total for c in kids[1:]):
            break
        if sub[kids[0]] < TRUNK_SHARE * total:
            break
        cur = kids[0]
        leg.append(cur)
    return leg[:-1] if len(leg) > 1 else leg, cur


def beyond_support(parents: list[int], masses: np.ndarray) -> list[int]:
    """The bodies beyond the support foot (its toes): every body below a child of the support
    body (0) other than its heaviest child (the supporting leg's side), that child included;
    empty when the mass splits at the support body (a trunk held in a gantry)."""
    if splits_at_support(parents, masses):
        return []
    sub = subtree_mass(parents, masses)
    kids = _children(parents).get(0, [])
    if len(kids) < 2:
        return []
    leg = min(kids, key=lambda c: (-sub[c], c))
    out: list[int] = []
    for c in kids:
        if c != leg:
            out += [c, *_descendants(parents, c)]
    return sorted(out)


def splits_at_support(parents: list[int], masses: np.ndarray) -> bool:
    """True when the robot's mass splits at its support body (a trunk or pelvis, held in a
    gantry: no foot carries a load), False at the end of a limb (a foot) or for one body."""
    return len(parents) > 1 and supporting_leg(parents, masses)[1] == 0


def mirror_foot(parents: list[int], masses: np.ndarray) -> int | None:
    """The supporting leg's mirror (None without one): of the branches leaving the end of the
    supporting leg, the one whose mass is nearest the supporting leg's (within a factor
    ``MIRROR_MASS``), followed down its heaviest bodies as many joints as the support foot lies
    from the trunk."""
    leg, top = supporting_leg(parents, masses)
    if top == 0:
        return None
    sub = subtree_mass(parents, masses)
    children = _children(parents)
    leg_mass = sub[0] - sub[top]
    kids = [c for c in children.get(top, []) if sub[c] > 0]
    if not kids or not leg_mass > 0:
        return None
    ratio = {c: abs(math.log(sub[c] / leg_mass)) for c in kids}
    best = min(kids, key=lambda c: (ratio[c], c))
    if ratio[best] > math.log(MIRROR_MASS):
        return None
    cur = best
    for _ in range(len(leg) - 1):
        below = sorted(children.get(cur, []), key=lambda c: (-sub[c], c))
        if not below:
            break
        cur = below[0]
    return cur


def _descendants(parents: list[int], top: int) -> list[int]:
    """Bodies below ``top`` in the tree rooted at the support body (``top`` excluded)."""
    below = np.zeros(len(parents), dtype=bool)
    for i in range(len(parents)):  # children follow their parents
        p = parents[i]
        below[i] = p >= 0 and (p == top or below[p])
    return [int(i) for i in np.flatnonzero(below)]


def free_foot(
    parents: list[int],
    masses: np.ndarray,
    shapes: list[Shape],
    zero_pose: tuple[np.ndarray, np.ndarray],
    floor: float,
) -> tuple[int | None, str]:
    """(body index or None, how it was found) of the free foot: of the bodies beyond the end
    of the supporting leg (``supporting_leg``), the one whose geometry (collision, else visual,
    else its origin) reaches lowest at the zero pose, when that lies within
    ``FREE_FOOT_SHARE`` of the robot's height of ``floor`` [m].

    ``zero_pose``: rotations (N, 3, 3) and origins (N, 3) of the bodies at the zero pose in
    the support frame."""
    rot, org = zero_pose
    top = supporting_leg(parents, masses)[1]
    cand = _descendants(parents, top)
    low = np.full(len(parents), np.inf)
    high = np.full(len(parents), -np.inf)
    how: dict[int, str] = {}
    for b in range(len(parents)):
        pts, role = body_points(shapes, b, rot[b], org[b])
        z = org[b, 2:3] if pts is None else pts[:, 2]
        low[b], high[b] = float(z.min()), float(z.max())
        how[b] = "its origin" if pts is None else f"its {role} geometry"
    if not cand:
        return None, "no body beyond the supporting leg"
    height = float(np.max(high) - floor)
    best = min(cand, key=lambda b: (low[b], b))
    gap = low[best] - floor
    if not gap <= FREE_FOOT_SHARE * height:
        mirror = mirror_foot(parents, masses)
        if mirror is not None:
            return mirror, (
                "the supporting leg's mirror: no body beyond the supporting leg comes within "
                f"{FREE_FOOT_SHARE:.0%} of the robot's height of the floor at the zero pose"
            )
        return None, (
            f"no body beyond the supporting leg comes within {FREE_FOOT_SHARE:.0%} of the robot's "
            f"height of the floor at the zero pose (lowest: {gap * 1e3:.0f} mm above it)"
        )
    return best, (
        f"the body beyond the supporting leg whose {how[best].removeprefix('its ')} reaches "
        f"lowest at the zero pose ({gap * 1e3:+.1f} mm from the floor)"
    )
