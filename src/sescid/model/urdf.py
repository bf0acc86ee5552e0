"""URDF → ``RobotModel``: parse, check, merge fixed links, re-root at the support link.

Parsing is strict XML (ElementTree) into small typed records holding just what statics, the
shapes and the physics bench use (origins as 4×4 transforms, URDF's fixed-axis roll-pitch-yaw);
no URDF library is imported, so loading a robot costs milliseconds (yourdfpy, which pulls in
trimesh, is the tests' oracle for this parser). Real-world quirks are accepted with a note in
``RobotModel.notes``: a ``<mimic>`` left on a fixed joint is ignored; a ``floating`` joint that
attaches the whole robot to a world link is dropped (the robot is re-rooted at its support
anyway). Everything else that statics cannot use
(prismatic, planar joints; non-finite numbers; duplicate names; lower > upper) is a one-line
``ModelError`` naming the file and the element.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import numpy as np

from sescid.errors import ModelError
from sescid.model.geometry import BOX, CYLINDER, MESH, SPHERE, Shape
from sescid.model.tree import Body, RobotModel, inv_transform

_SUPPORTED = {"revolute", "continuous", "fixed"}


@dataclass
class Geometry:
    """One of box (size), cylinder (radius, length), sphere (radius) or mesh (file, scale)."""

    box: Box | None = None
    cylinder: Cylinder | None = None
    sphere: Sphere | None = None
    mesh: Mesh | None = None


@dataclass
class Box:
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
class Robot:
    """The <robot>: its name, links and joints in file order."""

    name: str
    links: list[Link]
    joints: list[Joint]


@dataclass
class Urdf:
    """A parsed URDF file (``.robot`` holds its links and joints, in file order)."""

    robot: Robot


def _floats(text: str) -> list[float]:
    return [float(v) for v in text.replace(",", " ").split()]


def _opt_float(text: str | None) -> float | None:
    return None if text is None else float(text)


def _rpy_matrix(r: float, p: float, y: float) -> np.ndarray:
    """Rz(y)·Ry(p)·Rx(r): URDF's roll-pitch-yaw about fixed axes."""
    si, sj, sk = math.sin(r), math.sin(p), math.sin(y)
    ci, cj, ck = math.cos(r), math.cos(p), math.cos(y)
    cc, cs, sc, ss = ci * ck, ci * sk, si * ck, si * sk
    return np.array(
        [
            [cj * ck, sj * sc - cs, sj * cc + ss],
            [cj * sk, sj * ss + cc, sj * cs - sc],
            [-sj, cj * si, cj * ci],
        ]
    )


def _origin_el(el: ElementTree.Element | None) -> np.ndarray | None:
    if el is None:
        return None
    out = np.eye(4)
    out[:3, 3] = _floats(el.get("xyz", "0 0 0"))
    out[:3, :3] = _rpy_matrix(*_floats(el.get("rpy", "0 0 0")))
    return out


def _geometry_el(el: ElementTree.Element | None) -> Geometry | None:
    if el is None:
        return None
    if len(el) == 0:
        raise ValueError("<geometry> has no shape")
    g, shape = Geometry(), el[0]
    if shape.tag == "box":
        g.box = Box(np.array(_floats(shape.attrib["size"]), dtype=float))
    elif shape.tag == "cylinder":
        g.cylinder = Cylinder(float(shape.attrib["radius"]), float(shape.attrib["length"]))
    elif shape.tag == "sphere":
        g.sphere = Sphere(float(shape.attrib["radius"]))
    elif shape.tag == "mesh":
        scale: float | np.ndarray | None = None
        if "scale" in shape.attrib:
            s = _floats(shape.attrib["scale"])
            scale = None if not s else s[0] if len(s) == 1 else np.array(s)
        g.mesh = Mesh(shape.get("filename"), scale)
    else:
        raise ValueError(f"unknown geometry <{shape.tag}>")
    return g


def _inertial_el(el: ElementTree.Element | None) -> Inertial | None:
    if el is None:
        return None
    m, i = el.find("mass"), el.find("inertia")
    inertia = None
    if i is not None:
        xx, yy, zz = (float(i.get(k, 1.0)) for k in ("ixx", "iyy", "izz"))
        xy, xz, yz = (float(i.get(k, 0.0)) for k in ("ixy", "ixz", "iyz"))
        inertia = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    mass = None if m is None else float(m.get("value", 0.0))
    return Inertial(_origin_el(el.find("origin")), mass, inertia)


def _link_el(el: ElementTree.Element) -> Link:
    link = Link(el.attrib["name"], _inertial_el(el.find("inertial")))
    for kind, items in (("visual", link.visuals), ("collision", link.collisions)):
        for v in el.findall(kind):
            items.append(Element(_geometry_el(v.find("geometry")), _origin_el(v.find("origin"))))
    return link


def _joint_el(el: ElementTree.Element) -> Joint:
    parent, child = el.find("parent"), el.find("child")
    axis, lim, mimic = el.find("axis"), el.find("limit"), el.find("mimic")
    return Joint(
        name=el.attrib["name"],
        type=el.get("type"),
        parent=None if parent is None else parent.get("link"),
        child=None if child is None else child.get("link"),
        origin=_origin_el(el.find("origin")),
        axis=np.array(_floats("1 0 0" if axis is None else axis.get("xyz", "1 0 0"))),
        limit=None
        if lim is None
        else Limit(_opt_float(lim.get("lower")), _opt_float(lim.get("upper"))),
        mimic=None
        if mimic is None
        else Mimic(
            mimic.get("joint"), float(mimic.get("multiplier", 1.0)), float(mimic.get("offset", 0.0))
        ),
    )


def _check_xml(path: Path) -> ElementTree.Element:
    if not path.is_file():
        raise ModelError(f"{path}: URDF file not found")
    try:
        root = ElementTree.parse(path).getroot()
    except (ElementTree.ParseError, OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"{path}: malformed URDF (XML: {exc})") from None
    if root.tag != "robot":
        raise ModelError(f"{path}: malformed URDF (root element <{root.tag}>, not <robot>)")
    for kind in ("link", "joint"):
        seen: set[str] = set()
        for el in root.findall(kind):
            name = el.get("name", "")
            if name in seen:
                raise ModelError(f"{path}: two <{kind}> elements are named '{name}'")
            seen.add(name)
    return root


def load_urdf(path: Path) -> Urdf:
    """The parsed URDF (links, joints; no meshes loaded); ModelError on malformed files."""
    root = _check_xml(path)
    try:
        robot = Robot(
            name=root.attrib["name"],
            links=[_link_el(el) for el in root.findall("link")],
            joints=[_joint_el(el) for el in root.findall("joint")],
        )
    except KeyError as exc:
        raise ModelError(f"{path}: malformed URDF (missing attribute {exc})") from None
    except (ValueError, TypeError) as exc:
        raise ModelError(f"{path}: malformed URDF ({exc})") from None
    if not robot.links:
        raise ModelError(f"{path}: malformed URDF (no links)")
    return Urdf(robot)


def _finite(path: Path, what: str, values: Any) -> np.ndarray:
    arr = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{path}: {what} has a non-finite number")
    return arr


def _origin(path: Path, j: Any) -> np.ndarray:
    if j.origin is None:
        return np.eye(4)
    return _finite(path, f"joint '{j.name}' origin", j.origin)


def _axis(path: Path, j: Any) -> np.ndarray:
    try:
        a = np.array([1.0, 0.0, 0.0]) if j.axis is None else np.asarray(j.axis, dtype=float)
    except (TypeError, ValueError):
        a = np.zeros(0)
    norm = float(np.linalg.norm(a)) if a.shape == (3,) else math.nan
    if not math.isfinite(norm) or norm < 1e-12:
        raise ModelError(
            f"{path}: joint '{j.name}' has a zero or invalid axis (expected 3 numbers)"
        )
    return a / norm


def _drop_floating_root(path: Path, links: dict, joints: list, notes: list[str]) -> list:
    """Drop a floating/planar joint that hangs the whole robot from a massless world link."""
    out = []
    for j in joints:
        if j.type == "floating":
            parent = links.get(j.parent)
            has_parent = any(k.child == j.parent for k in joints)
            massless = parent is None or parent.inertial is None or not parent.inertial.mass
            if not has_parent and massless:
                notes.append(
                    f"floating root joint '{j.name}' dropped (world link '{j.parent}' "
                    "removed): the robot is rooted at its support instead"
                )
                continue
        out.append(j)
    return out


def build_model(path: str | Path, support: str) -> RobotModel:
    """Parse a URDF and build the body tree rooted at the link ``support``."""
    path = Path(path)
    urdf = load_urdf(path)
    robot = urdf.robot
    links = {lk.name: lk for lk in robot.links}
    notes: list[str] = []
    joints = _drop_floating_root(path, links, list(robot.joints), notes)
    used = {j.parent for j in joints} | {j.child for j in joints}
    if len(links) > 1:
        links = {n: lk for n, lk in links.items() if n in used}
    if support not in links:
        raise ModelError(
            f"{path}: unknown support link '{support}' (links: {', '.join(sorted(links)[:12])}"
            + (", …)" if len(links) > 12 else ")")
        )

    child_joint = {}
    for j in joints:
        if j.parent not in links or j.child not in links:
            raise ModelError(f"{path}: joint '{j.name}' names a link that does not exist")
        if j.child in child_joint:
            raise ModelError(f"{path}: link '{j.child}' has two parent joints")
        child_joint[j.child] = j
    roots = [name for name in links if name not in child_joint]
    if len(roots) != 1:
        raise ModelError(f"{path}: the links do not form one tree (roots: {roots})")

    by_name = {j.name: j for j in joints}
    for j in joints:
        if j.type not in _SUPPORTED:
            raise ModelError(
                f"{path}: joint '{j.name}' has type '{j.type}'; only revolute, continuous and "
                "fixed joints are supported (the SESC form needs rotations only)"
            )
        if j.mimic is not None and j.type == "fixed":
            notes.append(f"fixed joint '{j.name}': its <mimic> is ignored (a fixed joint is rigid)")

    # Independent joint coordinates, in URDF order; mimic joints follow their master.
    movable = [j for j in joints if j.type != "fixed"]
    joint_names = [j.name for j in movable if j.mimic is None]
    col = {name: i for i, name in enumerate(joint_names)}
    drive: dict[str, tuple[int, float, float]] = {}
    for j in movable:
        if j.mimic is None:
            drive[j.name] = (col[j.name], 1.0, 0.0)
            continue
        master = by_name.get(j.mimic.joint)
        if master is None:
            raise ModelError(
                f"{path}: joint '{j.name}' mimics '{j.mimic.joint}', which does not exist"
            )
        if master.type == "fixed" or master.mimic is not None:
            raise ModelError(
                f"{path}: joint '{j.name}' mimics '{j.mimic.joint}', which is not an "
                "independent revolute/continuous joint"
            )
        mult = 1.0 if j.mimic.multiplier is None else float(j.mimic.multiplier)
        off = 0.0 if j.mimic.offset is None else float(j.mimic.offset)
        _finite(path, f"joint '{j.name}' mimic", [mult, off])
        drive[j.name] = (col[master.name], mult, off)

    limits = np.empty((len(joint_names), 2))
    for name, i in col.items():
        j = by_name[name]
        lim = j.limit
        if j.type == "continuous" or lim is None or lim.lower is None or lim.upper is None:
            limits[i] = (-np.inf, np.inf)
            continue
        lo, hi = float(lim.lower), float(lim.upper)
        if math.isnan(lo) or math.isnan(hi):
            raise ModelError(f"{path}: joint '{name}' has a non-finite limit")
        if lo > hi:
            raise ModelError(f"{path}: joint '{name}' has lower limit {lo:g} > upper {hi:g} rad")
        limits[i] = (lo, hi)

    # Undirected adjacency between links, then an iterative walk from the support link.
    adj: dict[str, list] = {name: [] for name in links}
    for j in joints:
        adj[j.parent].append(j)
        adj[j.child].append(j)

    # Each link gets: its body index and X = transform of the link's URDF frame in F_body.
    link_frames: dict[str, tuple[int, np.ndarray]] = {support: (0, np.eye(4))}
    rows: list[dict] = [
        {
            "links": [support],
            "parent": -1,
            "joint": None,
            "sign": 1.0,
            "axis": np.array([0.0, 0.0, 1.0]),
            "C": np.eye(3),
            "t": np.zeros(3),
        }
    ]
    # Depth-first, children in URDF order, with an explicit stack (no recursion limit).
    stack: list[tuple[str, Any, Any]] = [(support, None, iter(adj[support]))]
    while stack:
        link, via, todo = stack[-1]
        j = next(todo, None)
        if j is None:
            stack.pop()
            continue
        if j is via:
            continue
        b, x_link = link_frames[link]
        downward = j.parent == link
        other = j.child if downward else j.parent
        o = _origin(path, j)
        if j.type == "fixed":
            link_frames[other] = (b, x_link @ (o if downward else inv_transform(o)))
            rows[b]["links"].append(other)
        else:  # a movable joint starts a new body whose frame sits on the joint axis
            if downward:  # F_new = X_link · O_j · Rot(a, q); the link frame is F_new itself
                t_const, x_other, sign = x_link @ o, np.eye(4), 1.0
            else:  # F_new = X_link · Rot(a, −q); the parent link frame is F_new · O_j⁻¹
                t_const, x_other, sign = x_link, inv_transform(o), -1.0
            rows.append(
                {
                    "links": [other],
                    "parent": b,
                    "joint": j,
                    "sign": sign,
                    "axis": _axis(path, j),
                    "C": t_const[:3, :3].copy(),
                    "t": t_const[:3, 3].copy(),
                }
            )
            link_frames[other] = (len(rows) - 1, x_other)
        stack.append((other, j, iter(adj[other])))

    bodies: list[Body] = []
    for i, row in enumerate(rows):
        mass = 0.0
        first = np.zeros(3)
        for lk in row["links"]:
            inertial = links[lk].inertial
            if inertial is None or inertial.mass is None or inertial.mass == 0:
                continue
            m = float(inertial.mass)
            if not math.isfinite(m) or m < 0:
                raise ModelError(f"{path}: link '{lk}' has an invalid mass {inertial.mass}")
            c_link = (
                np.zeros(3)
                if inertial.origin is None
                else _finite(path, f"link '{lk}' inertial origin", inertial.origin)[:3, 3]
            )
            x = link_frames[lk][1]
            first += m * (x[:3, :3] @ c_link + x[:3, 3])
            mass += m
        com = first / mass if mass > 0 else np.zeros(3)
        j = row["joint"]
        if j is None:
            jcol, mult, off, jname = -1, 1.0, 0.0, ""
            name = _main_link(row["links"], child_joint, support)
        else:
            (jcol, mult, off), jname, name = drive[j.name], j.name, row["links"][0]
        bodies.append(
            Body(
                name=name,
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
        raise ModelError(f"{path}: the robot has no mass (no <inertial> with mass > 0)")

    # Support frame = world; the root body frame is the support link frame itself (X = I).
    return RobotModel(
        name=robot.name or path.stem,
        path=path.resolve(),
        format="urdf",
        support=support,
        joint_names=joint_names,
        joint_limits=limits,
        bodies=bodies,
        link_frames=link_frames,
        root_rotation=np.eye(3),
        root_origin=np.zeros(3),
        model_root=roots[0],
        shapes=_shapes(path, links, link_frames),
        notes=notes,
    )


def _main_link(root_links: list[str], child_joint: dict, default: str) -> str:
    """Name the support body after its link that a movable joint (or nothing) attaches."""
    for lk in root_links:
        j = child_joint.get(lk)
        if j is None or j.type != "fixed":
            return lk
    return default


def _shapes(path: Path, links: dict, link_frames: dict) -> list[Shape]:
    """Collision and visual shapes of every link, placed in their body frames."""
    out = []
    for name, link in links.items():
        b, x = link_frames[name]
        for role, items in (("collision", link.collisions), ("visual", link.visuals)):
            for el in items or []:
                g = el.geometry
                if g is None:
                    continue
                org = np.eye(4) if el.origin is None else np.asarray(el.origin, dtype=float)
                pose = _finite(path, f"link '{name}' {role} origin", x @ org)
                mesh, scale = "", np.ones(3)
                if g.box is not None and g.box.size is not None:
                    kind, size = BOX, np.asarray(g.box.size, dtype=float)
                elif g.cylinder is not None:
                    kind, size = CYLINDER, np.array([g.cylinder.radius, g.cylinder.length], float)
                elif g.sphere is not None:
                    kind, size = SPHERE, np.array([g.sphere.radius], dtype=float)
                elif g.mesh is not None:
                    kind, size, mesh = MESH, np.zeros(0), str(g.mesh.filename or "")
                    if g.mesh.scale is not None:
                        scale = np.broadcast_to(np.asarray(g.mesh.scale, float), (3,)).copy()
                else:
                    continue
                _finite(path, f"link '{name}' {role} size", size)
                out.append(Shape(kind, role, b, name, pose, size, mesh, scale))
    return out
