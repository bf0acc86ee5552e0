"""The body tree: rigid bodies (fixed links merged), re-rooted at the support frame.

A *body* is a set of links welded together by fixed joints. The tree is re-rooted at the body that
holds the support frame (e.g. ``r_sole``), so that every body ``b`` has a frame ``F_b`` whose
rotation and origin relative to the support frame obey

    R_b = R_parent · C_b · Rot(a_b, s_b (k_b q_j + o_b))        o_b = o_parent + R_parent · t_b

with constants ``C_b`` (3×3), ``t_b`` (m), a unit axis ``a_b``, a sign ``s_b = ±1`` (−1 where the
joint is crossed against its URDF direction) and a mimic multiplier/offset ``k_b``, ``o_b``
(1, 0 for an ordinary joint). The frame of a body is placed on the axis of the joint that links it
to its parent, which is what makes the SESC form ``CoM = d + Σ B_i r_i`` hold.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sescid.model.geometry import Shape


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


@dataclass
class RobotModel:
    """The body tree and the map from every model link (or site) to its body frame."""

    name: str
    path: Path  #: the model file (URDF or MJCF)
    format: str  #: "urdf" or "mjcf"
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
