"""The paper's §3 simulation study: simulate, identify and validate, with the theory beside.

1000 random poses (joints uniform in ±30°), Gaussian CoP noise σ = 4.93 mm; the statistics of
least squares (``shared/reference/theory.md``): MAE → 0.798σ√(1 − p/2n) (the paper's 4.0 mm is
this noise floor), RMS error against the noise-free CoP σ√(p/2n) at the fitted poses and
σ√(p/(2n − p − 1)) at fresh poses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.estimation import Fit, Measurements, fit_measurements
from sescid.robot import Robot
from sescid.simulation import PAPER_NOISE, PAPER_POSES, PAPER_RANGE_DEG, SimData, simulate

__all__ = ["PaperStudy", "paper_study"]


@dataclass
class PaperStudy:
    """Numbers of the paper's §3 study (all in metres)."""

    fit: Fit
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
    sim = simulate(robot, n, range_deg, noise, seed, r_true=r_true)
    fresh = simulate(
        robot, n_fresh, range_deg, noise, None if seed is None else seed + 1, r_true=r_true
    )
    fit = fit_measurements(robot, Measurements(q=sim.q, cop=sim.cop), method="ls")  # the paper's
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
