"""The body tree: rigid bodies (fixed links merged), re-rooted at the support frame.

A *body* is a set of links welded together by fixed joints. The tree is re-rooted at the body that
holds the support frame (e.g. ``r_sole``), so that every body ``b`` has a frame ``F_b`` whose
rotation and origin relative to the support frame obey

    R_b = R_parent · C_b · Rot(a_b, s_b (k_b q_j + o_b))        o_b = o_parent + R_parent · t_b

with constants ``C_b`` (3×3), ``t_b`` (m), a unit axis ``a_b``, a sign ``s_b = ±1`` (−1 where the
joint is crossed against its URDF direction) and a mimic multiplier/offset ``k_b``, ``o_b``
(1, 0 for an ordinary joint). The frame of a body is placed on the axis of the joint that links it
to its parent, which is what makes the SESC form ``CoM = d + Σ B_i r_i`` hold.

``reroot`` is the one walk that makes this tree from either file format's ``Graph``: depth-first
from the support frame, edges in file order, with an explicit stack (no recursion limit). A fixed
edge welds its far frame into the current body; a hinge starts a new body, crossed in its file
direction (s = +1) or against it (s = −1, the parent side becomes the child).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from sescid.errors import ModelError
from sescid.model.geometry import Shape
from sescid.model.graph import Edge, Graph, LinkInertial


@dataclass(frozen=True)
class Body:
    """One rigid body of the re-rooted tree; all lengths in metres, mass in kg."""

    name: str  #: URDF name of the body's main link
    links: tuple[str, ...]  #: URDF links welded into this body
    parent: int  #: index of the parent body, −1 for the root (support body)
    joint: int  #: column of q that drives the body's joint, −1 for the root
    joint_name: str  #: URDF name of that joint ("" for the root)
    sign: float  #: +1 when the joint is crossed in its URDF direction, −1 against it
    multiplier: float  #: mimic multiplier (1 for an ordinary joint)
    offset: float  #: mimic offset in rad (0 for an ordinary joint)
    axis: np.ndarray  #: (3,) unit joint axis in the body frame
    rot_const: np.ndarray  #: (3, 3) constant rotation C_b from the parent frame
    trans_const: np.ndarray  #: (3,) constant translation t_b in the parent frame, m
    mass: float  #: kg
    com: np.ndarray  #: (3,) CoM in the body frame, m (zeros when massless)
    #: a massless frame that the model file cannot give mass (between two hinges of one MJCF
    #: body): the consistent step keeps its mass and first moment at 0
    frame_only: bool = False


#: the model file formats sescid reads and exports
ModelFormat = Literal["urdf", "mjcf"]


@dataclass
class RobotModel:
    """The body tree and the map from every model link (or site) to its body frame."""

    name: str
    path: Path  #: the model file (URDF or MJCF)
    format: ModelFormat
    support: str
    joint_names: list[str]
    joint_limits: np.ndarray  #: (nq, 2) lower/upper in rad (±inf for continuous joints)
    bodies: list[Body]
    #: model link/site name → (body index, 4×4 transform of the link frame in the body frame)
    link_frames: dict[str, tuple[int, np.ndarray]]
    root_rotation: np.ndarray  #: (3, 3) rotation of the root body in the support frame
    root_origin: np.ndarray  #: (3,) origin of the root body in the support frame, m (= d)
    model_root: str = ""  #: the model file's own root link
    shapes: list[Shape] = field(default_factory=list)  #: collision/visual shapes, body frames
    notes: list[str] = field(default_factory=list)  #: what loading changed or ignored
    #: model link (or MJCF body) name → its inertial as the file gives it (links with one)
    inertials: dict[str, LinkInertial] = field(default_factory=dict)


def rot_axis(axis: np.ndarray, angle: float) -> np.ndarray:
    """(3, 3) rotation by ``angle`` [rad] about the unit ``axis`` (Rodrigues)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


def inv_transform(t: np.ndarray) -> np.ndarray:
    """Inverse of a (4, 4) rigid transform."""
    out = np.eye(4)
    out[:3, :3] = t[:3, :3].T
    out[:3, 3] = -t[:3, :3].T @ t[:3, 3]
    return out


@dataclass
class _Row:
    """A body under construction: its frames and the edge that reached it."""

    links: list[str]
    parent: int
    edge: Edge | None
    sign: float
    axis: np.ndarray
    rot: np.ndarray
    trans: np.ndarray


def _walk(graph: Graph, support: str) -> tuple[list[_Row], dict[str, tuple[int, np.ndarray]]]:
    """Bodies (rows) and every frame's (body, 4×4 transform in the body frame), from the
    support frame outwards (see the module doc)."""
    adj: dict[str, list[Edge]] = {name: [] for name in graph.frames}
    for e in graph.edges:
        adj[e.parent].append(e)
        adj[e.child].append(e)
    frames: dict[str, tuple[int, np.ndarray]] = {support: (0, np.eye(4))}
    rows = [_Row([support], -1, None, 1.0, np.array([0.0, 0.0, 1.0]), np.eye(3), np.zeros(3))]
    stack: list[tuple[str, Edge | None, Iterator[Edge]]] = [(support, None, iter(adj[support]))]
    while stack:
        node, via, todo = stack[-1]
        e = next(todo, None)
        if e is None:
            stack.pop()
            continue
        if e is via:
            continue
        b, x = frames[node]
        down = e.parent == node
        other = e.child if down else e.parent
        if other in frames:
            raise ModelError(f"{graph.source}: the joints form a loop through '{other}'")
        if e.drive is None:  # fixed: the far frame joins this body
            frames[other] = (b, x @ (e.origin if down else inv_transform(e.origin)))
            rows[b].links.append(other)
        else:  # a hinge starts a new body whose frame sits on the joint axis
            if down:  # F_new = X · O · Rot(a, θ); the child frame is P in F_new
                t = x @ e.origin
                x_other, sign = np.eye(4) if e.after is None else e.after, 1.0
            else:  # F_new = X · P⁻¹ · Rot(a, −θ); the parent frame is O⁻¹ in F_new
                t = x if e.after is None else x @ inv_transform(e.after)
                x_other, sign = inv_transform(e.origin), -1.0
            assert e.axis is not None
            rows.append(_Row([other], b, e, sign, e.axis, t[:3, :3].copy(), t[:3, 3].copy()))
            frames[other] = (len(rows) - 1, x_other)
        stack.append((other, e, iter(adj[other])))
    if len(frames) < len(graph.frames):
        lost = [n for n in graph.frames if n not in frames]
        raise ModelError(
            f"{graph.source}: {len(lost)} frame(s) not connected to the support "
            f"'{support}' (e.g. '{lost[0]}')"
        )
    return rows, frames


def _root_name(graph: Graph, links: list[str], support: str) -> str:
    """A body's name: its first frame that no fixed edge hangs from a parent — the link the
    model file itself makes the top of the merged group (a moving joint's child, or the model's
    root), whichever way the tree is rooted (Romeo re-rooted at a sole: ``base_link``, not the
    ``body`` link fixed below it); ``support`` when every frame hangs by a fixed edge."""
    fixed_child = {e.child for e in graph.edges if e.drive is None}
    return next((lk for lk in links if lk not in fixed_child), support)


def reroot(graph: Graph, support: str) -> tuple[list[Body], dict[str, tuple[int, np.ndarray]]]:
    """The body tree rooted at the frame ``support``, and every frame's (body index, 4×4
    transform of the frame in the body frame); fixed edges merged (masses and CoMs summed)."""
    rows, frames = _walk(graph, support)
    bodies = []
    for i, row in enumerate(rows):
        mass, first = 0.0, np.zeros(3)
        for lk in row.links:
            inertial = graph.frames[lk].inertial
            if inertial is not None and inertial.mass > 0:
                x = frames[lk][1]
                first += inertial.mass * (x[:3, :3] @ inertial.com + x[:3, 3])
                mass += inertial.mass
        e = row.edge
        jcol, mult, off = (-1, 1.0, 0.0) if e is None or e.drive is None else e.drive
        bodies.append(
            Body(
                name=_root_name(graph, row.links, support if i == 0 else row.links[0]),
                links=tuple(row.links),
                parent=row.parent,
                joint=jcol,
                joint_name="" if e is None else e.name,
                sign=row.sign,
                multiplier=mult,
                offset=off,
                axis=row.axis,
                rot_const=row.rot,
                trans_const=row.trans,
                mass=mass,
                com=first / mass if mass > 0 else np.zeros(3),
                frame_only=i > 0 and all(graph.frames[lk].frame_only for lk in row.links),
            )
        )
    return bodies, frames


def rooted_model(
    graph: Graph, support: str, shapes: Callable[[dict], list[Shape]], **fields: Any
) -> RobotModel:
    """The model of ``graph`` rooted at the frame ``support`` (``reroot``; the root body at the
    support frame's origin, unrotated), with the file's inertials; ``shapes(link_frames)`` its
    shapes in body frames; ``fields``: the file's name, format, joints, limits, root, notes.
    ModelError for a robot without mass."""
    bodies, link_frames = reroot(graph, support)
    if not sum(b.mass for b in bodies) > 0:
        raise ModelError(f"{graph.source}: the robot has no mass (no inertial with mass > 0)")
    return RobotModel(
        path=Path(graph.source).resolve(),
        support=support,
        bodies=bodies,
        link_frames=link_frames,
        root_rotation=np.eye(3),
        root_origin=np.zeros(3),
        shapes=shapes(link_frames),
        inertials={n: f.inertial for n, f in graph.frames.items() if f.inertial is not None},
        **fields,
    )
