"""The simulator and the paper's §3 study against the least-squares theory (theory.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sescid
from sescid.simulation import PAPER_NOISE, random_poses, simulate
from sescid.study import paper_study


def test_simulated_cop_is_the_com_projection_plus_noise(op2):
    sim = simulate(op2, 4000, range_deg=30, noise=0.004, seed=2)
    assert sim.q.shape == (4000, 20) and np.abs(sim.q).max() <= math.radians(30)
    np.testing.assert_allclose(sim.cop_true, op2.com(sim.q)[:, :2], atol=1e-15)
    noise = sim.cop - sim.cop_true
    assert noise.std() == pytest.approx(0.004, rel=0.03)
    assert abs(noise.mean()) < 3 * 0.004 / math.sqrt(noise.size)
    again = simulate(op2, 4000, range_deg=30, noise=0.004, seed=2)
    np.testing.assert_array_equal(again.cop, sim.cop)


def test_clip_respects_joint_limits(op2):
    q = random_poses(op2, 500, 179, 0, clip=True)
    lim = op2.joint_limits
    assert np.all(q >= lim[:, 0]) and np.all(q <= lim[:, 1])
    assert np.any(q == lim[:, 1])  # ±179° exceeds some limits, so clipping happened


def test_bad_simulation_settings(op2):
    with pytest.raises(sescid.SescidError, match="poses must be"):
        simulate(op2, 0)
    with pytest.raises(sescid.SescidError, match="noise"):
        simulate(op2, 10, noise=-1)


def test_paper_study_matches_theory(op2):
    """n = 1000, ±30°, σ = 4.93 mm (paper §3) with the theory of theory.md beside it."""
    st = paper_study(op2, seed=0, n_fresh=20000)
    p, n, s = 42, 1000, PAPER_NOISE
    assert st.fit.rank == p
    floor = math.sqrt(2 / math.pi) * s * math.sqrt(1 - p / (2 * n))
    assert st.noise_floor_mae == pytest.approx(floor) and floor == pytest.approx(0.00389, abs=1e-5)
    assert st.mae == pytest.approx(floor, rel=0.03)  # paper: 0.0040
    assert st.rmse_fitted == pytest.approx(s * math.sqrt(p / (2 * n)), rel=0.15)
    assert st.rmse_fresh == pytest.approx(s * math.sqrt(p / (2 * n - p - 1)), rel=0.15)
    assert st.fit.sigma_hat == pytest.approx(s, rel=0.04)
    assert st.rmse_prior_fresh < 1e-15  # the simulated robot is the model itself


def test_fresh_error_averages_to_theory_over_seeds(op2):
    """Average of the noise-free CoP error on fresh poses over seeds: σ²p/(2n − p − 1)."""
    n, s = 200, PAPER_NOISE
    mse = []
    for seed in range(12):
        st = paper_study(op2, n=n, seed=10 * seed, n_fresh=3000)
        mse.append(st.rmse_fresh**2)
    theory = s**2 * 42 / (2 * n - 42 - 1)
    assert np.mean(mse) == pytest.approx(theory, rel=0.15)


@pytest.mark.slow
def test_paper_statistics_over_many_seeds(op2):
    """200 replicates of the paper's study: MAE → noise floor, fresh-pose error² → expectation."""
    # Per replicate the fresh-pose error² scatters by ~20 %, so 200 replicates pin the mean to
    # ~1.5 %. The expectation given the design is σ²·mean φ(ΦᵀΦ)⁺φᵀ over the fresh rows.
    p, n, s = 42, 1000, PAPER_NOISE
    maes, mses, expected = [], [], []
    for seed in range(200):
        st = paper_study(op2, n=n, seed=5000 + 7 * seed, n_fresh=2000)
        maes.append(st.mae)
        mses.append(st.rmse_fresh**2)
        std = st.fit.predict_std(st.fresh.q, rows=(0, 1)) / st.fit.sigma_hat * s
        expected.append(np.mean(std**2))
    assert np.mean(maes) == pytest.approx(st.noise_floor_mae, rel=0.005)
    assert np.mean(mses) == pytest.approx(np.mean(expected), rel=0.05)
    assert np.mean(expected) == pytest.approx(s**2 * p / (2 * n - p - 1), rel=0.02)
