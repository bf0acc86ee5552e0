"""Does the CAD model itself meet the constraints of the consistent-mass step?

The consistent step (``consistent``) asks for masses ≥ the mass floor, a given total mass and
each CoM inside its body's box. A CAD model can violate these by itself (a CoM outside the hull
of the body's collision shapes — the box is then grown to contain it; a massless body under a
positive floor): ``cad_violations`` names them, one full line each, and notes a total mass
imposed (weighed or given) that differs from the CAD's — a fact of the fit, not a violation.
"""

from __future__ import annotations

import numpy as np

from sescid.base.text import listed
from sescid.estimation.result.records import BodyInertials

TOTAL_TOL = 1e-9  #: kg, a total mass this close to the CAD's counts as the same


def cad_violations(inertials: BodyInertials, body_names: list[str]) -> list[str]:
    """One line per constraint that the CAD model (masses ``cad_masses``, boxes before growth)
    violates by itself, each saying so, and one noting an imposed total that differs from the
    CAD's; [] when there is nothing to say."""
    bad = "the CAD model itself violates a constraint: "
    out = []
    if inertials.grown_boxes:
        out.append(
            f"{bad}CAD CoM outside its body's shape box for {len(inertials.grown_boxes)} body(ies) "
            f"({listed(inertials.grown_boxes)}): the boxes were grown to contain it"
        )
    cad = inertials.cad_masses
    if cad is not None:
        cad = np.asarray(cad, dtype=float)
        low = [body_names[i] for i in np.flatnonzero(cad < inertials.mass_floor - 1e-12)]
        if low:
            out.append(
                f"{bad}CAD mass below the mass floor {inertials.mass_floor:g} kg for {len(low)} "
                f"body(ies) ({listed(low, first=6)})"
            )
        if abs(float(cad.sum()) - inertials.total_mass) > TOTAL_TOL:
            out.append(
                f"the total mass imposed ({inertials.total_mass:.4f} kg, weighed or given) "
                f"differs from the CAD model's {cad.sum():.4f} kg: the masses are fitted to it"
            )
    return out
