"""Inertia tensors as the model file gives them: per-body parts, and the physical-validity rule.

Statics (CoM, CoP) uses masses and CoMs only; the inertia tensors matter to the physics bench
and to export. ``inertia_parts`` lists, per sescid body, each link's (mass, CoM, inertia) in the
body frame, read once with the model (no second parse of the file). ``inertia_issue`` is the one
home of the rule a physical inertia tensor obeys (finite, symmetric, positive principal moments
that satisfy the triangle inequality); ``repair_inertia`` the smallest change that makes a tensor
obey it (Σ = ½ tr(I)·1 − I clipped at zero); ``inertia_problems`` every link breaking it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from sescid.model.tree import RobotModel

#: tolerances of the validity rule, relative to the tensor's largest entry and absolute (kg·m²,
#: about 1 g at 0.03 mm): rounding noise on a zero tensor (iCub's 1e-20) is a point mass
INERTIA_RTOL = 1e-9
INERTIA_ATOL = 1e-12
#: m, radius of the solid sphere whose inertia a massive point mass (or a newly massive body)
#: gets when repaired
NEW_BODY_RADIUS = 0.01


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


def second_moment(inertia: np.ndarray) -> np.ndarray:
    """Σ = ½ tr(I)·1 − I (3, 3) kg·m²: the density's second moment about the CoM, whose
    eigenvalues ≥ 0 are what a physical (pseudo-inertia positive semi-definite) tensor obeys."""
    t = 0.5 * (np.asarray(inertia, dtype=float) + np.asarray(inertia, dtype=float).T)
    return 0.5 * np.trace(t) * np.eye(3) - t


def sphere_inertia(mass: float) -> np.ndarray:
    """Principal moments (3,) kg·m² of a solid sphere of ``NEW_BODY_RADIUS`` and ``mass``."""
    return np.full(3, 0.4 * mass * NEW_BODY_RADIUS**2)


def repair_inertia(inertia: np.ndarray, mass: float = 0.0) -> tuple[np.ndarray, bool]:
    """The physical tensor (3, 3) kg·m² closest to ``inertia`` and whether it changed: Σ's
    negative eigenvalues clipped at zero (the smallest change in Σ's Frobenius norm), the
    tensor rebuilt as tr(Σ)·1 − Σ. A zero tensor of a body with ``mass`` > 0 kg (a point mass,
    whose pseudo-inertia is singular) becomes a solid sphere's of ``NEW_BODY_RADIUS``. A tensor
    that obeys ``inertia_issue``'s rule is returned unchanged (symmetrised)."""
    t = 0.5 * (np.asarray(inertia, dtype=float) + np.asarray(inertia, dtype=float).T)
    if not np.all(np.isfinite(t)):
        raise ValueError("the inertia tensor is not finite")
    if mass > 0 and float(np.abs(t).max()) <= INERTIA_ATOL:
        return np.diag(sphere_inertia(mass)), True
    if physical(t)[0]:
        return t, False
    w, v = np.linalg.eigh(second_moment(t))
    sigma = (v * np.maximum(w, 0.0)) @ v.T
    out = np.trace(sigma) * np.eye(3) - sigma
    return 0.5 * (out + out.T), True


@dataclass(frozen=True)
class InertiaProblem:
    """A model link whose CAD inertia tensor is not that of a rigid body with volume."""

    link: str
    mass: float  #: kg
    kind: Literal["point mass", "not physical"]
    deficit: float  #: kg·m², the most negative eigenvalue of Σ (0 for a point mass)
    moments: tuple[float, float, float]  #: principal moments, kg·m², ascending

    def text(self) -> str:
        """One line for a report."""
        a, b, c = (f"{x:.3g}" for x in self.moments)
        if self.kind == "point mass":
            return f"{self.link}: {self.mass:.4g} kg with a zero inertia tensor (a point mass)"
        how = (
            f"negative principal moment {a} kg·m²"
            if self.moments[0] < 0
            else f"triangle inequality broken: {c} > {a} + {b} kg·m²"
        )
        return (
            f"{self.link}: {self.mass:.4g} kg, {how} (second moment {self.deficit:.3g} kg·m² "
            "below zero)"
        )


def inertia_problems(model: RobotModel) -> list[InertiaProblem]:
    """Every link with mass whose inertia tensor is zero (a point mass) or not physical
    (``inertia_issue``), in the file's order."""
    out = []
    for name, inertial in model.inertials.items():
        if not inertial.mass > 0 or inertial.inertia is None:
            continue
        t = np.asarray(inertial.inertia, dtype=float)
        if not np.all(np.isfinite(t)):
            continue
        w = np.linalg.eigvalsh(0.5 * (t + t.T))
        moments = (float(w[0]), float(w[1]), float(w[2]))
        if float(np.abs(t).max()) <= INERTIA_ATOL:
            out.append(InertiaProblem(name, inertial.mass, "point mass", 0.0, moments))
        elif not physical(t)[0]:
            deficit = float(np.linalg.eigvalsh(second_moment(t))[0])
            out.append(InertiaProblem(name, inertial.mass, "not physical", deficit, moments))
    return out
