"""What export writes into an inertial, whatever the format: the identified mass and CoM spread
over the file's parts of a (merged) body, the rotational inertia closest to CAD's that is
physically consistent, and a warning when a body's mass leaves the CAD's neighbourhood.

- A sescid body may merge several file bodies (URDF fixed joints, MJCF bodies without joints).
  Its identified mass m and first moment h = m c are spread over the parts that carried mass:
  each part's mass × m / m_CAD and its CoM + (c − c_CAD), so the parts keep their layout and
  the merged body has exactly (m, c).
- Rotational inertia: with a part's mass and first moment fixed, the pseudo-inertia
  J = [[Σ, h], [hᵀ, m]] closest to CAD's in the log-det (Bregman) divergence
  tr(J J_CAD⁻¹) − log det(J J_CAD⁻¹) − 4 has the Schur complement Σ − h hᵀ/m of CAD's: the
  second moment about the CoM, hence the inertia tensor about the CoM, is CAD's, unchanged
  (static data say nothing about it; scaling it with the mass would invent a change).
- A CAD tensor that is not consistent (a massive point mass, a negative principal moment, the
  triangle inequality broken: ``sescid.model.inertia_problems``) has no such neighbour: export
  refuses, naming the links, unless asked to repair them (``repair_inertia``: Σ = ½ tr(I)·1 − I
  clipped at zero, a point mass given a ``NEW_BODY_RADIUS`` sphere's), each change reported.
- A body that was massless gets the inertia of a solid sphere of radius ``NEW_BODY_RADIUS``.
- A body whose exported mass leaves ±``MASS_WARN`` (50 %) of the CAD's is reported.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from sescid.base.text import listed
from sescid.errors import ModelError
from sescid.model.inertia import inertia_problems, repair_inertia

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


def merged_correction(masses, coms, ratio: float) -> np.ndarray:
    """ΔI (3, 3) kg·m², body-frame axes, to add to one part's tensor so that a merged body
    whose parts (CAD ``masses`` (k,) kg, CoMs (k, 3) m in the body frame) all scale by
    ``ratio`` and shift together keeps CAD's second moment about its CoM: the parts' spread
    term Σ m_k d_k d_kᵀ scales with the masses, so the parts' own second moments make up
    (1 − ratio)·S (zero for a single part)."""
    m = np.asarray(masses, dtype=float)
    c = np.asarray(coms, dtype=float).reshape(-1, 3)
    if m.size < 2 or not m.sum() > 0:
        return np.zeros((3, 3))
    d = c - (m @ c) / m.sum()
    sigma = (1.0 - ratio) * (d.T * m) @ d
    return np.trace(sigma) * np.eye(3) - sigma


def principal(tensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(moments (3,) kg·m², quaternion (4,) w x y z): ``tensor`` = R diag(moments) Rᵀ with R the
    rotation of the quaternion (columns: the principal axes in the tensor's frame)."""
    t = 0.5 * (np.asarray(tensor, dtype=float) + np.asarray(tensor, dtype=float).T)
    w, v = np.linalg.eigh(t)
    if np.linalg.det(v) < 0:
        v[:, 2] = -v[:, 2]
    return w, quaternion(v)


def quaternion(r: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z), w ≥ 0, of a rotation matrix (3, 3) (Shepperd's method)."""
    tr = float(np.trace(r))
    if tr > 0:
        s = 2.0 * np.sqrt(tr + 1.0)
        q = np.array([0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s,
                      (r[1, 0] - r[0, 1]) / s])  # fmt: skip
    else:
        i = int(np.argmax(np.diag(r)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(max(1.0 + r[i, i] - r[j, j] - r[k, k], 0.0))
        q = np.zeros(4)
        q[0] = (r[k, j] - r[j, k]) / s
        q[1 + i] = 0.25 * s
        q[1 + j] = (r[j, i] + r[i, j]) / s
        q[1 + k] = (r[k, i] + r[i, k]) / s
    q /= np.linalg.norm(q)
    return q if q[0] >= 0 else -q


#: the warning of a tensor ``exported_inertia`` repaired (``where`` "link NAME"), and its reader
REPAIRED = "{where}: inertia repaired (principal moments {before} → {after} kg·m²)"
_REPAIRED = re.compile(r"^link (.+): inertia repaired \(principal moments (.+) kg·m²\)$")


def repairs_summarised(warnings: list[str]) -> list[str]:
    """An export's warnings with the tensors repaired (``REPAIRED``, one a link) in one line when
    there are several (a robot with dozens of massless-inertia sensor links gave as many)."""
    repaired = [m for m in map(_REPAIRED.match, warnings) if m is not None]
    if len(repaired) < 2:
        return warnings
    items = [f"{m[1]} ({m[2]})" for m in repaired]
    where = "each in the file written"
    return [w for w in warnings if _REPAIRED.match(w) is None] + [
        f"{len(repaired)} links' inertia tensors repaired with the smallest change (principal "
        f"moments before → after, kg·m²): {listed(items, where=where)}"
    ]


def exported_inertia(
    tensor: np.ndarray, mass: float, where: str, repair: bool
) -> tuple[np.ndarray, str | None]:
    """The rotational inertia (3, 3) kg·m² about the CoM written for a part whose CAD tensor
    about its CoM is ``tensor`` and whose exported mass is ``mass`` kg, and a note.

    With the mass and first moment fixed, the pseudo-inertia closest to CAD's in the log-det
    (Bregman) divergence keeps CAD's second moment about the CoM: a consistent CAD tensor is
    written unchanged (not scaled with the mass). A tensor that is not (a point mass, or
    ``repair_inertia``'s rule broken) raises ModelError unless ``repair``: then the smallest
    change (``sescid.model.repair_inertia``) is written and named in the note."""
    t = 0.5 * (np.asarray(tensor, dtype=float) + np.asarray(tensor, dtype=float).T)
    if not np.isfinite(t).all():
        raise ModelError(f"{where}: the inertia tensor is not finite")
    if mass <= 0:
        return t, None
    fixed, changed = repair_inertia(t, mass)
    if not changed:
        return t, None
    before = ", ".join(f"{x:.3g}" for x in np.linalg.eigvalsh(t))
    after = ", ".join(f"{x:.3g}" for x in np.linalg.eigvalsh(fixed))
    if not repair:
        raise ModelError(
            f"{where}: the inertia tensor (principal moments {before} kg·m²) is not physically "
            "consistent; export --repair-inertia repairs it with the smallest change"
        )
    return fixed, REPAIRED.format(where=where, before=before, after=after)


def check_inertias(model, src: Path, repair: bool) -> None:
    """ModelError naming every link of ``model`` with mass whose CAD tensor is not physically
    consistent (``inertia_problems``), unless ``repair``."""
    problems = inertia_problems(model)
    if problems and not repair:
        shown = "; ".join(p.text() for p in problems[:3])
        more = f" and {len(problems) - 3} more" if len(problems) > 3 else ""
        raise ModelError(
            f"{src}: {len(problems)} link(s) with mass have an inertia tensor that is not "
            f"physically consistent ({shown}{more}; `sescid info` lists them): export "
            "--repair-inertia (repair_inertia=True) repairs them with the smallest change"
        )


def kept_notes(fit) -> list[str]:
    """The export's lines about bodies the data never determined (CAD's values kept)."""
    b = fit.inertials
    if b is None or not b.undetermined:
        return []
    return [
        f"{len(b.undetermined)} body(ies) not determined by the data keep CAD's mass, CoM and "
        f"inertia: {', '.join(b.undetermined)}"
    ]


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
