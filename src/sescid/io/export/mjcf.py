"""MJCF export: the fit's MJCF with identified masses and CoMs, everything else as in the source.

The source is read with ``xmldoc`` (comments, geoms, joints, defaults and element order
survive), its ``<include>`` files are resolved into the one file written (``assets``: relative
asset paths then rewritten to resolve from the output's folder), and only ``<inertial>``
elements change (see ``sescid.io.export.inertia`` for how a merged body's parts move):

- an MJCF body whose inertia MuJoCo inferred from its geoms gets an explicit ``<inertial>``
  (first child) with MuJoCo's compiled principal frame (``quat``) and ``diaginertia``;
  explicit inertials keep their orientation (``quat``/``fullinertia`` axes); the tensor about
  the CoM is CAD's (``sescid.io.export.inertia``);
- a sescid body that was massless gets its mass on its MJCF body with a small sphere's inertia.
  The massless frames between the hinges of one MJCF body (``Body.frame_only``) cannot carry
  mass in MJCF; the consistent step keeps them at 0, and a fit that gives one more than 1e-12 ×
  the total raises ModelError;
- MuJoCo refuses a moving body without mass: one the fit leaves below ``MIN_MOVING_MASS`` is
  written with that mass, with a warning;
- ``<compiler inertiafromgeom="true">`` would override explicit inertials: it becomes "auto"
  (and every body with mass gets an explicit ``<inertial>``); ``settotalmass`` would rescale
  the written masses: it is removed. Both give a warning.

Numbers are written with ``repr`` (shortest exact decimal), so MuJoCo reads back exactly the
doubles computed here. ``<replicate>`` and ``<attach>`` are refused (their bodies are not
elements of the file).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.etree import ElementTree as ET

import numpy as np

from sescid.errors import ModelError
from sescid.estimation import Fit, fit_inertials
from sescid.io.export.assets import resolve_includes
from sescid.io.export.inertia import fmt, merged_body_change, principal
from sescid.io.export.parts import Part, exported_parts
from sescid.io.export.payload import write_identified
from sescid.io.export.xmldoc import XmlDoc, new_child, read_xml
from sescid.model.mjcf import object_names, quat_rotation
from sescid.model.mjcf_compile import compile_mjcf, mujoco_module

_ORIENT = ("quat", "axisangle", "xyaxes", "zaxis", "euler")
#: kg written for a moving MJCF body the fit leaves (nearly) massless (MuJoCo needs mass > 0)
MIN_MOVING_MASS = 1e-6


@dataclass
class _Target:
    """The parsed source and what its compiled model says about each body."""

    elements: list[ET.Element]  #: <body> elements in MuJoCo's body order (world excluded)
    m: Any  #: the compiled MjModel
    from_geom: bool  #: compiler inertiafromgeom="true" in the source
    warnings: list[str]


def _write(t: _Target, bid: int, part: Part) -> None:
    """Put ``part`` (mass, CoM and tensor in MJCF body ``bid``'s frame) into the body's
    ``<inertial>``: an explicit one keeps its ``fullinertia`` or its orientation when the
    tensor is diagonal there; otherwise the tensor's principal frame (``quat``) and moments.
    An unchanged CAD tensor is written with MuJoCo's own numbers."""
    el, m = t.elements[bid - 1], t.m
    name = f"body {el.get('name') or bid}"
    mass = part.mass
    if m.body_dofnum[bid] > 0 and mass < MIN_MOVING_MASS:
        t.warnings.append(
            f"{name}: the fit leaves it {mass:.3g} kg; written as {MIN_MOVING_MASS:g} kg "
            "(MuJoCo needs a moving body to have mass)"
        )
        mass = MIN_MOVING_MASS
    inertial = el.find("inertial")
    explicit = inertial is not None and not t.from_geom and not part.new
    if explicit and inertial is not None and inertial.get("fullinertia") is not None:
        write_mjcf_inertial(inertial, mass, part.com, part.inertia, None)
        return
    rot = np.eye(3) if part.new else quat_rotation(m.body_iquat[bid])
    d = rot.T @ part.inertia @ rot
    cad = np.asarray(m.body_inertia[bid], dtype=float)
    scale = max(float(np.abs(d).max()), 1e-300)
    diagonal = float(np.abs(d - np.diag(np.diag(d))).max()) <= 1e-12 * scale
    if diagonal and not part.new and np.abs(np.diag(d) - cad).max() <= 1e-12 * scale:
        d = np.diag(cad)  # CAD's, exactly
    if explicit and inertial is not None and diagonal:
        write_mjcf_inertial(inertial, mass, part.com, d, None)
        return
    if diagonal:
        quat = np.array([1.0, 0.0, 0.0, 0.0]) if part.new else np.asarray(m.body_iquat[bid])
        moments = np.diag(d)
    else:
        moments, quat = principal(part.inertia)
    if inertial is None:
        inertial = new_child(el, "inertial", first=True)
    write_mjcf_inertial(inertial, mass, part.com, np.diag(moments), quat)


def _compiled(m, bid: int) -> Part:
    """MJCF body ``bid`` as MuJoCo compiled it (a body the fit does not touch)."""
    rot = quat_rotation(m.body_iquat[bid])
    tensor = rot @ np.diag(m.body_inertia[bid]) @ rot.T
    return Part(m.body(bid).name, float(m.body_mass[bid]), np.asarray(m.body_ipos[bid]), tensor)


def write_mjcf_inertial(
    inertial: ET.Element, mass: float, pos: np.ndarray, tensor: np.ndarray, quat
) -> None:
    """Set an MJCF ``<inertial>``: mass (kg), pos (m, body frame), the tensor (3, 3) kg·m²
    about the CoM in the inertial's frame — its own orientation kept when ``quat`` is None
    (``fullinertia`` stays full, else ``diaginertia``), else the frame ``quat`` (w x y z) with
    a diagonal tensor. The one place an MJCF inertial is written."""
    if quat is not None:
        for key in (*_ORIENT, "fullinertia", "diaginertia"):
            inertial.attrib.pop(key, None)
        inertial.set("pos", fmt(pos))
        inertial.set("quat", fmt(quat))
        inertial.set("mass", repr(float(mass)))
        inertial.set("diaginertia", fmt(np.diag(tensor)))
        return
    inertial.set("mass", repr(float(mass)))
    inertial.set("pos", fmt(pos))
    if inertial.get("fullinertia") is not None:
        inertial.set("fullinertia", fmt(tensor[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]))
    else:
        inertial.set("diaginertia", fmt(np.diag(tensor)))


def _compiler_edits(root: ET.Element, warnings: list[str]) -> None:
    """inertiafromgeom="true" → "auto"; settotalmass removed (see the module docstring)."""
    for comp in root.iter("compiler"):
        if comp.get("inertiafromgeom") == "true":
            comp.set("inertiafromgeom", "auto")
            warnings.append(
                "compiler inertiafromgeom='true' changed to 'auto' (explicit inertials)"
            )
        if comp.get("settotalmass") is not None:
            del comp.attrib["settotalmass"]
            warnings.append("compiler settotalmass removed (the masses written are absolute)")


def _target(src: Path) -> tuple[_Target, XmlDoc, Any]:
    """The source MJCF (includes resolved), matched to MuJoCo's compiled bodies."""
    mujoco = mujoco_module()
    spec, m = compile_mjcf(src)
    doc = read_xml(src, "MJCF")
    resolve_includes(doc.root, src)
    for tag in ("replicate", "attach"):
        if doc.root.find(f".//{tag}") is not None:
            raise ModelError(f"{src}: uses <{tag}>; export needs bodies written out in the file")
    elements = [el for wb in doc.root.iter("worldbody") for el in wb.iter("body")]
    if len(elements) != m.nbody - 1 or any(
        el.get("name", "") != m.body(i + 1).name for i, el in enumerate(elements)
    ):
        raise ModelError(f"{src}: cannot match the <body> elements to MuJoCo's compiled bodies")
    from_geom = spec.compiler.inertiafromgeom == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE
    target = _Target(elements, m, from_geom, [])
    return target, doc, spec


def export_mjcf(
    fit: Fit,
    path: str | Path,
    source_path: str | Path | None = None,
    repair_inertia: bool = False,
) -> list[str]:
    """Write ``fit.robot``'s MJCF with the fit's body masses and CoMs to ``path`` (atomically).

    ``source_path``: the MJCF the fit's model was built from (default: the model's path).
    ``fit`` must hold masses (method "consistent"). Inertias: CAD's about each CoM
    (``exported_inertia``); inconsistent CAD tensors raise ModelError unless
    ``repair_inertia``. Returns warnings (compiler attributes changed, bodies whose mass leaves
    ±50 % of the CAD's, bodies kept at CAD, tensors repaired).
    """
    masses, _ = fit_inertials(fit)
    model = fit.robot.model
    src = Path(source_path if source_path is not None else model.path)
    t, doc, spec = _target(src)
    m = t.m
    names = object_names(m, "body", m.nbody, "body")
    body_id = {n: i for i, n in enumerate(names) if i}
    for body in model.bodies:  # the file the fit's model was read from, unchanged since?
        m_file = sum(float(m.body_mass[body_id[n]]) for n in body.links if n in body_id)
        merged_body_change(src, "MJCF", body, m_file, body.mass, body.com)
    parts, warnings = exported_parts(fit, repair_inertia)
    t.warnings += warnings
    total_set = spec.compiler.settotalmass > 0
    _compiler_edits(doc.root, t.warnings)
    written: set[int] = set()
    for part in parts:
        bid = body_id.get(part.link)
        if bid is None:
            raise ModelError(f"{src}: body '{part.link}' of the fit's model is missing")
        _write(t, bid, part)
        written.add(bid)
    if t.from_geom or total_set:  # every other massive body needs its compiled inertial written
        for bid in range(1, m.nbody):
            if bid not in written and m.body_mass[bid] > 0:
                _write(t, bid, _compiled(m, bid))
    write_identified(doc, fit, float(masses.sum()), src, path, "mjcf")
    return t.warnings
