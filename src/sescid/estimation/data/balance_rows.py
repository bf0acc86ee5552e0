"""The balance measurement kind: a robot balancing on a line (a wheel axle, an edge).

At a pose balanced on a line through the support frame's origin with direction u (``Robot.line``)
the CoM lies vertically above (or below) the line: its horizontal offset across the line,

    s = n · CoM(q)        n = (u × up) / |u × up|,  up = −g/|g|  (support frame)

is 0 (or the measured ``balance`` value). ``CoM = d + Φ(q) vec(r)`` makes it one linear row per
pose in the SESC vectors, whatever the tilt (n stays horizontal and of unit length as long as
gravity does not run along the line). Each row is divided by ρ, the distance of the prior
model's CoM from the line at that pose (never below ``MIN_RHO``): its residual is then the tilt
about the line, in radians, that would balance the robot — what an IMU's pitch error is — so the
kind's noise is an angle.

The targets of balanced poses are all 0: the data fix the directions and ratios of the first
moments but not their scale (the model with all its mass on the line fits them exactly). The
fit takes the scale from elsewhere (``estimation.anchor``).
"""

from __future__ import annotations

import numpy as np

from sescid.robot import Robot
from sescid.sesc import line_across, line_distance

#: smallest distance of the prior model's CoM from the line used to scale a row, m
MIN_RHO = 1e-3


def balance_rows(
    robot: Robot, q: np.ndarray, offset: np.ndarray, gravity: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The balance rows of validated poses as columns: x (3N, n) and targets y (n,), both
    divided by the prior model's distance from the line (module docstring)."""
    assert robot.line is not None
    phi = robot.regressor(q, (0, 1, 2))  # (n, 3, 3N)
    n_dir = line_across(robot.line, gravity)
    x = np.einsum("na,nap->pn", n_dir, phi)
    y = offset - n_dir @ robot.d
    rho = np.maximum(line_distance(robot.line, robot.com(q)), MIN_RHO)
    return x / rho, y / rho


def balance_residuals(
    robot: Robot, r: np.ndarray, q: np.ndarray, offset: np.ndarray, gravity: np.ndarray
) -> np.ndarray:
    """(n,) residuals of the balance rows for SESC vectors r (N, 3): measured minus predicted
    offset across the line, over the prior model's distance from it (rad)."""
    assert robot.line is not None
    n_dir = line_across(robot.line, gravity)
    com = robot.com(q, r)
    pred = n_dir[:, 0] * com[:, 0] + n_dir[:, 1] * com[:, 1] + n_dir[:, 2] * com[:, 2]
    rho = np.maximum(line_distance(robot.line, robot.com(q)), MIN_RHO)
    return (offset - pred) / rho
