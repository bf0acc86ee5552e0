"""MJCF export: the fit's MJCF with identified masses and CoMs, everything else untouched.

Mirrors ``io.export.urdf.export_urdf``. The source XML is edited in place with lxml (comments,
geoms, joints, defaults, element order survive; lxml re-serialises attribute quoting), and only
``<inertial>`` elements change:

- a sescid body may merge several MJCF bodies (bodies without joints). Its identified mass m and
  CoM c (body frame) are distributed over the MJCF bodies that carried mass in the source: every
  one's mass and inertia are scaled by m / m_CAD and its CoM (``<inertial pos>``) moved by the
  same offset c − c_CAD, so they keep their relative layout and the merged body has exactly
  (m, c). Inertias keep their orientation (``quat``/``fullinertia`` axes) and are scaled by the
  mass ratio: static data do not identify them;
- a body whose inertia MuJoCo inferred from its geoms gets an explicit ``<inertial>`` (first
  child) with MuJoCo's compiled principal frame (``quat``) and ``diaginertia`` × the ratio;
- a sescid body that was massless gets its mass on its MJCF body, with the inertia of a 1 mm
  solid sphere (MuJoCo rejects a moving body with zero inertia). The massless frames between the
  hinges of one MJCF body (``Body.frame_only``) cannot carry mass in MJCF; the consistent step
  keeps them at 0, and a fit that gives one more than 1e-12 × the total raises ModelError;
- ``<compiler inertiafromgeom="true">`` would override explicit inertials: it becomes "auto"
  (and every body with mass gets an explicit ``<inertial>``); ``settotalmass`` would rescale the
  written masses: it is removed (same). Both give a warning.

Numbers are written with ``repr`` (shortest exact decimal), so MuJoCo reads back exactly the
doubles computed here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sescid.base.files import atomic_path
from sescid.errors import ModelError
from sescid.estimation import Fit, fit_inertials
from sescid.io.export.urdf import _fmt, merged_body_change
from sescid.model.mjcf import _mujoco, _names, compile_mjcf

_ORIENT = ("quat", "axisangle", "xyaxes", "zaxis", "euler")


def export_mjcf(fit: Fit, path: str | Path, source_path: str | Path | None = None) -> list[str]:
    """Write ``fit.robot``'s MJCF with the fit's body masses and CoMs to ``path`` (atomically).

    ``source_path``: the MJCF the fit's model was built from (default: the model's path).
    ``fit`` must hold masses (method "consistent"; see ``sescid.estimation.consistent``).
    Returns warnings (compiler attributes changed, relative asset paths that no longer resolve).
    """
    from lxml import etree

    mujoco = _mujoco()
    masses, coms = fit_inertials(fit)
    model = fit.robot.model
    src = Path(source_path if source_path is not None else model.path)
    spec, m = compile_mjcf(src)
    try:
        tree = etree.parse(str(src), etree.XMLParser(remove_blank_text=False))
    except (OSError, etree.XMLSyntaxError) as exc:
        raise ModelError(f"{src}: cannot read the MJCF to export ({exc})") from None
    root = tree.getroot()
    if root.find(".//include") is not None or root.find(".//replicate") is not None:
        raise ModelError(f"{src}: uses <include>/<replicate>; export needs a single-file MJCF")
    elements = [el for wb in root.iter("worldbody") for el in wb.iter("body")]
    names = _names(m, "body", m.nbody, "body")
    if len(elements) != m.nbody - 1 or any(
        el.get("name", "") != m.body(i + 1).name for i, el in enumerate(elements)
    ):
        raise ModelError(f"{src}: cannot match the <body> elements to MuJoCo's compiled bodies")
    body_id = {n: i for i, n in enumerate(names) if i}
    warnings: list[str] = []

    from_geom = spec.compiler.inertiafromgeom == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE
    total_set = spec.compiler.settotalmass > 0
    for comp in root.iter("compiler"):
        if comp.get("inertiafromgeom") == "true":
            comp.set("inertiafromgeom", "auto")
            warnings.append(
                "compiler inertiafromgeom='true' changed to 'auto' (explicit inertials)"
            )
        if comp.get("settotalmass") is not None:
            del comp.attrib["settotalmass"]
            warnings.append("compiler settotalmass removed (the masses written are absolute)")

    def write(bid: int, mass: float, pos: np.ndarray, scale: float | None) -> None:
        """Set body ``bid``'s mass (kg) and CoM (m, MJCF body frame); inertia × ``scale``."""
        el = elements[bid - 1]
        inertial = el.find("inertial")
        if scale is None:  # newly massive: a 1 mm solid sphere
            diag = np.full(3, max(0.4 * mass * 1e-6, 1e-12))
        else:
            diag = np.asarray(m.body_inertia[bid], dtype=float) * scale
        if inertial is not None and not from_geom and scale is not None:
            inertial.set("mass", repr(float(mass)))
            inertial.set("pos", _fmt(pos))
            for key in ("diaginertia", "fullinertia"):
                if inertial.get(key) is not None:
                    vals = [float(v) * scale for v in inertial.get(key).split()]
                    inertial.set(key, _fmt(vals))
            return
        if inertial is None:
            inertial = etree.Element("inertial")
            indent = el.text if el.text and not el.text.strip() else None
            el.insert(0, inertial)
            if indent is not None:
                inertial.tail = indent
        for key in (*_ORIENT, "fullinertia", "diaginertia"):
            inertial.attrib.pop(key, None)
        inertial.set("pos", _fmt(pos))
        quat = m.body_iquat[bid] if scale is not None else np.array([1.0, 0.0, 0.0, 0.0])
        inertial.set("quat", _fmt(quat))
        inertial.set("mass", repr(float(mass)))
        inertial.set("diaginertia", _fmt(diag))

    written: set[int] = set()
    big_m = float(masses.sum())
    for b, body in enumerate(model.bodies):
        parts = []  # (MJCF body id, mass, CoM in the MJCF body frame, its transform in F_body)
        for name in body.links:
            bid = body_id.get(name)
            if bid is not None and m.body_mass[bid] > 0:
                parts.append((bid, float(m.body_mass[bid]), m.body_ipos[bid], name))
        change = merged_body_change(src, "MJCF", body, sum(p[1] for p in parts), masses[b], coms[b])
        if change is not None:
            ratio, shift = change
            for bid, mk, ck, name in parts:
                x = model.link_frames[name][1]
                write(bid, mk * ratio, ck + x[:3, :3].T @ shift, ratio)
                written.add(bid)
        elif masses[b] > 1e-12 * big_m:
            bid = body_id.get(body.name)
            if bid is None or body.frame_only:
                raise ModelError(
                    f"{src}: the fit gives {masses[b]:.6g} kg to '{body.name}', a massless frame "
                    "between two hinges of one MJCF body, which cannot carry mass in MJCF"
                )
            x = model.link_frames[body.name][1]
            write(bid, masses[b], x[:3, :3].T @ (coms[b] - x[:3, 3]), None)
            written.add(bid)
    if from_geom or total_set:  # every other massive body needs its compiled inertial written
        for bid in range(1, m.nbody):
            if bid not in written and m.body_mass[bid] > 0:
                write(bid, float(m.body_mass[bid]), m.body_ipos[bid], 1.0)

    note = etree.Comment(
        f" masses and CoMs identified by sescid (method {fit.method_label}, "
        f"{fit.n_poses} poses, total mass {big_m:.6f} kg); other elements as in the source MJCF "
    )
    note.tail = "\n  "
    root.insert(0, note)
    out = Path(path)
    if out.resolve().parent != src.resolve().parent:
        for el in root.iter():
            name = el.get("file") if isinstance(el.tag, str) else None
            if name and not Path(name).is_absolute():
                warnings.append(
                    f"<{el.tag} file='{name}'> is relative to {src.parent}; it will not resolve "
                    f"from {out.parent} (geometry only: masses and CoMs are unaffected)"
                )
    head = src.read_bytes()[:100].lstrip()
    parts = [b'<?xml version="1.0" encoding="utf-8"?>'] if head.startswith(b"<?xml") else []
    parts += [etree.tostring(el) for el in reversed(list(root.itersiblings(preceding=True)))]
    parts += [etree.tostring(root, encoding="utf-8")]
    parts += [etree.tostring(el) for el in root.itersiblings()]
    with atomic_path(out) as tmp:
        tmp.write_bytes(b"\n".join(parts) + b"\n")
    return warnings
