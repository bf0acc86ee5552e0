"""Least squares: rank, identifiability, exact recovery, calibrated uncertainty, streaming."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from fitting import identify_ls, identify_stream

import sescid
from sescid.estimation import fit_notes
from sescid.sesc import sesc_vectors
from sescid.simulation import random_poses, simulate


def perturbed_r(robot, seed=0, frac=0.04):
    """SESC vectors of a 'real' robot: ~frac of the total mass added at offsets on 5 bodies."""
    rng = np.random.default_rng(seed)
    bodies = list(robot.model.bodies)
    extra = frac * robot.total_mass / 5
    for i in rng.choice(len(bodies), 5, replace=False):
        b = bodies[i]
        m = b.mass + extra
        com = (b.mass * b.com + extra * rng.uniform(-0.03, 0.03, 3)) / m
        bodies[i] = dataclasses.replace(b, mass=m, com=com)
    return sesc_vectors(dataclasses.replace(robot.model, bodies=bodies))


def test_op2_rank_is_42_and_43_with_the_height_row(op2, rng):
    q = random_poses(op2, 300, 30, rng)
    assert np.linalg.matrix_rank(op2.regressor(q).reshape(600, 63)) == 42
    assert np.linalg.matrix_rank(op2.regressor(q, (0, 1, 2)).reshape(900, 63)) == 43
    fit = identify_ls(op2, q, op2.cop(q))
    assert fit.rank == 42 and len(fit.base) == 42 and len(fit.unidentifiable) == 21


def test_noise_free_data_is_reproduced_exactly(op2):
    r_true = perturbed_r(op2)
    q = random_poses(op2, 200, 30, 1)
    fit = identify_ls(op2, q, op2.cop(q, r_true))
    fresh = random_poses(op2, 500, 30, 2)
    np.testing.assert_allclose(fit.predict_cop(fresh), op2.cop(fresh, r_true), atol=1e-12)
    assert fit.rms < 1e-13
    # undetermined directions come from the prior, not the truth
    null = np.eye(63) - fit.basis @ fit.basis.T
    np.testing.assert_allclose(null @ fit.r.ravel(), null @ fit.r_prior.ravel(), atol=1e-14)
    # every named base combination equals its value on the true vectors
    labels = [(b, a) for b in op2.body_names for a in "xyz"]
    for comb in fit.base:
        g = np.zeros(63)
        for body, axis, c in comb.terms:
            g[labels.index((body, axis))] = c
        assert comb.value == pytest.approx(g @ r_true.ravel(), abs=1e-12)


def test_unidentifiable_directions_are_named_with_reasons(op2, rng):
    q = random_poses(op2, 100, 30, rng)
    fit = identify_ls(op2, q, op2.cop(q))
    reasons = [c.reason for c in fit.unidentifiable]
    assert sum("vertical component of the support body" in r for r in reasons) == 1
    assert sum("along its joint axis" in r for r in reasons) == 20
    knee = next(c for c in fit.unidentifiable if "(r_knee)" in c.reason)
    assert {t[0] for t in knee.terms} == {"MP_TIBIA_R", "MP_THIGH2_R"}


def test_a_joint_that_never_moves_is_reported(op2, rng):
    q = random_poses(op2, 200, 30, rng)
    q[:, op2.joint_names.index("head_tilt")] = 0.0
    fit = identify_ls(op2, q, op2.cop(q))
    assert fit.rank == 40  # the head's two off-axis components now merge with the neck's
    extra = [c for c in fit.unidentifiable if c.reason.startswith("not excited")]
    assert len(extra) == 2
    assert all(any(t[0] == "MP_HEAD" for t in c.terms) for c in extra)


@pytest.mark.slow
def test_predicted_standard_errors_are_calibrated(op2):
    """Monte Carlo: spread of predicted CoP over noise replicates vs Fit.predict_std."""
    q = random_poses(op2, 60, 30, 5)
    test = random_poses(op2, 5, 30, 6)
    truth = op2.cop(q)
    rng = np.random.default_rng(7)
    sigma = 0.005
    preds, stds = [], []
    for _ in range(300):
        fit = identify_ls(op2, q, truth + rng.normal(0, sigma, truth.shape))
        preds.append(fit.predict_cop(test))
    fit0 = identify_ls(op2, q, truth + rng.normal(0, sigma, truth.shape))
    # predict_std scales with sigma_hat; compare at the true sigma
    stds = fit0.predict_std(test, rows=(0, 1)) * sigma / fit0.sigma_hat
    ratio = np.std(np.array(preds), axis=0) / stds
    assert np.all((ratio > 0.8) & (ratio < 1.2)), ratio


def test_streaming_equals_in_memory(op2):
    sim = simulate(op2, 3000, seed=3)
    fit = identify_ls(op2, sim.q, sim.cop)
    chunks = [(sim.q[a:b], sim.cop[a:b]) for a, b in [(0, 7), (7, 2100), (2100, 3000)]]
    fit2 = identify_stream(op2, chunks)
    np.testing.assert_allclose(fit2.r, fit.r, atol=1e-12)
    assert fit2.rank == fit.rank and fit2.n_poses == 3000
    assert fit2.sigma_hat == pytest.approx(fit.sigma_hat, rel=1e-9)
    assert fit2.rms == pytest.approx(fit.rms, rel=1e-6)
    np.testing.assert_allclose(fit2.cov, fit.cov, rtol=0, atol=1e-9 * np.abs(fit.cov).max())


def test_weights_follow_the_given_standard_errors(op2):
    """Heteroscedastic noise: weighting by the true σ beats equal weights on fresh poses."""
    errs = []
    for seed in range(4):
        rng = np.random.default_rng(seed)
        q = random_poses(op2, 200, 30, rng)
        sig = np.where(np.arange(200) % 2, 0.001, 0.01)
        cop = op2.cop(q) + rng.normal(0, 1, (200, 2)) * sig[:, None]
        fresh = random_poses(op2, 2000, 30, rng)
        for k, s in enumerate([None, sig]):
            fit = identify_ls(op2, q, cop, sigma=s)
            errs.append((seed, k, np.sqrt(np.mean((fit.predict_cop(fresh) - op2.cop(fresh)) ** 2))))
            if s is not None:
                assert fit.sigma_hat == pytest.approx(1.0, abs=0.15)
    e = np.array(errs)
    assert e[e[:, 1] == 1, 2].mean() < 0.6 * e[e[:, 1] == 0, 2].mean()


def test_too_few_poses_and_the_papers_38(op2):
    q = random_poses(op2, 20, 30, 0)
    with pytest.raises(sescid.SescidError, match="at least 22 poses are needed"):
        identify_ls(op2, q, op2.cop(q))
    q = random_poses(op2, 38, 30, 0)
    fit = identify_ls(op2, q, op2.cop(q) + np.random.default_rng(0).normal(0, 0.005, (38, 2)))
    assert fit.rank == 42 and fit.n_rows == 76 and np.isfinite(fit.sigma_hat)
    q = random_poses(op2, 21, 30, 0)  # 42 equations, 42 combinations: no degrees of freedom
    with pytest.raises(sescid.SescidError, match="no degrees of freedom.*at least 22 poses"):
        identify_ls(op2, q, op2.cop(q))
    fit = identify_ls(op2, q, op2.cop(q), allow_exact=True)  # asked for: nothing is "exact"
    assert fit.rank == 42 and np.isnan(fit.sigma_hat) and "no residual" in fit_notes(fit)[0]
    assert np.all(np.isnan(fit.cov)) and all(np.isnan(c.std) for c in fit.base)
    assert np.all(np.isnan(fit.predict_std(q[:3])))


def test_bad_cop_input(op2):
    q = random_poses(op2, 30, 30, 0)
    cop = op2.cop(q)
    cop[3, 1] = np.inf
    with pytest.raises(sescid.SescidError, match="pose 3, cop_y: inf is not a finite number"):
        identify_ls(op2, q, cop)
    with pytest.raises(sescid.SescidError, match="expected shape"):
        identify_ls(op2, q, cop[:, :1])


def test_com_height_prior_share(op2, rng):
    q = random_poses(op2, 400, 30, rng)
    fit = identify_ls(op2, q, op2.cop(q))
    frac = fit.com_z_prior_fraction(q[:200])
    assert 0.15 < frac.mean() < 0.3  # "about a fifth of the z row" (theory.md)
    # the prior's share of CoM_z is exactly what changes when only the prior changes
    r2 = fit.r_prior.ravel() + 0.001 * (np.eye(63) - fit.basis @ fit.basis.T) @ np.ones(63)
    fit2 = identify_ls(op2, q, op2.cop(q), r_prior=r2.reshape(-1, 3))
    dz = fit2.predict_com(q[:10])[:, 2] - fit.predict_com(q[:10])[:, 2]
    np.testing.assert_allclose(
        dz, fit2.com_z_from_prior(q[:10]) - fit.com_z_from_prior(q[:10]), atol=1e-14
    )
