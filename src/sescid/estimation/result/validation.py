"""Uncertainty and validation: prediction intervals, k-fold cross-validation, error vs truth.

Intervals are for the noise-free CoP/CoM (the model's prediction), built from ``fit.cov`` and a
Student-t quantile with the fit's residual degrees of freedom (``fit.residual_dof``: what the
method set, else ``n_rows − rank``); ``new_measurement=True`` widens a CoP interval by the noise σ̂
to cover a future measured CoP.

What the CoM-z interval does not cover: for least squares ``fit.cov`` is zero along the directions
the data cannot see, and the CoM height has a component there (``fit.com_z_from_prior``) taken
from the prior model as if exact. An error in the CAD model along those directions is outside the
interval. A MAP fit (``sescid.prior``) carries the prior's uncertainty τ there instead, so its
interval covers it to the extent the prior scale is honest.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from sescid.errors import SescidError
from sescid.estimation.result.fit import Fit
from sescid.estimation.result.records import CrossValidation
from sescid.kinds import Kind
from sescid.kinematics import as_poses
from sescid.robot import Robot
from sescid.sesc import sesc_vectors

#: a fitting function: list of validated Measurements → Fit (``api.make_fitter``)
CvFitter = Callable[..., Fit]


def quantile(level: float, dof: float) -> float:
    """Two-sided Student-t quantile for a confidence ``level`` (normal when dof is inf)."""
    if not 0 < level < 1:
        raise SescidError(f"confidence level must be in (0, 1), got {level}")
    import scipy.stats  # lazy: ~1 s of import time that most commands never need

    if not math.isfinite(dof):
        return float(scipy.stats.norm.ppf(0.5 + level / 2))
    return float(scipy.stats.t.ppf(0.5 + level / 2, dof))


@dataclass
class Interval:
    """Predictions (n, k) with their standard errors and two-sided interval bounds, m."""

    value: np.ndarray
    std: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    level: float

    @property
    def half_width(self) -> np.ndarray:
        """(n, k) half-widths of the interval, m."""
        return self.upper - self.value

    def covers(self, truth) -> np.ndarray:
        """(n, k) booleans: truth inside the interval."""
        t = np.asarray(truth, dtype=float)
        return (t >= self.lower) & (t <= self.upper)


def _interval(value, std, level, dof) -> Interval:
    """Bounds value ± t·std; a nan std (a row the data do not determine) gives nan bounds."""
    if np.any(np.isinf(std)) or (std.size and np.all(np.isnan(std)) and not np.isfinite(dof)):
        raise SescidError("the fit has no finite covariance (no residual to estimate the noise)")
    k = quantile(level, dof)
    return Interval(value, std, value - k * std, value + k * std, level)


def cop_std(fit: Fit, q, gravity=None) -> np.ndarray:
    """Standard error (n, 2) [m] of the predicted CoP at poses q, under gravity (n, 3) if given.

    Under tilted gravity the CoP row is Φ_xy − (g_xy/g_z) Φ_z, so its variance carries the
    CoM-height uncertainty: var_x − 2 t cov(x, z) + t² var_z with t = g_x/g_z (likewise y).
    nan where the level x/y row is not determined (``Fit.predict_std``).
    """
    q = as_poses(q, fit.robot.nq)
    level = fit.predict_std(q, rows=(0, 1))
    if gravity is None:
        return level
    g = np.asarray(gravity, dtype=float)
    out = np.empty_like(level)
    for s in range(0, q.shape[0], 4096):
        blk = slice(s, s + 4096)
        phi = fit.robot.regressor_tilted(q[blk], g[blk])
        var = np.einsum("nri,ij,nrj->nr", phi, fit.cov, phi)
        out[blk] = np.sqrt(np.clip(var, 0, None))
    out[np.isnan(level)] = np.nan
    return out


def cop_interval(
    fit: Fit, q, level: float = 0.95, new_measurement: bool = False, gravity=None
) -> Interval:
    """Interval for the CoP (n, 2) [m] at poses q (n, nq) [rad], under gravity (n, 3) if given.

    Default: confidence interval of the noise-free CoP; ``new_measurement`` adds σ̂² to cover
    a future measurement. Under tilted gravity it includes the CoM-height uncertainty
    (``cop_std``).
    """
    q = as_poses(q, fit.robot.nq)
    std = cop_std(fit, q, gravity)
    if new_measurement:
        std = np.sqrt(std**2 + fit.sigma_hat**2)
    return _interval(fit.predict_cop(q, gravity), std, level, fit.residual_dof)


def com_interval(fit: Fit, q, level: float = 0.95) -> Interval:
    """Interval for the CoM (n, 3) [m]; see the module docstring for what z does not cover."""
    q = as_poses(q, fit.robot.nq)
    return _interval(fit.predict_com(q), fit.predict_std(q), level, fit.residual_dof)


def balance_interval(fit: Fit, q, level: float = 0.95) -> Interval:
    """Interval for the balance tilt (n,) [rad] of a robot on a line (``Fit.predict_balance``)."""
    q = as_poses(q, fit.robot.nq)
    tilt = fit.predict_balance(q)
    std = fit.predict_balance_std(q)
    return _interval(tilt, std, level, fit.residual_dof)


def rms(a) -> float:
    """Root mean square of all entries of ``a``."""
    return float(np.sqrt(np.mean(np.square(a))))


def truth_error(fit: Fit, q, cop_true) -> float:
    """RMS (m) of the predicted minus the noise-free CoP over poses q (simulation only)."""
    return rms(fit.predict_cop(q) - np.asarray(cop_true, dtype=float))


def folds(n: int, k: int, seed: int = 0) -> list[np.ndarray]:
    """K disjoint random index sets covering range(n)."""
    if not 2 <= k <= n:
        raise SescidError(f"cross-validation needs 2 ≤ k ≤ number of poses ({n}), got k = {k}")
    perm = np.random.default_rng(seed).permutation(n)
    return [np.sort(f) for f in np.array_split(perm, k)]


def cross_validate(
    fitter: CvFitter, data, k: int = 5, seed: int = 0, progress=None
) -> CrossValidation:
    """k-fold cross-validated error of a fitting method (``fitter([Measurements]) -> Fit``) on
    validated data: the CoP's when the data have one (m), else the torques' (N·m).

    With standard errors in the data and a weighted fit, the held-out residuals are divided by
    them, so the RMSE, the noise and the model part are all in units of the given errors.
    ``progress(i, k)`` is called after each fold.
    """
    from sescid.estimation.solvers.least_squares import residuals

    n = data.n
    kind: Kind = "cop" if data.cop is not None else "tau"
    sq, count, per_fold, noise2 = 0.0, 0, [], []
    for i, test in enumerate(folds(n, k, seed)):
        train = np.setdiff1d(np.arange(n), test)
        fit = fitter([data.take(train)])
        held = data.take(test)
        err = residuals(fit, held)[kind]
        kf = fit.kind(kind)
        se = held.cop_se if kind == "cop" else held.tau_se
        if kf is not None and kf.weighted and se is not None:
            err = err / se
        sq += float(np.sum(err**2))
        count += err.size
        per_fold.append(rms(err))
        if kf is not None and math.isfinite(kf.sigma):
            noise2.append(kf.sigma**2)
        if progress:
            progress(i + 1, k)
    total = math.sqrt(sq / count)
    noise = math.sqrt(np.mean(noise2)) if noise2 else math.nan
    model = math.sqrt(max(total**2 - noise**2, 0.0)) if noise2 else math.nan
    return CrossValidation(k, total, per_fold, noise, model, kind=kind)


def perturbed_sesc(
    robot: Robot,
    fraction: float = 0.04,
    n_bodies: int = 6,
    offset: float = 0.03,
    seed: int = 0,
) -> np.ndarray:
    """SESC vectors (N, 3) [m] of a "true" robot that differs from the model (simulation).

    ``fraction`` of the total mass is added as point masses, split over ``n_bodies`` random
    non-support bodies, each at a random offset of up to ``offset`` m per axis from the body's
    CoM.
    """
    rng = np.random.default_rng(seed)
    bodies = list(robot.model.bodies)
    picks = rng.choice(np.arange(1, len(bodies)), size=n_bodies, replace=False)
    dm = fraction * robot.total_mass / n_bodies
    for i in picks:
        b = bodies[i]
        at = b.com + rng.uniform(-offset, offset, 3)
        mass = b.mass + dm
        bodies[i] = replace(b, mass=mass, com=(b.mass * b.com + dm * at) / mass)
    return sesc_vectors(replace(robot.model, bodies=bodies))
