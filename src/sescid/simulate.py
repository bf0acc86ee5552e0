"""Synthetic CoP data with known truth (the paper's §3 simulation study)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import SescidError
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
        raise SescidError(f"number of poses must be ≥ 1, got {n}")
    if not (range_deg > 0 and math.isfinite(range_deg)):
        raise SescidError(f"range must be a positive number of degrees, got {range_deg}")
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
        raise SescidError(f"noise must be a finite standard deviation ≥ 0 m, got {noise}")
    rng = np.random.default_rng(seed)
    q = random_poses(robot, n, range_deg, rng, clip)
    cop_true = robot.cop(q, r_true)
    cop = cop_true + rng.normal(0.0, noise, size=cop_true.shape)
    return SimData(q=q, cop=cop, cop_true=cop_true, noise=noise)


@dataclass
class PaperStudy:
    """Numbers of the paper's §3 study (all in metres)."""

    fit: object  #: the Fit
    sim: SimData  #: the identification data
    fresh: SimData  #: fresh poses from the same distribution, for validation
    mae: float  #: mean |estimated − measured CoP| at the fitted poses (paper: 0.0040)
    noise_floor_mae: float  #: 0.798 σ √(1 − p/2n): the MAE an exact model would show
    rmse_fitted: float  #: RMS of estimated − noise-free CoP at the fitted poses
    rmse_fitted_theory: float  #: σ √(p / 2n)
    rmse_fresh: float  #: the same at fresh poses
    rmse_fresh_theory: float  #: σ √(p / (2n − p − 1))
    rmse_prior_fresh: float  #: the URDF model's own CoP error at fresh poses (0 in simulation)


def paper_study(
    robot: Robot,
    n: int = PAPER_POSES,
    range_deg: float = PAPER_RANGE_DEG,
    noise: float = PAPER_NOISE,
    seed: int = 0,
    n_fresh: int = 20000,
    r_true: np.ndarray | None = None,
) -> PaperStudy:
    """Simulate, identify and validate as in the paper's §3, with the theory beside."""
    from .estimate import identify

    sim = simulate(robot, n, range_deg, noise, seed, r_true=r_true)
    fresh = simulate(
        robot, n_fresh, range_deg, noise, None if seed is None else seed + 1, r_true=r_true
    )
    fit = identify(robot, sim.q, sim.cop)
    p, rows = fit.rank, 2 * n

    def rms(a):
        return float(np.sqrt(np.mean(a**2)))

    return PaperStudy(
        fit=fit,
        sim=sim,
        fresh=fresh,
        mae=fit.mae,
        noise_floor_mae=math.sqrt(2 / math.pi) * noise * math.sqrt(max(1 - p / rows, 0.0)),
        rmse_fitted=rms(fit.predict_cop(sim.q) - sim.cop_true),
        rmse_fitted_theory=noise * math.sqrt(p / rows),
        rmse_fresh=rms(fit.predict_cop(fresh.q) - fresh.cop_true),
        rmse_fresh_theory=noise * math.sqrt(p / max(rows - p - 1, 1)),
        rmse_prior_fresh=rms(robot.cop(fresh.q) - fresh.cop_true),
    )
