"""URDF export: the fit's robot URDF with identified masses and CoMs, everything else untouched.

Only ``<inertial>`` elements change (mass value, origin xyz, inertia), written as
``sescid.io.export.inertia`` describes (merged links keep their layout, every tensor consistent
and CAD's about the CoM, a massless body gets a small sphere's inertia); comments, visuals,
collisions, joints and element order survive (``xmldoc``). Written to another folder,
relative mesh and texture file names are rewritten to resolve from there (``assets``).
"""

from __future__ import annotations

from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from sescid.errors import ModelError
from sescid.estimation import Fit, fit_inertials
from sescid.io.export.inertia import fmt, merged_body_change
from sescid.io.export.parts import exported_parts
from sescid.io.export.payload import write_identified
from sescid.io.export.xmldoc import new_child, read_xml

_INERTIA = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def _mass(link: ET.Element) -> float:
    """A <link>'s inertial mass in kg (0 without one); ModelError when it is not a number."""
    el = link.find("inertial/mass")
    text = "0" if el is None else el.get("value", "0")
    try:
        return float(text)
    except ValueError:
        raise ModelError(f"link {link.get('name')}: malformed mass '{text}'") from None


def write_urdf_inertial(link: ET.Element, mass: float, com: np.ndarray, tensor: np.ndarray) -> None:
    """Set a link's inertial: mass (kg), CoM (m, link frame) and inertia tensor (3, 3) kg·m²
    about the CoM in the inertial's frame (its ``origin rpy``, identity when new). The one
    place a URDF inertial is written."""
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
    if inertia is None:
        inertia = new_child(inertial, "inertia")
    at = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
    try:
        old = np.array([float(inertia.get(key, "nan")) for key in _INERTIA])
    except ValueError:
        old = np.full(6, np.nan)
    new = np.array([tensor[i, j] for i, j in at], dtype=float)
    if np.all(np.abs(new - old) <= 1e-13 * max(float(np.abs(new).max()), 1e-300)):
        return  # the file's own numbers (a tensor kept, up to the frame changes' round-off)
    for key, value in zip(_INERTIA, new, strict=True):
        inertia.set(key, repr(float(value)))


def export_urdf(fit: Fit, path: str | Path, repair_inertia: bool = False) -> list[str]:
    """Write ``fit.robot``'s URDF with the fit's body masses and CoMs to ``path`` (atomically).

    ``fit`` must hold masses (method "consistent"). What each link gets is
    ``exported_parts``'s (the inertia CAD's about each body's CoM); a model with inconsistent
    CAD tensors raises ModelError unless ``repair_inertia``. Returns warnings: bodies whose
    mass leaves ±50 % of the CAD's, bodies kept at CAD, tensors repaired.
    """
    masses, _ = fit_inertials(fit)
    model = fit.robot.model
    src = Path(fit.robot.model_path)
    doc = read_xml(src, "URDF")
    links = {el.get("name"): el for el in doc.root.findall("link")}
    for body in model.bodies:  # the file the fit's model was read from, unchanged since?
        missing = [n for n in body.links if n not in links]
        if missing:
            raise ModelError(f"{src}: link '{missing[0]}' of the fit's model is missing")
        m_file = sum(_mass(links[n]) for n in body.links)
        merged_body_change(src, "URDF", body, m_file, body.mass, body.com)
    parts, warnings = exported_parts(fit, repair_inertia)
    for part in parts:
        if part.link not in links:
            raise ModelError(f"{src}: link '{part.link}' of the fit's model is missing")
        el = links[part.link]
        inertial = model.inertials.get(part.link)
        # the tensor goes in the frame of the inertial's origin rpy (identity when written new)
        has_rpy = el.find("inertial/origin") is not None and inertial is not None
        rot = inertial.frame[:3, :3] if has_rpy and inertial is not None else np.eye(3)
        write_urdf_inertial(el, part.mass, part.com, rot.T @ part.inertia @ rot)
    write_identified(doc, fit, float(masses.sum()), src, path, "urdf")
    return warnings
