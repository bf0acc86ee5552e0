"""The typed records of a parsed URDF (``urdf_parse`` fills them): the file's numbers as written.

Field names follow yourdfpy's, the tests' oracle for the parser.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Geometry:
    """One of box (size), cylinder (radius, length), sphere (radius) or mesh (file, scale)."""

    box: UrdfBox | None = None
    cylinder: Cylinder | None = None
    sphere: Sphere | None = None
    mesh: Mesh | None = None


@dataclass
class UrdfBox:
    """A box: full sizes (3,), m."""

    size: np.ndarray


@dataclass
class Cylinder:
    """A cylinder along z: radius and length, m."""

    radius: float
    length: float


@dataclass
class Sphere:
    """A sphere: radius, m."""

    radius: float


@dataclass
class Mesh:
    """A mesh file and its scale."""

    filename: str | None
    scale: float | np.ndarray | None


@dataclass
class Element:
    """A <visual> or <collision>: geometry placed by an origin in the link frame."""

    geometry: Geometry | None
    origin: np.ndarray | None


@dataclass
class Inertial:
    """An <inertial>: CoM frame (4, 4), mass kg, inertia."""

    origin: np.ndarray | None
    mass: float | None
    inertia: np.ndarray | None  #: (3, 3) about the CoM, in the inertial frame


@dataclass
class Link:
    """A <link>: its inertial and its visual/collision elements."""

    name: str
    inertial: Inertial | None
    visuals: list[Element] = field(default_factory=list)
    collisions: list[Element] = field(default_factory=list)


@dataclass
class Limit:
    """A joint's <limit>: lower/upper in rad (None where absent)."""

    lower: float | None
    upper: float | None


@dataclass
class Mimic:
    """A <mimic>: q = multiplier · q_master + offset."""

    joint: str | None
    multiplier: float
    offset: float


@dataclass
class Joint:
    """A <joint>: type, parent/child links, origin (4, 4), unit axis, limit, mimic."""

    name: str
    type: str | None
    parent: str | None
    child: str | None
    origin: np.ndarray | None
    axis: np.ndarray
    limit: Limit | None
    mimic: Mimic | None


@dataclass
class UrdfRobot:
    """The <robot>: its name, links and joints in file order."""

    name: str
    links: list[Link]
    joints: list[Joint]


@dataclass
class Urdf:
    """A parsed URDF file (``.robot`` holds its links and joints, in file order)."""

    robot: UrdfRobot
