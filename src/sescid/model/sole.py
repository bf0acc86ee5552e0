"""Soles for any robot: the floor plane and the sole rectangle of a foot, from a profile or
derived from the foot's lowest collision geometry.

The support frame's z axis is taken as vertical. A foot's sole is derived from its body's
collision shapes (visual ones when it has none) at the zero pose, in the support frame's
orientation: the lowest points of every box (corners), cylinder (rim), sphere and capsule
(bottom points) and mesh (hull vertices) are collected, the floor is the lowest of them, and the
rectangle is the x/y extent of the points within ``CONTACT_TOL`` of it. A foot whose frame is a
sole (its geometry at or above z = 0) keeps z = 0 as the floor; a foot frame above the geometry
(G1 stands on its ankle frame) gets the derived floor below it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from sescid.model.geometry import BOX, CAPSULE, CYLINDER, MESH, SPHERE, Shape

CONTACT_TOL = 0.003  #: m, points this close to the lowest one touch the floor
MIN_SOLE = 0.01  #: m, a derived side shorter than this is widened to the foot's x/y extent

_SIDES = [
    (r"^(.*)_R$", r"\1_L"),
    (r"^(.*)_r$", r"\1_l"),
    (r"^r_(.*)$", r"l_\1"),
    (r"^R_(.*)$", r"L_\1"),
    (r"^R([A-Z].*)$", r"L\1"),
    (r"^(.*)right(.*)$", r"\1left\2"),
    (r"^(.*)Right(.*)$", r"\1Left\2"),
    (r"^(.*)_L$", r"\1_R"),
    (r"^(.*)_l$", r"\1_r"),
    (r"^l_(.*)$", r"r_\1"),
    (r"^L_(.*)$", r"R_\1"),
    (r"^L([A-Z].*)$", r"R\1"),
    (r"^(.*)left(.*)$", r"\1right\2"),
    (r"^(.*)Left(.*)$", r"\1Right\2"),
]


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


def mirror_link(name: str, names) -> str | None:
    """The other side's link (``r_sole`` → ``l_sole``, ``right_…`` → ``left_…``, and back)."""
    pool = set(names)
    for pat, rep in _SIDES:
        other = re.sub(pat, rep, name) if re.match(pat, name) else name
        if other != name and other in pool:
            return other
    return None


def lowest_points(shape: Shape, rot: np.ndarray, org: np.ndarray) -> np.ndarray | None:
    """(k, 3) candidate floor-contact points [m] of a shape in the reference frame in which
    its body has rotation ``rot`` and origin ``org`` (z up); None for an unloaded mesh."""
    t_rot = rot @ shape.pose[:3, :3]
    t_org = org + rot @ shape.pose[:3, 3]
    down = np.array([0.0, 0.0, 1.0])
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
        return ends - rad * down
    elif shape.kind == MESH and shape.vertices is not None:
        return shape.vertices @ rot.T + org
    else:
        return None
    return loc @ t_rot.T + t_org


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
    for role in ("collision", "visual"):
        pts = [
            p
            for s in shapes
            if s.body == body and s.role == role
            for p in [lowest_points(s, rot, org)]
            if p is not None
        ]
        if pts:
            break
    else:
        return None
    allp = np.vstack(pts)
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
