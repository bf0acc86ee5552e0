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
from sescid.io.export.assets import relocate_mjcf, resolve_includes
from sescid.io.export.inertia import (
    check_inertias,
    corrected,
    exported_inertia,
    fmt,
    kept_notes,
    mass_warnings,
    merged_body_change,
    merged_correction,
    principal,
    sphere_inertia,
)
from sescid.io.export.xmldoc import XmlDoc, add_note, new_child, read_xml, write_xml
from sescid.model.mjcf import object_names
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
    repair: bool = False  #: repair inconsistent CAD tensors (``exported_inertia``)


def _rotation(quat) -> np.ndarray:
    """(3, 3) rotation of a unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(v) for v in quat)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _full_tensor(values: list[float]) -> np.ndarray:
    """MJCF fullinertia 'ixx iyy izz ixy ixz iyz' → (3, 3)."""
    xx, yy, zz, xy, xz, yz = values
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def _write(
    t: _Target, bid: int, mass: float, pos: np.ndarray, cad: bool, extra: np.ndarray | None = None
) -> None:
    """Set MJCF body ``bid``'s mass (kg) and CoM (m, body frame), the inertia CAD's about the
    CoM (``exported_inertia``; ``cad`` False: a newly massive body, a small sphere's), plus
    ``extra`` (``merged_correction``, body-frame axes) when given: then written as its
    principal frame (``quat``) and moments."""
    el, m = t.elements[bid - 1], t.m
    name = f"body {el.get('name') or bid}"
    if m.body_dofnum[bid] > 0 and mass < MIN_MOVING_MASS:
        t.warnings.append(
            f"{name}: the fit leaves it {mass:.3g} kg; written as {MIN_MOVING_MASS:g} kg "
            "(MuJoCo needs a moving body to have mass)"
        )
        mass = MIN_MOVING_MASS
    inertial = el.find("inertial")
    if extra is not None and np.any(extra):
        rot = _rotation(m.body_iquat[bid])
        full = rot @ np.diag(m.body_inertia[bid]) @ rot.T
        full, note = exported_inertia(full, mass, name, t.repair)
        full, more = corrected(full, extra, name)
        moments, quat = principal(full)
        if inertial is None:
            inertial = new_child(el, "inertial", first=True)
        write_inertial(inertial, mass, pos, np.diag(moments), quat)
        for n in (note, more):
            if n:
                t.warnings.append(n)
        return
    if inertial is not None and not t.from_geom and cad:
        full = inertial.get("fullinertia")
        if full is not None:
            tensor = _full_tensor([float(v) for v in full.split()])
        else:
            tensor = np.diag([float(v) for v in inertial.get("diaginertia", "0 0 0").split()])
        tensor, note = exported_inertia(tensor, mass, name, t.repair)
        write_inertial(inertial, mass, pos, tensor, None)
    else:
        if cad:
            tensor, quat = np.diag(m.body_inertia[bid]), np.asarray(m.body_iquat[bid], float)
        else:
            tensor, quat = np.diag(sphere_inertia(mass)), np.array([1.0, 0.0, 0.0, 0.0])
        tensor, note = exported_inertia(tensor, mass, name, t.repair)
        if inertial is None:
            inertial = new_child(el, "inertial", first=True)
        write_inertial(inertial, mass, pos, tensor, quat)
    if note:
        t.warnings.append(note)


def write_inertial(
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
    masses, coms = fit_inertials(fit)
    model = fit.robot.model
    src = Path(source_path if source_path is not None else model.path)
    check_inertias(model, src, repair_inertia)
    t, doc, spec = _target(src)
    t.repair = repair_inertia
    m = t.m
    total_set = spec.compiler.settotalmass > 0
    t.warnings += mass_warnings(model, masses) + kept_notes(fit)
    _compiler_edits(doc.root, t.warnings)
    names = object_names(m, "body", m.nbody, "body")
    body_id = {n: i for i, n in enumerate(names) if i}
    written = _write_bodies(t, model, body_id, masses, coms, src)
    if t.from_geom or total_set:  # every other massive body needs its compiled inertial written
        for bid in range(1, m.nbody):
            if bid not in written and m.body_mass[bid] > 0:
                _write(t, bid, float(m.body_mass[bid]), m.body_ipos[bid], True)
    root = doc.root
    add_note(
        root,
        f"masses and CoMs identified by sescid (method {fit.method_label}, {fit.n_poses} poses, "
        f"total mass {float(masses.sum()):.6f} kg); other elements as in the source MJCF",
    )
    out = Path(path)
    if out.resolve().parent != src.resolve().parent:
        relocate_mjcf(root, src.parent.resolve(), out.resolve().parent)
    write_xml(doc, out)
    return t.warnings


def _write_bodies(t: _Target, model, body_id, masses, coms, src: Path) -> set[int]:
    """Write every sescid body's mass and CoM onto its MJCF bodies; the MJCF body ids written."""
    m = t.m
    written: set[int] = set()
    big_m = float(masses.sum())
    for b, body in enumerate(model.bodies):
        parts = []  # (MJCF body id, mass, CoM in the MJCF body frame, name)
        for name in body.links:
            bid = body_id.get(name)
            if bid is not None and m.body_mass[bid] > 0:
                parts.append((bid, float(m.body_mass[bid]), m.body_ipos[bid], name))
        change = merged_body_change(src, "MJCF", body, sum(p[1] for p in parts), masses[b], coms[b])
        if change is not None:
            ratio, shift = change
            frames = [model.link_frames[name][1] for _, _, _, name in parts]
            at = [x[:3, :3] @ ck + x[:3, 3] for x, (_, _, ck, _) in zip(frames, parts, strict=True)]
            delta = merged_correction([p[1] for p in parts], at, ratio)
            main = int(np.argmax([p[1] for p in parts]))
            for k, ((bid, mk, ck, _), x) in enumerate(zip(parts, frames, strict=True)):
                extra = x[:3, :3].T @ delta @ x[:3, :3] if k == main else None
                _write(t, bid, mk * ratio, ck + x[:3, :3].T @ shift, True, extra)
                written.add(bid)
        elif masses[b] > 1e-12 * big_m:
            bid = body_id.get(body.name)
            if bid is None or body.frame_only:
                raise ModelError(
                    f"{src}: the fit gives {masses[b]:.6g} kg to '{body.name}', a massless frame "
                    "between two hinges of one MJCF body, which cannot carry mass in MJCF"
                )
            x = model.link_frames[body.name][1]
            _write(t, bid, masses[b], x[:3, :3].T @ (coms[b] - x[:3, 3]), False)
            written.add(bid)
    return written
