"""What export writes into an inertial, whatever the format: the identified mass and CoM spread
over the file's parts of a (merged) body, an inertia tensor that is physically valid, and a
warning when a body's mass leaves the CAD's neighbourhood.

- A sescid body may merge several file bodies (URDF fixed joints, MJCF bodies without joints).
  Its identified mass m and CoM c are spread over the parts that carried mass: each part's mass
  and inertia × m / m_CAD and its CoM + (c − c_CAD), so the parts keep their layout and the
  merged body has exactly (m, c). Inertias keep their axes and scale with the mass: static data
  do not identify them.
- A body that was massless, or whose tensor is (nearly) zero, gets the inertia of a solid
  sphere of radius ``NEW_BODY_RADIUS``.
- Every written tensor is checked: positive definite and physical by the model's rule
  (``sescid.model.inertia_issue``: symmetric, principal moments a ≤ b ≤ c with a + b ≥ c, what
  MuJoCo demands and any rigid body has). A CAD tensor that is not is replaced by a valid one on
  the same axes (moments floored at ``MIN_MOMENT`` × the largest, the largest lowered to
  a + b), with a warning.
- A body whose exported mass leaves ±``MASS_WARN`` (50 %) of the CAD's is reported.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sescid.errors import ModelError
from sescid.model.inertia import INERTIA_ATOL, inertia_issue

#: m, radius of the solid sphere whose inertia a newly massive body gets
NEW_BODY_RADIUS = 0.01
#: smallest principal moment written, relative to the largest (a flat plate keeps a sliver)
MIN_MOMENT = 1e-6
#: relative change of a body's mass from the CAD's beyond which export warns
MASS_WARN = 0.5


def fmt(values) -> str:
    """Numbers as their shortest exact decimals (``repr``), space-separated."""
    return " ".join(repr(float(v)) for v in values)


def merged_body_change(
    src: Path, kind: str, body, m_old: float, mass: float, com: np.ndarray
) -> tuple[float, np.ndarray] | None:
    """How the file's parts of a (merged) body move to the identified mass (kg) and CoM (body
    frame, m): every part's mass times ``ratio`` and its CoM plus ``shift`` (body frame); None
    when the parts weigh nothing. ``m_old``: the parts' mass in the ``kind`` file ("URDF",
    "MJCF"), which must be the fit's model's (else ModelError: the file changed)."""
    if abs(m_old - body.mass) > 1e-9 * max(1.0, body.mass):
        raise ModelError(
            f"{src}: body {body.name} weighs {m_old} kg in the {kind} but {body.mass} kg in "
            f"the fit's model; the {kind} changed since the fit was made"
        )
    if not m_old > 0:
        return None
    return mass / m_old, com - body.com


def sphere_inertia(mass: float) -> np.ndarray:
    """Principal moments (3,) kg·m² of a solid sphere of ``NEW_BODY_RADIUS`` and ``mass``."""
    return np.full(3, 0.4 * mass * NEW_BODY_RADIUS**2)


def valid_inertia(tensor: np.ndarray, mass: float, where: str) -> tuple[np.ndarray, str | None]:
    """``tensor`` (3, 3) kg·m² about the CoM if positive definite and physical (the model's
    rule, ``sescid.model.inertia_issue``), else a valid tensor on the same principal axes and a
    warning naming ``where``. A body with mass whose tensor is zero (a point mass, within the
    rule's absolute tolerance) gets the sphere's; a massless body's tensor is left as it is."""
    t = 0.5 * (np.asarray(tensor, dtype=float) + np.asarray(tensor, dtype=float).T)
    if not np.isfinite(t).all():
        raise ModelError(f"{where}: the inertia tensor is not finite")
    if mass <= 0:
        return t, None
    w, v = np.linalg.eigh(t)  # ascending
    top = float(w[-1])
    if top <= INERTIA_ATOL:
        return np.diag(sphere_inertia(mass)), (
            f"{where}: no inertia in the model (largest principal moment {top:.3g} kg·m² for "
            f"{mass:.4g} kg); written as a {NEW_BODY_RADIUS * 1000:g} mm solid sphere's"
        )
    issue = inertia_issue(t)
    if issue is None and w[0] > 0:
        return t, None
    fixed = np.maximum(w, MIN_MOMENT * top)
    if fixed[0] + fixed[1] < fixed[2]:
        fixed[2] = (fixed[0] + fixed[1]) * (1 - 1e-12)  # strictly inside after round-off
    out = (v * fixed) @ v.T
    return 0.5 * (out + out.T), (
        f"{where}: the model's inertia {issue or 'has a zero principal moment'}; written as a "
        f"valid tensor on the same axes (principal moments "
        f"{', '.join(f'{x:.3g}' for x in fixed)} kg·m²)"
    )


def mass_warnings(model, masses: np.ndarray) -> list[str]:
    """One line per body whose exported mass (kg) leaves ±MASS_WARN of the CAD's."""
    out = []
    for body, m in zip(model.bodies, masses, strict=True):
        cad = float(body.mass)
        if cad > 0 and abs(m / cad - 1) > MASS_WARN:
            out.append(
                f"body {body.name}: exported mass {m:.4g} kg is {100 * (m / cad - 1):+.0f} % of "
                f"the CAD's {cad:.4g} kg (beyond ±{100 * MASS_WARN:.0f} %: check the fit's "
                "constraints, e.g. --cad-std, before using it)"
            )
    return out
