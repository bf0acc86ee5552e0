"""URDF → tree of rigid bodies (fixed links merged), re-rooted at the support frame.

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
import sys
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree

import numpy as np

from .errors import SescidError

_SUPPORTED = {"revolute", "continuous", "fixed"}


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


@dataclass
class RobotModel:
    """The body tree and the map from every URDF link to its body frame."""

    name: str
    urdf_path: Path
    support: str
    joint_names: list[str]
    joint_limits: np.ndarray  #: (nq, 2) lower/upper in rad (±inf for continuous joints)
    bodies: list[Body]
    #: URDF link name → (body index, 4×4 transform of the link frame in the body frame)
    link_frames: dict[str, tuple[int, np.ndarray]]
    root_rotation: np.ndarray  #: (3, 3) rotation of the root body in the support frame
    root_origin: np.ndarray  #: (3,) origin of the root body in the support frame, m (= d)
    urdf_root: str = ""


def _rot_axis(axis: np.ndarray, angle: float) -> np.ndarray:
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


def _inv(t: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = t[:3, :3].T
    out[:3, 3] = -t[:3, :3].T @ t[:3, 3]
    return out


def _load_urdf(path: Path):
    import yourdfpy  # a maintained URDF library; imported here to keep start-up light

    if not path.is_file():
        raise SescidError(f"{path}: URDF file not found")
    try:  # strict XML first: yourdfpy would otherwise recover silently from broken XML
        root = ElementTree.parse(path).getroot()
    except (ElementTree.ParseError, OSError, UnicodeDecodeError) as exc:
        raise SescidError(f"{path}: malformed URDF (XML: {exc})") from None
    if root.tag != "robot":
        raise SescidError(f"{path}: malformed URDF (root element <{root.tag}>, not <robot>)")
    try:
        urdf = yourdfpy.URDF.load(
            str(path),
            build_scene_graph=False,
            build_collision_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
        )
    except Exception as exc:  # lxml / parser errors: one line, naming the file
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SescidError(f"{path}: malformed URDF ({msg})") from None
    if urdf.robot is None or not urdf.robot.links:
        raise SescidError(f"{path}: malformed URDF (no links)")
    return urdf


def build_model(path: str | Path, support: str) -> RobotModel:
    """Parse a URDF and build the body tree rooted at the link ``support``."""
    path = Path(path)
    urdf = _load_urdf(path)
    robot = urdf.robot
    links = {lk.name: lk for lk in robot.links}
    joints = list(robot.joints)
    if support not in links:
        raise SescidError(
            f"{path}: unknown support link '{support}' (links: {', '.join(sorted(links)[:12])}"
            + (", …)" if len(links) > 12 else ")")
        )

    child_joint = {}
    for j in joints:
        if j.parent not in links or j.child not in links:
            raise SescidError(f"{path}: joint '{j.name}' names a link that does not exist")
        if j.child in child_joint:
            raise SescidError(f"{path}: link '{j.child}' has two parent joints")
        child_joint[j.child] = j
    roots = [name for name in links if name not in child_joint]
    if len(roots) != 1:
        raise SescidError(f"{path}: the links do not form one tree (roots: {roots})")

    for j in joints:
        if j.type not in _SUPPORTED:
            raise SescidError(
                f"{path}: joint '{j.name}' has type '{j.type}'; only revolute, continuous and "
                "fixed joints are supported (the SESC form needs rotations only)"
            )
        if j.mimic is not None and j.type == "fixed":
            raise SescidError(f"{path}: fixed joint '{j.name}' cannot mimic")

    # Independent joint coordinates, in URDF order; mimic joints follow their master.
    movable = [j for j in joints if j.type != "fixed"]
    joint_names = [j.name for j in movable if j.mimic is None]
    col = {name: i for i, name in enumerate(joint_names)}
    by_name = {j.name: j for j in joints}
    drive: dict[str, tuple[int, float, float]] = {}
    for j in movable:
        if j.mimic is None:
            drive[j.name] = (col[j.name], 1.0, 0.0)
            continue
        master = by_name.get(j.mimic.joint)
        if master is None or master.type == "fixed" or master.mimic is not None:
            raise SescidError(
                f"{path}: joint '{j.name}' mimics '{j.mimic.joint}', which is not an "
                "independent revolute/continuous joint"
            )
        mult = 1.0 if j.mimic.multiplier is None else float(j.mimic.multiplier)
        off = 0.0 if j.mimic.offset is None else float(j.mimic.offset)
        drive[j.name] = (col[master.name], mult, off)

    limits = np.empty((len(joint_names), 2))
    for name, i in col.items():
        j = by_name[name]
        lim = j.limit
        if j.type == "continuous" or lim is None or lim.lower is None or lim.upper is None:
            limits[i] = (-np.inf, np.inf)
        else:
            limits[i] = (float(lim.lower), float(lim.upper))

    # Undirected adjacency between links, then a walk from the support link.
    adj: dict[str, list] = {name: [] for name in links}
    for j in joints:
        adj[j.parent].append(j)
        adj[j.child].append(j)

    def origin(j) -> np.ndarray:
        return np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=float)

    def axis_of(j) -> np.ndarray:
        a = np.array([1.0, 0.0, 0.0]) if j.axis is None else np.asarray(j.axis, dtype=float)
        norm = np.linalg.norm(a)
        if not np.isfinite(norm) or norm < 1e-12:
            raise SescidError(f"{path}: joint '{j.name}' has a zero or invalid axis")
        return a / norm

    # Each link gets: its body index and X = transform of the link's URDF frame in F_body.
    link_frames: dict[str, tuple[int, np.ndarray]] = {}
    body_rows: list[dict] = []
    support_body = {
        "name": support,
        "links": [],
        "parent": -1,
        "joint_urdf": None,
        "sign": 1.0,
        "axis": np.array([0.0, 0.0, 1.0]),
        "C": np.eye(3),
        "t": np.zeros(3),
    }
    body_rows.append(support_body)
    link_frames[support] = (0, np.eye(4))
    support_body["links"].append(support)

    def visit(link: str, via) -> None:  # pre-order, children in URDF order
        b, x_link = link_frames[link]
        for j in adj[link]:
            if j is via:
                continue
            downward = j.parent == link
            other = j.child if downward else j.parent
            if j.type == "fixed":
                t_other = x_link @ (origin(j) if downward else _inv(origin(j)))
                link_frames[other] = (b, t_other)
                body_rows[b]["links"].append(other)
                visit(other, j)
                continue
            # A movable joint starts a new body whose frame sits on the joint axis.
            if downward:  # F_new = X_link · O_j · Rot(a, q); the link frame is F_new itself
                t_const = x_link @ origin(j)
                x_other = np.eye(4)
                sign = 1.0
            else:  # F_new = X_link · Rot(a, −q); the parent link frame is F_new · O_j⁻¹
                t_const = x_link
                x_other = _inv(origin(j))
                sign = -1.0
            body_rows.append(
                {
                    "name": other,
                    "links": [other],
                    "parent": b,
                    "joint_urdf": j,
                    "sign": sign,
                    "axis": axis_of(j),
                    "C": t_const[:3, :3].copy(),
                    "t": t_const[:3, 3].copy(),
                }
            )
            link_frames[other] = (len(body_rows) - 1, x_other)
            visit(other, j)

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 4 * len(links) + 100))
    try:
        visit(support, None)
    finally:
        sys.setrecursionlimit(limit)

    # The support body is named after the link its movable joint (or the URDF root) gives it.
    body_rows[0]["name"] = _main_link(body_rows[0]["links"], child_joint, support)

    bodies: list[Body] = []
    for i, row in enumerate(body_rows):
        mass = 0.0
        first = np.zeros(3)
        for lk in row["links"]:
            inertial = links[lk].inertial
            if inertial is None or inertial.mass is None or inertial.mass == 0:
                continue
            m = float(inertial.mass)
            if not np.isfinite(m) or m < 0:
                raise SescidError(f"{path}: link '{lk}' has an invalid mass {inertial.mass}")
            c_link = np.zeros(3) if inertial.origin is None else np.asarray(inertial.origin)[:3, 3]
            x = link_frames[lk][1]
            first += m * (x[:3, :3] @ c_link + x[:3, 3])
            mass += m
        com = first / mass if mass > 0 else np.zeros(3)
        j = row["joint_urdf"]
        if j is None:
            jcol, mult, off, jname = -1, 1.0, 0.0, ""
        else:
            jcol, mult, off = drive[j.name]
            jname = j.name
        bodies.append(
            Body(
                name=row["name"],
                links=tuple(row["links"]),
                parent=row["parent"] if i else -1,
                joint=jcol,
                joint_name=jname,
                sign=row["sign"],
                multiplier=mult,
                offset=off,
                axis=row["axis"],
                rot_const=row["C"],
                trans_const=row["t"],
                mass=mass,
                com=com,
            )
        )
    total = sum(b.mass for b in bodies)
    if not total > 0:
        raise SescidError(f"{path}: the robot has no mass (no <inertial> with mass > 0)")

    # Support frame = world; the root body frame is the support link frame itself (X = I),
    # so its rotation/origin in the support frame are the identity.
    return RobotModel(
        name=robot.name or path.stem,
        urdf_path=path.resolve(),
        support=support,
        joint_names=joint_names,
        joint_limits=limits,
        bodies=bodies,
        link_frames=link_frames,
        root_rotation=np.eye(3),
        root_origin=np.zeros(3),
        urdf_root=roots[0],
    )


def _main_link(root_links: list[str], child_joint: dict, default: str) -> str:
    """Name the support body after its link that a movable joint (or nothing) attaches."""
    for lk in root_links:
        j = child_joint.get(lk)
        if j is None or j.type != "fixed":
            return lk
    return default
