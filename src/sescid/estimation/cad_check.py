"""Does the CAD model itself meet the constraints of the consistent-mass step?

The consistent step (``consistent``) asks for masses ≥ the mass floor, a given total mass and
each CoM inside its body's box. A CAD model can violate these by itself (a CoM outside the hull
of the body's collision shapes — the box is then grown to contain it; a massless body under a
positive floor; a weighed total that differs from the CAD's): ``cad_violations`` names them.
"""

from __future__ import annotations

import numpy as np

from sescid.estimation.fit import BodyInertials

TOTAL_TOL = 1e-9  #: kg, a total mass this close to the CAD's counts as the same


def cad_violations(inertials: BodyInertials, body_names: list[str]) -> list[str]:
    """One line per constraint that the CAD model (masses ``cad_masses``, boxes before growth)
    violates by itself; [] when it meets them all."""
    out = []
    if inertials.grown_boxes:
        out.append(
            f"CAD CoM outside its body's shape box for {len(inertials.grown_boxes)} body(ies) "
            f"({', '.join(inertials.grown_boxes)}): the boxes were grown to contain it"
        )
    cad = inertials.cad_masses
    if cad is not None:
        cad = np.asarray(cad, dtype=float)
        low = [body_names[i] for i in np.flatnonzero(cad < inertials.mass_floor - 1e-12)]
        if low:
            out.append(
                f"CAD mass below the mass floor {inertials.mass_floor:g} kg for {len(low)} "
                f"body(ies) ({', '.join(low[:6])}{' …' if len(low) > 6 else ''})"
            )
        if abs(float(cad.sum()) - inertials.total_mass) > TOTAL_TOL:
            out.append(
                f"CAD total mass {cad.sum():.4f} kg differs from the total imposed "
                f"({inertials.total_mass:.4f} kg)"
            )
    return out
