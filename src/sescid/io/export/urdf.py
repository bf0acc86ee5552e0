"""URDF export: the fit's robot URDF with identified masses and CoMs, everything else untouched.

Only ``<inertial>`` elements change (mass value, origin xyz, inertia scaled), written as
``sescid.io.export.inertia`` describes (merged links keep their layout, every tensor physically
valid, a massless body gets a small sphere's inertia); comments, visuals, collisions, joints and
element order survive (``xmldoc``). Written to another folder, relative mesh and texture file
names are rewritten to resolve from there (``assets``).
"""

from __future__ import annotations

from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from sescid.errors import ModelError
from sescid.estimation import Fit, fit_inertials
from sescid.io.export.assets import relocate_urdf
from sescid.io.export.inertia import (
    fmt,
    mass_warnings,
    merged_body_change,
    sphere_inertia,
    valid_inertia,
)
from sescid.io.export.payload import add_payload
from sescid.io.export.xmldoc import add_note, new_child, read_xml, write_xml

_INERTIA = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def _floats(text: str | None, n: int, what: str) -> np.ndarray:
    if text is None:
        return np.zeros(n)
    try:
        out = np.array([float(v) for v in text.split()])
    except ValueError:
        out = np.zeros(0)
    if out.shape != (n,):
        raise ModelError(f"malformed {what}: '{text}'")
    return out


def _read_inertial(link: ET.Element) -> tuple[float, np.ndarray]:
    """(mass kg, CoM m in the link frame) of a <link> element; (0, 0) when it has none."""
    inertial = link.find("inertial")
    if inertial is None:
        return 0.0, np.zeros(3)
    mass_el = inertial.find("mass")
    mass = 0.0 if mass_el is None else float(mass_el.get("value", "0"))
    origin = inertial.find("origin")
    xyz = _floats(None if origin is None else origin.get("xyz"), 3, "inertial origin xyz")
    return mass, xyz


def _tensor(inertia: ET.Element | None) -> np.ndarray:
    """The (3, 3) tensor of an <inertia> element (zeros when absent)."""
    v = {k: 0.0 if inertia is None else float(inertia.get(k, "0")) for k in _INERTIA}
    return np.array(
        [
            [v["ixx"], v["ixy"], v["ixz"]],
            [v["ixy"], v["iyy"], v["iyz"]],
            [v["ixz"], v["iyz"], v["izz"]],
        ]
    )


def _write_inertial(
    link: ET.Element, mass: float, com: np.ndarray, scale: float | None
) -> str | None:
    """Set a link's mass (kg) and CoM (m, link frame); its inertia tensor × ``scale`` (None: a
    newly massive link, a small sphere's). A warning when the tensor had to be made valid."""
    inertial = link.find("inertial")
    if inertial is None:
        inertial = new_child(link, "inertial")
    origin = inertial.find("origin")
    if origin is None:
        origin = new_child(inertial, "origin", first=True)
        origin.set("rpy", "0 0 0")
    origin.set("xyz", fmt(com))
    mass_el = inertial.find("mass")
    if mass_el is None:
        mass_el = new_child(inertial, "mass")
    mass_el.set("value", repr(float(mass)))
    inertia = inertial.find("inertia")
    if scale is None:
        tensor = np.diag(sphere_inertia(mass))
    else:
        tensor = _tensor(inertia) * float(scale)
    tensor, warning = valid_inertia(tensor, mass, f"link {link.get('name')}")
    if inertia is None:
        inertia = new_child(inertial, "inertia")
    for key, (i, j) in zip(_INERTIA, [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)], strict=True):
        inertia.set(key, repr(float(tensor[i, j])))
    return warning


def export_urdf(fit: Fit, path: str | Path) -> list[str]:
    """Write ``fit.robot``'s URDF with the fit's body masses and CoMs to ``path`` (atomically).

    ``fit`` must hold masses (method "consistent"). Returns warnings: bodies whose mass leaves
    ±50 % of the CAD's, inertia tensors of the model that were not physically valid.
    """
    masses, coms = fit_inertials(fit)
    model = fit.robot.model
    src = Path(fit.robot.model_path)
    doc = read_xml(src, "URDF")
    links = {el.get("name"): el for el in doc.root.findall("link")}
    warnings = mass_warnings(model, masses)
    for b, body in enumerate(model.bodies):
        cad = []  # (link element, mass, CoM in the link frame, link-frame transform)
        for name in body.links:
            if name not in links:
                raise ModelError(f"{src}: link '{name}' of the fit's model is missing")
            m, c = _read_inertial(links[name])
            cad.append((links[name], m, c, model.link_frames[name][1]))
        change = merged_body_change(
            src, "URDF", body, sum(m for _, m, _, _ in cad), masses[b], coms[b]
        )
        notes: list[str | None] = []
        if change is not None:
            ratio, shift = change
            for el, m, c, x in cad:
                if m > 0:
                    notes.append(_write_inertial(el, m * ratio, c + x[:3, :3].T @ shift, ratio))
        elif masses[b] > 0:
            el, _, _, x = next(item for item in cad if item[0].get("name") == body.name)
            notes.append(_write_inertial(el, masses[b], x[:3, :3].T @ (coms[b] - x[:3, 3]), None))
        warnings += [n for n in notes if n]
    add_note(
        doc.root,
        f"masses and CoMs identified by sescid (method {fit.method_label}, {fit.n_poses} poses, "
        f"total mass {float(masses.sum()):.6f} kg); other elements as in the source URDF",
    )
    if fit.payload is not None:  # a payload fit: its payload as one more fixed link
        add_note(doc.root, add_payload(doc.root, fit, "urdf"))
    out = Path(path)
    if out.resolve().parent != src.resolve().parent:
        relocate_urdf(doc.root, src.parent.resolve(), out.resolve().parent)
    write_xml(doc, out)
    return warnings
