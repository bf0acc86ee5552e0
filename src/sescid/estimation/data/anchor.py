"""Homogeneous data: measurements whose every target the "all mass at the support" model meets.

A robot balancing on a line (or a point) is measured by where its CoM is *not*: every balanced
pose says the CoM lies over the support, whatever the robot weighs and however far from the
support its mass sits. The model with all its mass at the support's origin (the collapse point
θ_c: CoM ≡ the origin) fits such data exactly, and so does every model θ_c + λ (θ − θ_c) on the
line through it: the data fix the directions and ratios of the first moments, not their scale.
Least squares would return the collapse point (a residual of 0 on noisy data), and a fit that
chooses its noise level by evidence would follow it.

``homogeneous`` detects such data from the sums (the collapse point's residual vanishes for every
kind), and ``anchored`` pins the scale: the system is restricted to the models whose CoM height
at the zero pose, along the prior model's CoM direction there (``scale_functional``), equals the
prior's. The restricted sums equal the data's on that set and see nothing along the pinned
direction, so every solver runs on them unchanged and fills that direction from the prior
(least squares) or keeps it at the prior with the prior's uncertainty (MAP). A known CoM height
(``rescale``) replaces the prior's scale afterwards: the data cannot tell the two apart.
"""

from __future__ import annotations

import math

import numpy as np

from sescid.estimation.sums.system import System, pinned_system
from sescid.robot import Robot

#: the collapse point's residual below this share of the prior model's marks homogeneous data
HOMOGENEOUS_RSS = 1e-20


def collapse_point(robot: Robot, system: System) -> np.ndarray:
    """θ_c = [vec(r_c); 0]: all the mass at the support frame's origin (CoM ≡ 0); for a pooled
    system (``pooled``) the body parameters of all the mass in the support body, there."""
    theta = np.zeros(system.size)
    r0 = -robot.tree.root_r.T @ robot.d  # d + B_0 r_0 = 0, every other r_i = 0
    if system.space == "bodies":
        from sescid.estimation.sums.pooled import PARAM_UNIT

        n = len(robot.body_names)
        theta[0] = 1.0
        theta[n : n + 3] = r0 / PARAM_UNIT
        return theta
    theta[:3] = r0
    return theta


def homogeneous(robot: Robot, system: System, theta0: np.ndarray) -> bool:
    """True when the collapse point meets every row of every kind (to round-off, against the
    prior model's residual): the data carry no scale (module docstring)."""
    theta_c = collapse_point(robot, system)
    for part in system.parts.values():
        rss0 = abs(part.ne.rss(theta0))
        scale = max(rss0, float(np.abs(part.ne.ata).max()) * float(theta0 @ theta0), 1e-300)
        if abs(part.ne.rss(theta_c)) > HOMOGENEOUS_RSS * scale + 1e-30:
            return False
    return True


def scale_functional(robot: Robot, n_params: int, r_prior: np.ndarray) -> np.ndarray:
    """A (P,): the CoM's component at the zero pose along the prior model's CoM direction
    there (perpendicular to the support line, if any), as a linear function of θ."""
    q0 = np.zeros((1, robot.nq))
    com = robot.com(q0, r_prior)[0]
    if robot.line is not None:
        com = com - (com @ robot.line) * robot.line
    norm = float(np.linalg.norm(com))
    e = com / norm if norm > 1e-9 else np.array([0.0, 0.0, 1.0])
    phi = robot.regressor(q0, (0, 1, 2))[0]  # (3, 3N)
    a = np.zeros(n_params)
    a[: phi.shape[1]] = e @ phi
    return a


def anchored(system: System, a: np.ndarray, theta0: np.ndarray) -> System:
    """The system restricted to aᵀθ = aᵀθ0 (``system.pinned`` along a): the residual of every
    model in that set is the data's, and no solver moves along a."""
    return pinned_system(system, a[:, None], theta0)


def com_distance(robot: Robot, r: np.ndarray) -> float:
    """The CoM's distance from the support (its line, if any) at the zero pose, m."""
    com = robot.com(np.zeros((1, robot.nq)), r)[0]
    if robot.line is not None:
        com = com - (com @ robot.line) * robot.line
    return float(np.linalg.norm(com))


def rescale(robot: Robot, r: np.ndarray, height: float) -> float:
    """λ that scales r about the collapse point so that the CoM's distance from the support at
    the zero pose is ``height`` [m] (the model's must not be 0)."""
    now = com_distance(robot, r)
    if not (math.isfinite(height) and height > 0):
        raise ValueError(f"CoM height must be a positive length in m, got {height}")
    return height / now if now > 0 else math.nan
