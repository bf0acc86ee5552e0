"""URDF export: the fit's robot URDF with identified masses and CoMs, everything else untouched.

Only ``<inertial>`` elements change (mass value, origin xyz, inertia scaled); the XML tree is
edited in place with lxml, so comments, visuals, collisions, joints and element order survive.

A sescid body may merge several URDF links (fixed joints). Its identified mass m and CoM c
(body frame) are distributed over the links that carried mass in the source URDF: every link's
mass and inertia tensor are scaled by m / m_CAD and every link's CoM is moved by the same
offset c − c_CAD, so the links keep their relative layout and the merged body has exactly
(m, c). Inertia tensors keep their orientation (``<origin rpy>``) and are scaled by the mass
ratio: the static SESC problem does not identify them. A body whose links were all massless
gets its mass on its main link (a new ``<inertial>`` with a zero inertia tensor if needed).

``export_model`` writes the fit's model in its own format: ``export_urdf`` here, ``export_mjcf``
(``sescid.io.export.mjcf``) for an MJCF model.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sescid.base.files import atomic_path
from sescid.errors import ModelError, OptionError
from sescid.estimation import Fit, fit_inertials

_INERTIA = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
#: model formats ``export_model`` writes
FORMATS = ("urdf", "mjcf")


def export_model(fit: Fit, path: str | Path, format: str | None = None) -> list[str]:
    """Write ``fit.robot``'s model file with the fit's masses and CoMs to ``path``; warnings.

    ``format``: "urdf" or "mjcf" (default: the model's own, ``RobotModel.format``). Export
    edits the model file the fit was made from, so a format other than the model's own raises
    OptionError (no URDF ↔ MJCF conversion).
    """
    own = fit.robot.model.format
    fmt = own if format is None else str(format).lower()
    if fmt not in FORMATS:
        raise OptionError(
            "format", f"unknown model format '{format}' (one of {', '.join(FORMATS)})"
        )
    if fmt != own:
        raise OptionError(
            "format",
            f"cannot write {fmt.upper()} from the {own.upper()} model {fit.robot.model_path}: "
            "export edits the inertials of the model file the fit was made from (convert the "
            "model first and identify on it)",
        )
    if fmt == "mjcf":
        from sescid.io.export.mjcf import export_mjcf

        return export_mjcf(fit, path)
    return export_urdf(fit, path)


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


def _fmt(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def merged_body_change(
    src: Path, kind: str, body, m_old: float, mass: float, com: np.ndarray
) -> tuple[float, np.ndarray] | None:
    """How the file's parts of a (merged) body move to the identified mass (kg) and CoM (body
    frame, m): every part's mass times ``ratio`` and its CoM plus ``shift`` (body frame) keep
    the parts' proportions; None when the parts weigh nothing. ``m_old``: the parts' mass in
    the ``kind`` file ("URDF", "MJCF"), which must be the fit's model's (else ModelError)."""
    if abs(m_old - body.mass) > 1e-9 * max(1.0, body.mass):
        raise ModelError(
            f"{src}: body {body.name} weighs {m_old} kg in the {kind} but {body.mass} kg in "
            f"the fit's model; the {kind} changed since the fit was made"
        )
    if not m_old > 0:
        return None
    return mass / m_old, com - body.com


def _read_inertial(link) -> tuple[float, np.ndarray]:
    """(mass kg, CoM m in the link frame) of a <link> element; (0, 0) when it has none."""
    inertial = link.find("inertial")
    if inertial is None:
        return 0.0, np.zeros(3)
    mass_el = inertial.find("mass")
    mass = 0.0 if mass_el is None else float(mass_el.get("value", "0"))
    origin = inertial.find("origin")
    xyz = _floats(None if origin is None else origin.get("xyz"), 3, "inertial origin xyz")
    return mass, xyz


def _write_inertial(link, mass: float, com: np.ndarray, scale: float) -> None:
    """Set a link's mass (kg) and CoM (m, link frame); scale its inertia tensor by ``scale``."""
    from lxml import etree

    inertial = link.find("inertial")
    if inertial is None:
        inertial = etree.SubElement(link, "inertial")
    origin = inertial.find("origin")
    if origin is None:
        origin = etree.Element("origin")
        inertial.insert(0, origin)
        origin.set("rpy", "0 0 0")
    origin.set("xyz", _fmt(com))
    mass_el = inertial.find("mass")
    if mass_el is None:
        mass_el = etree.SubElement(inertial, "mass")
    mass_el.set("value", repr(float(mass)))
    inertia = inertial.find("inertia")
    if inertia is None:
        inertia = etree.SubElement(inertial, "inertia")
        for key in _INERTIA:
            inertia.set(key, "0")
        return
    for key in _INERTIA:
        inertia.set(key, repr(float(inertia.get(key, "0")) * float(scale)))


def export_urdf(fit: Fit, path: str | Path) -> list[str]:
    """Write ``fit.robot``'s URDF with the fit's body masses and CoMs to ``path`` (atomically).

    ``fit`` must hold masses (method "consistent"; see ``sescid.consistent``). Returns
    warnings (e.g. relative mesh paths that no longer resolve from the output folder).
    """
    from lxml import etree

    masses, coms = fit_inertials(fit)
    robot = fit.robot
    model = robot.model
    src = Path(robot.model_path)
    try:
        tree = etree.parse(str(src), etree.XMLParser(remove_blank_text=False))
    except (OSError, etree.XMLSyntaxError) as exc:
        raise ModelError(f"{src}: cannot read the URDF to export ({exc})") from None
    root = tree.getroot()
    links = {el.get("name"): el for el in root.findall("link")}
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
        if change is not None:
            ratio, shift = change
            for el, m, c, x in cad:
                if m > 0:
                    _write_inertial(el, m * ratio, c + x[:3, :3].T @ shift, ratio)
        elif masses[b] > 0:
            el, _, _, x = next(item for item in cad if item[0].get("name") == body.name)
            _write_inertial(el, masses[b], x[:3, :3].T @ (coms[b] - x[:3, 3]), 0.0)
    note = etree.Comment(
        f" masses and CoMs identified by sescid (method {fit.method_label}, "
        f"{fit.n_poses} poses, total mass {float(masses.sum()):.6f} kg); "
        "other elements as in the source URDF "
    )
    note.tail = "\n  "
    root.insert(0, note)
    warnings = []
    out = Path(path)
    if out.resolve().parent != src.resolve().parent:
        for mesh in root.iter("mesh"):
            name = mesh.get("filename", "")
            if name and "://" not in name and not Path(name).is_absolute():
                warnings.append(
                    f"mesh '{name}' is relative to {src.parent}; it will not resolve from "
                    f"{out.parent} (geometry only: masses and CoMs are unaffected)"
                )
    # Comments/PIs around <robot> one per line (lxml drops the line breaks between them).
    parts = [b'<?xml version="1.0" encoding="utf-8"?>']
    parts += [etree.tostring(el) for el in reversed(list(root.itersiblings(preceding=True)))]
    parts += [etree.tostring(root, encoding="utf-8")]
    parts += [etree.tostring(el) for el in root.itersiblings()]
    with atomic_path(out) as tmp:
        tmp.write_bytes(b"\n".join(parts) + b"\n")
    return warnings
