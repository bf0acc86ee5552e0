"""The format-neutral graph a model file is read into, before re-rooting: frames and edges.

A *frame* is a URDF link, an MJCF body (or a massless frame between two hinges of one MJCF
body) or an MJCF site; it may carry an inertial (mass, CoM, inertia) in its own axes. An *edge*
joins a parent frame to a child frame, as the file writes it:

    F_child = F_parent · O · Rot(a, θ) · P        θ = k q[col] + o        (a hinge)
    F_child = F_parent · O                                                (fixed)

``O`` is the joint frame in the parent frame, ``a`` a unit axis in the joint frame and ``P`` the
child frame in the rotated joint frame: the identity for URDF (a link frame sits on its joint),
``Trans(−pos)`` for an MJCF hinge whose ``pos`` is off the body origin. ``sescid.model.tree.reroot``
turns the graph into the body tree rooted at the support frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class LinkInertial:
    """What a model file says of one link's mass distribution (SI units)."""

    mass: float  #: kg (≥ 0, finite)
    #: (4, 4) the inertial frame in the link frame: origin = CoM, m; axes those of ``inertia``
    frame: np.ndarray
    inertia: np.ndarray | None  #: (3, 3) about the CoM in the inertial frame's axes, kg·m²

    @property
    def com(self) -> np.ndarray:
        """(3,) CoM in the link frame, m."""
        return self.frame[:3, 3]


@dataclass(frozen=True)
class Frame:
    """A node of the graph: a link, body or site, with its inertial if it has one."""

    name: str
    inertial: LinkInertial | None = None
    #: a massless frame the model file cannot give mass (between two hinges of one MJCF body)
    frame_only: bool = False

    @property
    def mass(self) -> float:
        """Mass in kg (0 without an inertial)."""
        return 0.0 if self.inertial is None else self.inertial.mass


@dataclass(frozen=True)
class Edge:
    """A joint of the file from ``parent`` to ``child`` (see the module doc for O, a, P)."""

    name: str  #: joint name ("" for an MJCF weld or site)
    parent: str
    child: str
    origin: np.ndarray  #: (4, 4) O, m
    after: np.ndarray | None = None  #: (4, 4) P, m; None is the identity (URDF)
    axis: np.ndarray | None = None  #: (3,) unit hinge axis; None for a fixed edge
    #: (column of q, multiplier k, offset o [rad]) of a hinge; None for a fixed edge
    drive: tuple[int, float, float] | None = None

    @property
    def fixed(self) -> bool:
        """True for a rigid edge (no joint coordinate)."""
        return self.drive is None


@dataclass
class Graph:
    """Frames (by name, in file order) and edges of one model file."""

    source: Path  #: the model file, named in error messages
    frames: dict[str, Frame]
    edges: list[Edge]
