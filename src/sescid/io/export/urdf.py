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
from sescid.io.export.assets import relocate_urdf
from sescid.io.export.inertia import (
    check_inertias,
    corrected,
    exported_inertia,
    fmt,
    kept_notes,
    mass_warnings,
    merged_body_change,
    merged_correction,
    sphere_inertia,
)
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


def write_inertial(link: ET.Element, mass: float, com: np.ndarray, tensor: np.ndarray) -> None:
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
    for key, (i, j) in zip(_INERTIA, [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)], strict=True):
        inertia.set(key, repr(float(tensor[i, j])))


def _part(
    link: ET.Element,
    mass: float,
    com: np.ndarray,
    cad: bool,
    repair: bool,
    extra: np.ndarray | None = None,
) -> str | None:
    """Write one link's identified mass and CoM with the inertia ``exported_inertia`` gives
    for its CAD tensor (``cad`` False: a newly massive link, a small sphere's), plus ``extra``
    (``merged_correction`` in the inertial's axes) when given; a note."""
    inertia = link.find("inertial/inertia")
    tensor = _tensor(inertia) if cad else np.diag(sphere_inertia(mass))
    where = f"link {link.get('name')}"
    tensor, note = exported_inertia(tensor, mass, where, repair)
    if extra is not None:
        tensor, more = corrected(tensor, extra, where)
        note = note or more
    write_inertial(link, mass, com, tensor)
    return note


def export_urdf(fit: Fit, path: str | Path, repair_inertia: bool = False) -> list[str]:
    """Write ``fit.robot``'s URDF with the fit's body masses and CoMs to ``path`` (atomically).

    ``fit`` must hold masses (method "consistent"). Inertias: CAD's about each CoM
    (``exported_inertia``); a model with inconsistent CAD tensors raises ModelError unless
    ``repair_inertia``. Returns warnings: bodies whose mass leaves ±50 % of the CAD's, bodies
    kept at CAD, tensors repaired.
    """
    masses, coms = fit_inertials(fit)
    model = fit.robot.model
    src = Path(fit.robot.model_path)
    doc = read_xml(src, "URDF")
    links = {el.get("name"): el for el in doc.root.findall("link")}
    check_inertias(model, src, repair_inertia)
    repair = repair_inertia
    warnings = mass_warnings(model, masses) + kept_notes(fit)
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
            live = [item for item in cad if item[1] > 0]
            at = [x[:3, :3] @ c + x[:3, 3] for _, _, c, x in live]
            delta = merged_correction([m for _, m, _, _ in live], at, ratio)
            main = int(np.argmax([m for _, m, _, _ in live]))
            for k, (el, m, c, x) in enumerate(live):
                rot = x[:3, :3] @ model.inertials[str(el.get("name"))].frame[:3, :3]
                extra = rot.T @ delta @ rot if k == main else None
                notes.append(_part(el, m * ratio, c + x[:3, :3].T @ shift, True, repair, extra))
        elif masses[b] > 0:
            el, _, _, x = next(item for item in cad if item[0].get("name") == body.name)
            com = x[:3, :3].T @ (coms[b] - x[:3, 3])
            notes.append(_part(el, masses[b], com, False, repair))
        warnings += [n for n in notes if n]
    add_note(
        doc.root,
        f"masses and CoMs identified by sescid (method {fit.method_label}, {fit.n_poses} poses, "
        f"total mass {float(masses.sum()):.6f} kg); other elements as in the source URDF",
    )
    out = Path(path)
    if out.resolve().parent != src.resolve().parent:
        relocate_urdf(doc.root, src.parent.resolve(), out.resolve().parent)
    write_xml(doc, out)
    return warnings
