"""URDF → ``RobotModel``: parse (``urdf_parse``), check (``urdf_check``), build the graph of
links and joints, re-root it at the support link (``tree.reroot``, which merges fixed links),
and place the collision/visual shapes in their body frames.

Supported: revolute, continuous and fixed joints, mimic joints (q = k·q_master + o), a floating
root joint (dropped with its world link). See ``urdf_check`` for what is refused.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sescid.errors import ModelError
from sescid.model.geometry import BOX, CYLINDER, MESH, SPHERE, Shape, ShapeRole
from sescid.model.graph import Edge, Frame, Graph, LinkInertial
from sescid.model.tree import RobotModel, rooted_model
from sescid.model.urdf_check import UrdfTree, check_urdf, finite_array
from sescid.model.urdf_parse import load_urdf, parse_inertial
from sescid.model.urdf_records import Link, Urdf


def _inertial(link: Link) -> LinkInertial | None:
    """The link's checked inertial as a graph record (None without a mass)."""
    inertial = link.inertial
    if inertial is None or inertial.mass is None:
        return None
    frame = np.eye(4) if inertial.origin is None else inertial.origin
    return LinkInertial(float(inertial.mass), frame, inertial.inertia)


def urdf_graph(path: Path, tree: UrdfTree) -> Graph:
    """The checked URDF as a format-neutral graph (link frames, joints as edges)."""
    frames = {name: Frame(name, _inertial(link)) for name, link in tree.links.items()}
    edges = []
    for j in tree.joints:
        assert j.parent is not None and j.child is not None
        if j.type == "fixed":
            edges.append(Edge(j.name, j.parent, j.child, tree.origins[j.name]))
        else:
            edges.append(
                Edge(
                    j.name,
                    j.parent,
                    j.child,
                    tree.origins[j.name],
                    axis=tree.axes[j.name],
                    drive=tree.drive[j.name],
                )
            )
    return Graph(path, frames, edges)


def build_urdf_model(path: str | Path, support: str) -> RobotModel:
    """Parse a URDF and build the body tree rooted at the link ``support``."""
    path = Path(path)
    tree = check_urdf(path, load_urdf(path), support)
    graph = urdf_graph(path, tree)
    return rooted_model(
        graph,
        support,
        lambda frames: _shapes(path, tree.links, frames),
        name=tree.name or path.stem,
        format="urdf",
        joint_names=tree.joint_names,
        joint_limits=tree.limits,
        model_root=tree.root,
        notes=tree.notes,
    )


def _size(path: Path, what: str, size, n: int, signed: bool = False) -> np.ndarray:
    """A shape's ``n`` sizes [m], finite and ≥ 0 (a mesh scale: 1 or 3 finite numbers, any
    sign); ModelError naming ``what`` otherwise."""
    size = finite_array(path, what, size)
    if signed and size.ndim == 0:
        size = np.full(n, float(size))
    if size.shape != (n,) or (not signed and np.any(size < 0)):
        rule = "finite numbers" if signed else "number(s) ≥ 0 m"
        raise ModelError(f"{path}: {what} must be {n} {rule}, not {size.tolist()}")
    return size


def _shapes(path: Path, links: dict[str, Link], link_frames: dict) -> list[Shape]:
    """Collision and visual shapes of every link, placed in their body frames."""
    out = []
    for name, link in links.items():
        b, x = link_frames[name]
        roles: tuple[tuple[ShapeRole, list], ...] = (
            ("collision", link.collisions),
            ("visual", link.visuals),
        )
        for role, items in roles:
            for el in items or []:
                g = el.geometry
                if g is None:
                    continue
                org = np.eye(4) if el.origin is None else np.asarray(el.origin, dtype=float)
                pose = finite_array(path, f"link '{name}' {role} origin", x @ org)
                mesh, scale, what = "", np.ones(3), f"link '{name}' {role}"
                if g.box is not None and g.box.size is not None:
                    kind, size = BOX, _size(path, f"{what} box size", g.box.size, 3)
                elif g.cylinder is not None:
                    cyl = np.array([g.cylinder.radius, g.cylinder.length], float)
                    kind, size = CYLINDER, _size(path, f"{what} cylinder radius/length", cyl, 2)
                elif g.sphere is not None:
                    sph = np.array([g.sphere.radius], dtype=float)
                    kind, size = SPHERE, _size(path, f"{what} sphere radius", sph, 1)
                elif g.mesh is not None:
                    kind, size, mesh = MESH, np.zeros(0), str(g.mesh.filename or "")
                    if g.mesh.scale is not None:
                        scale = _size(path, f"{what} mesh scale", g.mesh.scale, 3, signed=True)
                else:
                    continue
                out.append(Shape(kind, role, b, name, pose, size, mesh, scale))
    return out


__all__ = ["Urdf", "build_urdf_model", "load_urdf", "parse_inertial", "urdf_graph"]
