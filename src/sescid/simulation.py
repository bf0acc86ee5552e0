"""Synthetic CoP data with known truth: random poses, the CoP they give plus noise.

The paper's §3 settings (``PAPER_*``) live here, their one home; the study itself (simulate,
identify, validate) is ``sescid.experiment.paper_study``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .errors import OptionError

if TYPE_CHECKING:  # pragma: no cover
    from .robot import Robot

#: the paper's §3 settings
PAPER_POSES = 1000
PAPER_RANGE_DEG = 30.0
PAPER_NOISE = 0.00493  #: m, CoP noise standard deviation (Ha et al. 2013)
PAPER_MAE = 0.0040  #: m, the mean absolute CoP error the paper reports for n = 1000


@dataclass
class SimData:
    """Simulated poses (n, nq) [rad], noisy CoP (n, 2) [m] and the noise-free CoP (n, 2) [m]."""

    q: np.ndarray
    cop: np.ndarray
    cop_true: np.ndarray
    noise: float


def random_poses(
    robot: Robot,
    n: int,
    range_deg: float = PAPER_RANGE_DEG,
    rng: np.random.Generator | int | None = 0,
    clip: bool = False,
) -> np.ndarray:
    """Joint angles (n, nq) [rad] uniform in ±range_deg; clipped to the joint limits if asked."""
    if n < 1:
        raise OptionError("n", f"number of poses must be ≥ 1, got {n}")
    if not (range_deg > 0 and math.isfinite(range_deg)):
        raise OptionError("range_deg", f"must be a positive number of degrees, got {range_deg}")
    rng = np.random.default_rng(rng)
    half = math.radians(range_deg)
    q = rng.uniform(-half, half, size=(n, robot.nq))
    if clip:
        lim = robot.joint_limits
        q = np.clip(q, lim[:, 0], lim[:, 1])
    return q


def simulate(
    robot: Robot,
    n: int = PAPER_POSES,
    range_deg: float = PAPER_RANGE_DEG,
    noise: float = PAPER_NOISE,
    seed: int | None = 0,
    clip: bool = False,
    r_true: np.ndarray | None = None,
) -> SimData:
    """Random poses and their CoP = CoM projection + N(0, noise²) per axis.

    ``r_true``: SESC vectors of the "true" robot (default: the model's own).
    """
    if not (noise >= 0 and math.isfinite(noise)):
        raise OptionError("noise", f"must be a finite standard deviation ≥ 0 m, got {noise}")
    rng = np.random.default_rng(seed)
    q = random_poses(robot, n, range_deg, rng, clip)
    cop_true = robot.cop(q, r_true)
    cop = cop_true + rng.normal(0.0, noise, size=cop_true.shape)
    return SimData(q=q, cop=cop, cop_true=cop_true, noise=noise)
