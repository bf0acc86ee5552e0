"""Collision and visual shapes of a robot model, parsed once with the model, in body frames.

A ``Shape`` is a box, cylinder, capsule (MJCF), sphere or mesh placed by a 4×4 transform in its
*sescid body* frame (links welded by fixed joints share a body). Consumers: CoM boxes of the
consistent-mass step (``shape_hull``) and self-collision capsules of pose planning.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

#: the kinds of collision/visual shape a model file gives
ShapeKind = Literal["box", "cylinder", "capsule", "sphere", "mesh"]
BOX: ShapeKind = "box"
CYLINDER: ShapeKind = "cylinder"
CAPSULE: ShapeKind = "capsule"
SPHERE: ShapeKind = "sphere"
MESH: ShapeKind = "mesh"
#: what a shape is for in the model file
ShapeRole = Literal["collision", "visual"]


@dataclass(frozen=True)
class Shape:
    """One geometric primitive of a link, in the frame of the body that holds the link."""

    kind: ShapeKind
    role: ShapeRole
    body: int  #: index of the sescid body
    link: str  #: model link (URDF link / MJCF body) it belongs to
    pose: np.ndarray  #: (4, 4) shape frame in the body frame, m
    #: box (3,) full sizes; cylinder (radius, length); capsule (radius, length of the segment
    #: between the centres of its end caps, along z); sphere (radius,); m
    size: np.ndarray
    mesh: str = ""  #: mesh file name as written in the model (mesh shapes)
    scale: np.ndarray = field(default_factory=lambda: np.ones(3))  #: mesh scale
    vertices: np.ndarray | None = None  #: (k, 3) mesh vertices in the body frame, m, if loaded


def shape_hull(shape: Shape) -> tuple[np.ndarray, np.ndarray] | None:
    """Axis-aligned hull (lo, hi) (3,), (3,) in the body frame; None for an unloaded mesh."""
    rot, org = shape.pose[:3, :3], shape.pose[:3, 3]
    if shape.kind == BOX:
        half = np.abs(rot) @ (0.5 * shape.size)
    elif shape.kind == CYLINDER:
        rad, length = float(shape.size[0]), float(shape.size[1])
        ax = rot[:, 2]
        half = np.abs(ax) * length / 2 + rad * np.sqrt(np.clip(1 - ax**2, 0, None))
    elif shape.kind == CAPSULE:
        rad, length = float(shape.size[0]), float(shape.size[1])
        half = np.abs(rot[:, 2]) * length / 2 + rad
    elif shape.kind == SPHERE:
        half = np.full(3, float(shape.size[0]))
    elif shape.vertices is not None and len(shape.vertices):
        return shape.vertices.min(axis=0), shape.vertices.max(axis=0)
    else:
        return None
    return org - half, org + half


def body_hulls(shapes: list[Shape], role: ShapeRole) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Per body index, the axis-aligned hull of its shapes of one role (body frame, m)."""
    out: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for s in shapes:
        if s.role != role:
            continue
        hull = shape_hull(s)
        if hull is None:
            continue
        lo, hi = out.get(s.body, hull)
        out[s.body] = (np.minimum(lo, hull[0]), np.maximum(hi, hull[1]))
    return out
