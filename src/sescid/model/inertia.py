"""Inertia tensors as the model file gives them: per-body parts, and the physical-validity rule.

Statics (CoM, CoP) uses masses and CoMs only; the inertia tensors matter to the physics bench
and to export. ``inertia_parts`` lists, per sescid body, each link's (mass, CoM, inertia) in the
body frame, read once with the model (no second parse of the file). ``inertia_issue`` is the one
home of the rule a physical inertia tensor obeys (finite, symmetric, positive principal moments
that satisfy the triangle inequality).
"""

from __future__ import annotations

import numpy as np

from sescid.model.tree import RobotModel

#: tolerances of the validity rule, relative to the tensor's largest entry and absolute (kg·m²,
#: about 1 g at 0.03 mm): rounding noise on a zero tensor (iCub's 1e-20) is a point mass
INERTIA_RTOL = 1e-9
INERTIA_ATOL = 1e-12


def physical(inertias: np.ndarray) -> np.ndarray:
    """(n,) bool: which of ``inertias`` (n, 3, 3) [kg·m²] obey the rule of ``inertia_issue``."""
    t = np.asarray(inertias, dtype=float).reshape(-1, 3, 3)
    ok = np.all(np.isfinite(t), axis=(1, 2))
    t = np.where(ok[:, None, None], t, 0.0)
    tol = np.maximum(INERTIA_RTOL * np.abs(t).max(axis=(1, 2)), INERTIA_ATOL)
    ok &= np.abs(t - t.transpose(0, 2, 1)).max(axis=(1, 2)) <= tol
    moments = np.linalg.eigvalsh(np.where(ok[:, None, None], t, 0.0))
    ok &= moments[:, 0] >= -tol
    return ok & (moments[:, 2] <= moments[:, 0] + moments[:, 1] + tol)


def inertia_issue(inertia: np.ndarray) -> str | None:
    """Why a (3, 3) inertia tensor [kg·m²] about a CoM is not physical, or None when it is.

    Physical: finite, symmetric, principal moments ≥ 0 and each at most the sum of the other two
    (within ``INERTIA_RTOL`` of the largest entry or ``INERTIA_ATOL``). A zero tensor (a point
    mass) is physical.
    """
    t = np.asarray(inertia, dtype=float)
    if t.shape != (3, 3) or not np.all(np.isfinite(t)):
        return "has a non-finite or missing component"
    if physical(t)[0]:
        return None
    tol = max(INERTIA_RTOL * float(np.abs(t).max()), INERTIA_ATOL)
    if np.abs(t - t.T).max() > tol:
        return "is not symmetric"
    moments = np.linalg.eigvalsh(t)
    if moments[0] < -tol:
        return f"has a negative principal moment ({moments[0]:.3g} kg·m²)"
    a, b, c = (f"{v:.3g}" for v in moments)
    return f"violates the triangle inequality (principal moments {a}, {b}, {c} kg·m²)"


def inertia_parts(model: RobotModel) -> dict[int, list[tuple[float, np.ndarray, np.ndarray]]]:
    """Per body index: (mass kg, CoM (3,) m, inertia (3, 3) kg·m² about that CoM), body frame,
    one entry per link (MJCF body) with mass > 0 and an inertia tensor, in file order."""
    out: dict[int, list[tuple[float, np.ndarray, np.ndarray]]] = {}
    for name, inertial in model.inertials.items():
        if name not in model.link_frames or not inertial.mass > 0 or inertial.inertia is None:
            continue
        b, x = model.link_frames[name]
        t = x @ inertial.frame
        rot = t[:3, :3]
        out.setdefault(b, []).append(
            (inertial.mass, t[:3, 3].copy(), rot @ inertial.inertia @ rot.T)
        )
    return out
