"""What a tilted support adds to a fit: the CoM-height direction and how well it is determined.

On a level sole each pose gives the x/y rows of the CoM; the robot's structural identifiable
subspace is their row space (``Robot.reduction``). Under tilted gravity the rows are
``Φ_xy − (g_xy/g_z) Φ_z``: the part of the z row outside that subspace (on the OP2 a constant
CoM-height offset, the support body's vertical SESC component) becomes observable, but only
through ``g_xy/g_z`` — a few mrad on a bench — so least squares determines it badly. This module
finds that direction in a fit's identifiable basis and reports the CoM-height offset along it
with its standard error (``tilt_direction``); ``checks.fit_warnings`` warns when least squares
leaves it uncertain (prefer MAP, whose prior keeps it near CAD).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from sescid.estimation.result.identifiability import basis_of
from sescid.robot import Robot

if TYPE_CHECKING:  # pragma: no cover
    from sescid.estimation.result.fit import Fit

#: relative standard error of the tilt-determined CoM-height offset above which an LS fit warns
TILT_REL_STD_WARN = 0.1


@dataclass(frozen=True)
class TiltDirection:
    """The CoM-height offset a tilted support determines (m), at the zero pose."""

    direction: np.ndarray  #: (3N,) unit vector in vec(r) space, outside the level subspace
    value: float  #: m, the fit's CoM-height contribution along it
    std: float  #: m, its standard error (from fit.cov)
    prior: float  #: m, the prior model's contribution along it

    @property
    def rel_std(self) -> float:
        """Relative standard error std / |value| (inf when the value is 0)."""
        return self.std / abs(self.value) if self.value else math.inf


def level_basis(robot: Robot) -> np.ndarray:
    """(3N, p) orthonormal basis of the x/y rows' structural row space (a level sole)."""
    return basis_of(robot.reduction.g.T, 1e-10)


def tilt_direction(fit: Fit) -> TiltDirection | None:
    """The direction of ``fit.basis`` outside the level subspace (None when there is none).
    Only a fit of one stance's CoP alone has one from a tilt: joint torques see beyond the
    level CoP's subspace on level ground, and so do stances pooled over the body parameters."""
    kinds = {k.kind for k in fit.kinds}
    if fit.bodies is not None or (kinds and kinds != {"cop"}):
        return None
    level = level_basis(fit.robot)
    extra = fit.basis - level @ (level.T @ fit.basis)
    if extra.size == 0:
        return None
    u, s, _ = np.linalg.svd(extra, full_matrices=False)
    if s[0] < 0.5:
        return None
    d = u[:, 0]
    phi_z = fit.robot.regressor(np.zeros((1, fit.robot.nq)), (2,))[0, 0]
    a = float(phi_z @ d)
    var = float(d @ np.nan_to_num(fit.cov) @ d)
    return TiltDirection(
        direction=d,
        value=a * float(d @ fit.r.reshape(-1)),
        std=abs(a) * math.sqrt(max(var, 0.0)),
        prior=a * float(d @ fit.r_prior.reshape(-1)),
    )
