"""The exported inertial of every model link, whatever the output format: each sescid body's
identified mass and CoM spread over its links as ``sescid.io.export.inertia`` describes, the
tensor about the CoM in the link frame (``Part``). The USD writer uses it directly; the URDF
and MJCF writers edit their files' elements by the same rule. A further body (a payload) is one
more ``Part``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sescid.errors import ModelError
from sescid.estimation import Fit, fit_inertials
from sescid.io.export.inertia import (
    check_inertias,
    corrected,
    exported_inertia,
    kept_notes,
    mass_warnings,
    merged_body_change,
    merged_correction,
    sphere_inertia,
)


@dataclass(frozen=True)
class Part:
    """One link's exported inertial, in the link's own frame (SI units)."""

    link: str  #: the model file's link (URDF link, MJCF body) name
    mass: float  #: kg
    com: np.ndarray  #: (3,) m, link frame
    inertia: np.ndarray  #: (3, 3) kg·m² about the CoM, link-frame axes


def exported_parts(fit: Fit, repair_inertia: bool = False) -> tuple[list[Part], list[str]]:
    """Every link with mass after export (file order of the bodies) and the warnings
    (masses far from CAD, bodies kept at CAD, tensors repaired). ModelError for inconsistent
    CAD tensors unless ``repair_inertia``, and for mass on a frame that cannot carry it."""
    masses, coms = fit_inertials(fit)
    model = fit.robot.model
    src = Path(fit.robot.model_path)
    check_inertias(model, src, repair_inertia)
    warnings = mass_warnings(model, masses) + kept_notes(fit)
    parts: list[Part] = []
    big_m = float(masses.sum())
    for b, body in enumerate(model.bodies):
        cad = [
            (name, model.inertials[name])
            for name in body.links
            if name in model.inertials and model.inertials[name].mass > 0
        ]
        m_old = sum(inertial.mass for _, inertial in cad)
        change = merged_body_change(src, "model", body, m_old, masses[b], coms[b])
        if change is not None:
            ratio, shift = change
            frames = [model.link_frames[name][1] for name, _ in cad]
            at = [
                x[:3, :3] @ i.frame[:3, 3] + x[:3, 3] for x, (_, i) in zip(frames, cad, strict=True)
            ]
            delta = merged_correction([i.mass for _, i in cad], at, ratio)
            main = int(np.argmax([i.mass for _, i in cad]))
            for k, ((name, inertial), x) in enumerate(zip(cad, frames, strict=True)):
                rot = inertial.frame[:3, :3]
                tensor = np.zeros((3, 3)) if inertial.inertia is None else inertial.inertia
                mass = inertial.mass * ratio
                tensor, note = exported_inertia(
                    rot @ tensor @ rot.T, mass, f"link {name}", repair_inertia
                )
                if k == main:
                    r = x[:3, :3]
                    tensor, extra = corrected(tensor, r.T @ delta @ r, f"link {name}")
                    note = note or extra
                com = inertial.frame[:3, 3] + x[:3, :3].T @ shift
                parts.append(Part(name, mass, com, tensor))
                warnings += [note] if note else []
        elif masses[b] > 1e-12 * big_m:
            if body.frame_only or body.name not in model.link_frames:
                raise ModelError(
                    f"{src}: the fit gives {masses[b]:.6g} kg to '{body.name}', a frame that "
                    "cannot carry mass in the model file"
                )
            x = model.link_frames[body.name][1]
            com = x[:3, :3].T @ (coms[b] - x[:3, 3])
            parts.append(Part(body.name, float(masses[b]), com, np.diag(sphere_inertia(masses[b]))))
    return parts, warnings
