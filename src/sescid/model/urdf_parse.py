"""URDF XML → typed records: the one URDF parser of sescid.

Strict XML (ElementTree) into small typed records of what statics, shapes, the physics bench and
export use (origins as 4×4 transforms, URDF's fixed-axis roll-pitch-yaw), numbers as written
(``urdf_check`` judges them); no URDF library, so loading costs milliseconds (yourdfpy is the
tests' oracle). A xacro file is recognised and refused with the command that expands it.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import numpy as np

from sescid.errors import ModelError
from sescid.model.urdf_records import (
    Cylinder,
    Element,
    Geometry,
    Inertial,
    Joint,
    Limit,
    Link,
    Mesh,
    Mimic,
    Sphere,
    Urdf,
    UrdfBox,
    UrdfRobot,
)

_XACRO_NS = "{http://www.ros.org/wiki/xacro}"


def _floats(text: str) -> list[float]:
    return [float(v) for v in text.replace(",", " ").split()]


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
        g.box = UrdfBox(np.array(_floats(shape.attrib["size"]), dtype=float))
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


def parse_inertial(el: Any) -> Inertial | None:
    """The record of an ``<inertial>`` element (ElementTree or lxml), None for None.

    ValueError on a malformed number. Export reads the element it edits through this function,
    so that sescid has one reading of URDF inertials.
    """
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
    link = Link(el.attrib["name"], parse_inertial(el.find("inertial")))
    for kind, items in (("visual", link.visuals), ("collision", link.collisions)):
        for v in el.findall(kind):
            items.append(Element(_geometry_el(v.find("geometry")), _origin_el(v.find("origin"))))
    return link


def _num(el: ElementTree.Element, key: str) -> float | None:
    v = el.get(key)
    return None if v is None else float(v)


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
        limit=None if lim is None else Limit(_num(lim, "lower"), _num(lim, "upper")),
        mimic=None
        if mimic is None
        else Mimic(
            mimic.get("joint"), float(mimic.get("multiplier", 1.0)), float(mimic.get("offset", 0.0))
        ),
    )


def _is_xacro(data: bytes, root: ElementTree.Element) -> bool:
    """True when the document uses xacro: tags in its namespace, or ``${…}`` / ``$(…)``."""
    if b"xacro" not in data and b"${" not in data and b"$(" not in data:
        return False  # the common case, without walking the tree
    for el in root.iter():
        if isinstance(el.tag, str) and el.tag.startswith(_XACRO_NS):
            return True
        if any("${" in v or "$(" in v for v in el.attrib.values()):
            return True
    return False


def _xacro_error(path: Path) -> ModelError:
    stem = path.name.removesuffix(".xacro").removesuffix(".urdf")
    return ModelError(
        f"{path}: a xacro file (URDF macros), not a URDF: expand it first, e.g. "
        f"`xacro {path.name} > {stem}.urdf` (ROS package xacro)"
    )


def _check_xml(path: Path) -> ElementTree.Element:
    if not path.is_file():
        raise ModelError(f"{path}: URDF file not found")
    if path.suffix.lower() == ".xacro":
        raise _xacro_error(path)
    data = b""
    try:
        data = path.read_bytes()
        root = ElementTree.fromstring(data)
    except (ElementTree.ParseError, OSError) as exc:
        if "unbound prefix" in str(exc) and b"xacro:" in data:
            raise _xacro_error(path) from None
        raise ModelError(f"{path}: malformed URDF (XML: {exc})") from None
    if root.tag != "robot":
        raise ModelError(f"{path}: malformed URDF (root element <{root.tag}>, not <robot>)")
    if _is_xacro(data, root):
        raise _xacro_error(path)
    for kind in ("link", "joint"):
        seen: set[str] = set()
        for el in root.findall(kind):
            name = el.get("name", "")
            if not name:
                raise ModelError(f"{path}: a <{kind}> element has no name")
            if name in seen:
                raise ModelError(f"{path}: two <{kind}> elements are named '{name}'")
            seen.add(name)
    return root


def load_urdf(path: str | Path) -> Urdf:
    """The parsed URDF (links, joints; no meshes loaded); ModelError on malformed files."""
    path = Path(path)
    root = _check_xml(path)
    parsed: dict[str, list[Any]] = {"link": [], "joint": []}
    for kind, parse in (("link", _link_el), ("joint", _joint_el)):
        for el in root.findall(kind):
            try:
                parsed[kind].append(parse(el))
            except KeyError as exc:
                what = f"missing attribute {exc}"
            except (ValueError, TypeError) as exc:
                what = str(exc)
            else:
                continue
            raise ModelError(f"{path}: malformed URDF, <{kind}> '{el.get('name')}' ({what})")
    if not parsed["link"]:
        raise ModelError(f"{path}: malformed URDF (no links)")
    return Urdf(UrdfRobot(root.get("name") or "", parsed["link"], parsed["joint"]))


__all__ = ["Inertial", "Joint", "Link", "Urdf", "load_urdf", "parse_inertial"]
