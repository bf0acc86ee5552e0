"""Weighted fits: σ̂ is one dimensionless scale on the given standard errors everywhere."""

from __future__ import annotations

import numpy as np
import pytest

import sescid
from sescid.estimation import cop_interval

SCALE = 3.0  # the given standard errors are 3× too small


@pytest.fixture(scope="module")
def scaled_data(op2):
    """400 random poses, per-pose standard errors 0.3–1.5 mm, actual noise 3× those."""
    rng = np.random.default_rng(7)
    sim = sescid.simulate(op2, n=400, range_deg=30, noise=0.0, seed=3)
    se = rng.uniform(0.3e-3, 1.5e-3, size=(400, 2))
    cop = sim.cop_true + SCALE * se * rng.standard_normal((400, 2))
    return sim.q, cop, se


def test_least_squares_scale_is_the_known_factor(op2, scaled_data):
    """Weighted least squares estimates σ̂ ≈ 3 (dimensionless), not metres."""
    q, cop, se = scaled_data
    fit = sescid.identify(op2, q, cop, sigma=se)
    assert fit.weighted and abs(fit.sigma_hat - SCALE) < 0.25


@pytest.mark.parametrize("method", ["ls", "map"])
def test_intervals_cover_the_truth_with_the_scale(op2, scaled_data, method):
    """MAP's evidence search finds the scale ≈ 3 (it stopped at 1.0, a covariance 9× too small)
    and the 95 % CoP intervals of both methods cover ≈ 95 % of the noise-free truths."""
    q, cop, se = scaled_data
    fit = sescid.identify(op2, q, cop, sigma=se, method=method)
    assert abs(fit.sigma_hat - SCALE) < 0.3
    truth = sescid.simulate(op2, n=400, range_deg=30, noise=0.0, seed=3).cop_true
    covered = cop_interval(fit, q, 0.95).covers(truth)
    assert 0.9 < float(np.mean(covered)) <= 1.0


def test_cv_noise_is_the_scale(op2, scaled_data):
    """Cross-validation of a weighted fit reports the scale ≈ 3 and an RMSE in units of the
    given errors (≈ 3 too), never metres."""
    q, cop, se = scaled_data
    cv = sescid.identify(op2, q, cop, sigma=se, cv=5, seed=0).cv
    assert abs(cv.noise - SCALE) < 0.3
    assert SCALE * 0.9 < cv.rmse < SCALE * 1.3
