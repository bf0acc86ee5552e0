"""The exported inertial of every model link, whatever the output format: each sescid body's
identified mass and CoM spread over its links as ``sescid.io.export.inertia`` describes, the
tensor about the CoM in the link frame (``Part``): the one home of what is written. The URDF,
MJCF and USD writers only put each ``Part`` into their files' elements (their
``write_inertial``); a further body (a payload) is one more ``Part``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sescid.errors import ModelError
from sescid.estimation import Fit, fit_inertials
from sescid.io.export.inertia import (
    check_inertias,
    exported_inertia,
    kept_notes,
    mass_warnings,
    merged_body_change,
    merged_correction,
)
from sescid.model.inertia import repair_inertia, sphere_inertia


@dataclass(frozen=True)
class Part:
    """One link's exported inertial, in the link's own frame (SI units)."""

    link: str  #: the model file's link (URDF link, MJCF body) name
    mass: float  #: kg
    com: np.ndarray  #: (3,) m, link frame
    inertia: np.ndarray  #: (3, 3) kg·m² about the CoM, link-frame axes
    new: bool = False  #: the link had no mass in the model (a small sphere's inertia)


def spread(tensors: list[np.ndarray], masses, delta: np.ndarray, where: list[str]):
    """Body-frame additions (one (3, 3) per part) that give a merged body's parts ``delta``
    (``merged_correction``) in total while every part stays consistent: all on the heaviest
    part, else shared in proportion to the masses, else each part given its mass's share of
    the body's total, else (the body's own tensor cannot be held) the heaviest part made
    consistent with the smallest change, with a note naming it. Returns (additions, note)."""
    k = len(tensors)
    zero = [np.zeros((3, 3)) for _ in range(k)]
    if not np.any(delta):
        return zero, None
    main = int(np.argmax(masses))
    fixed, changed = repair_inertia(tensors[main] + delta)
    if not changed:
        zero[main] = delta
        return zero, None
    share = np.asarray(masses, dtype=float) / float(np.sum(masses))
    if all(not repair_inertia(t + w * delta)[1] for t, w in zip(tensors, share, strict=True)):
        return [w * delta for w in share], None
    total = sum(tensors) + delta
    if not repair_inertia(total)[1]:  # the body's can be held: each part a share of it
        return [w * total - t for t, w in zip(tensors, share, strict=True)], None
    zero[main] = fixed - tensors[main]
    return zero, (
        f"{where[main]}: its merged body's CAD second moment about the CoM cannot be kept with "
        "its parts scaled together; the closest consistent tensor written"
    )


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
            rots = [model.link_frames[name][1][:3, :3] for name, _ in cad]
            own = []  # each part's tensor about its CoM, link frame (consistent or repaired)
            for name, inertial in cad:
                r = inertial.frame[:3, :3]
                t = np.zeros((3, 3)) if inertial.inertia is None else inertial.inertia
                t, note = exported_inertia(
                    r @ t @ r.T, inertial.mass * ratio, f"link {name}", repair_inertia
                )
                own.append(t)
                warnings += [note] if note else []
            at = [
                model.link_frames[n][1][:3, :3] @ i.com + model.link_frames[n][1][:3, 3]
                for n, i in cad
            ]
            delta = merged_correction([i.mass for _, i in cad], at, ratio)
            body_frame = [r @ t @ r.T for r, t in zip(rots, own, strict=True)]
            names = [f"link {n}" for n, _ in cad]
            add, note = spread(body_frame, [i.mass for _, i in cad], delta, names)
            warnings += [note] if note else []
            for (name, inertial), r, t, a in zip(cad, rots, own, add, strict=True):
                com = inertial.com + r.T @ shift
                parts.append(Part(name, inertial.mass * ratio, com, t + r.T @ a @ r))
        elif masses[b] > 1e-12 * big_m:
            if body.frame_only or body.name not in model.link_frames:
                raise ModelError(
                    f"{src}: the fit gives {masses[b]:.6g} kg to '{body.name}', a massless frame "
                    "between two hinges of one MJCF body, which cannot carry mass in MJCF"
                    if body.frame_only
                    else f"{src}: the fit gives {masses[b]:.6g} kg to '{body.name}', a frame "
                    "that cannot carry mass in the model file"
                )
            x = model.link_frames[body.name][1]
            com = x[:3, :3].T @ (coms[b] - x[:3, 3])
            sphere = np.diag(sphere_inertia(masses[b]))
            parts.append(Part(body.name, float(masses[b]), com, sphere, new=True))
    return parts, warnings
