"""A payload fit's payload in an exported model: one more body, fixed to the payload's link.

The payload (``Fit.payload``: mass m on the link BODY, CoM c in BODY's frame) becomes a body
``<BODY>_payload`` with mass m at c and a small sphere's inertia (static data do not identify
an inertia), fixed to BODY: in URDF a link and a fixed joint whose origin is c, in MJCF a
``<body pos="c">`` without a joint inside BODY's ``<body>``. A payload component the data did
not determine is refused (nothing is written with a guessed number). A payload fit whose base
is the model file keeps the model's inertials as they are (``export_model_with_payload``).
"""

from __future__ import annotations

import math
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from sescid.errors import ModelError
from sescid.estimation import Fit
from sescid.io.export.assets import relocate_mjcf, relocate_urdf, resolve_includes
from sescid.io.export.inertia import fmt
from sescid.io.export.xmldoc import XmlDoc, add_note, read_xml, write_xml
from sescid.model.inertia import sphere_inertia


def payload_name(root: ET.Element, body: str) -> str:
    """A name for the payload's body that the file does not use yet."""
    used = {el.get("name") for el in root.iter() if el.get("name")}
    name, k = f"{body}_payload", 1
    while name in used:
        k += 1
        name = f"{body}_payload{k}"
    return name


def _checked(fit: Fit) -> tuple[str, float, np.ndarray]:
    p = fit.payload
    assert p is not None
    if not (math.isfinite(p.mass) and p.mass > 0 and np.all(np.isfinite(p.com))):
        raise ModelError(
            f"the payload on {p.body} is not determined ({', '.join(p.unseen) or 'mass ≤ 0'}): "
            "nothing to export for it; measure more poses (sescid poses --payload)"
        )
    return p.body, float(p.mass), np.asarray(p.com, dtype=float)


def add_payload(root: ET.Element, fit: Fit, format: str) -> str:  # noqa: A002
    """Add the payload of a payload fit to a URDF or MJCF document's root; a note for the file."""
    body, mass, com = _checked(fit)
    name = payload_name(root, body)
    diag = sphere_inertia(mass)
    if format == "urdf":
        if not any(el.get("name") == body for el in root.findall("link")):
            raise ModelError(f"export: the payload's link '{body}' is not a <link> of the URDF")
        link = ET.SubElement(root, "link", name=name)
        inertial = ET.SubElement(link, "inertial")
        ET.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
        ET.SubElement(inertial, "mass", value=repr(mass))
        ET.SubElement(inertial, "inertia", ixx=repr(float(diag[0])), ixy="0", ixz="0",
                      iyy=repr(float(diag[1])), iyz="0", izz=repr(float(diag[2])))  # fmt: skip
        joint = ET.SubElement(root, "joint", name=f"{name}_joint", type="fixed")
        ET.SubElement(joint, "parent", link=body)
        ET.SubElement(joint, "child", link=name)
        ET.SubElement(joint, "origin", xyz=fmt(com), rpy="0 0 0")
    else:
        parent = next((el for el in root.iter("body") if el.get("name") == body), None)
        if parent is None:
            raise ModelError(f"export: the payload's link '{body}' is not a <body> of the MJCF")
        child = ET.SubElement(parent, "body", name=name, pos=fmt(com))
        ET.SubElement(child, "inertial", pos="0 0 0", mass=repr(mass), diaginertia=fmt(diag))
    p = fit.payload
    assert p is not None
    return (
        f"payload {name}: {mass:.6g} kg at {fmt(com)} m in {body}'s frame, identified by sescid "
        f"from {p.n_poses} poses (base: {p.base})"
    )


def write_identified(
    doc: XmlDoc, fit: Fit, total_mass: float, src: Path, path, fmt_name: str
) -> None:
    """Write the model file ``doc`` ("urdf" or "mjcf", read from ``src``, its inertials set from
    ``fit``) to ``path``: a note on the fit (``total_mass`` kg), a payload fit's payload as one
    more fixed link or body, relative asset paths rewritten for the output's folder."""
    add_note(
        doc.root,
        f"masses and CoMs identified by sescid (method {fit.method_label}, {fit.n_poses} poses, "
        f"total mass {total_mass:.6f} kg); other elements as in the source {fmt_name.upper()}",
    )
    if fit.payload is not None:
        add_note(doc.root, add_payload(doc.root, fit, fmt_name))
    out = Path(path)
    if out.resolve().parent != src.resolve().parent:
        relocate = relocate_mjcf if fmt_name == "mjcf" else relocate_urdf
        relocate(doc.root, src.parent.resolve(), out.resolve().parent)
    write_xml(doc, out)


def export_model_with_payload(fit: Fit, path: str | Path) -> list[str]:
    """Write the model file of a payload fit on the model's own masses, with the payload added
    (everything else as in the source; includes resolved and assets relocated as export
    does). Returns warnings (none)."""
    model = fit.robot.model
    src = Path(model.path)
    fmt_name = model.format
    doc = read_xml(src, "URDF" if fmt_name == "urdf" else "MJCF")
    out = Path(path)
    moved = out.resolve().parent != src.resolve().parent
    if fmt_name == "mjcf":
        resolve_includes(doc.root, src)
        if moved:
            relocate_mjcf(doc.root, src.parent.resolve(), out.resolve().parent)
    elif moved:
        relocate_urdf(doc.root, src.parent.resolve(), out.resolve().parent)
    add_note(doc.root, add_payload(doc.root, fit, fmt_name) + "; the robot's own masses as in "
             "the source")  # fmt: skip
    write_xml(doc, out)
    return []
