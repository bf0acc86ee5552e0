"""MAP identification with a CAD prior, checked against closed forms and simulated truth."""

import numpy as np
import pytest
import scipy.stats
from click.testing import CliRunner
from fitting import identify_ls, identify_map

from sescid.cli import cli
from sescid.errors import SescidError
from sescid.estimation import accumulate, load_fit
from sescid.estimation.result.validation import perturbed_sesc, truth_error
from sescid.estimation.solvers.map import log_evidence
from sescid.estimation.solvers.map_prior import Prior, body_prior
from sescid.simulation import simulate

SIGMA = 0.00493


def _heldout_errors(robot, n, seed, fraction=0.04, offset=0.03):
    """(LS, MAP) RMS CoP error vs the noise-free truth at fresh poses, CAD off by 4 % of mass."""
    r_true = perturbed_sesc(robot, fraction=fraction, offset=offset, seed=seed)
    sim = simulate(robot, n, 30.0, SIGMA, seed, r_true=r_true)
    fresh = simulate(robot, 2000, 30.0, 0.0, seed + 1000, r_true=r_true)
    ls = identify_ls(robot, sim.q, sim.cop)
    mp = identify_map(robot, sim.q, sim.cop)
    return truth_error(ls, fresh.q, fresh.cop_true), truth_error(mp, fresh.q, fresh.cop_true)


def test_map_halves_least_squares_error_with_38_poses(robot):
    errs = np.array([_heldout_errors(robot, 38, seed) for seed in range(4)])
    ratio = errs[:, 1].mean() / errs[:, 0].mean()
    assert ratio < 0.5


def test_map_not_worse_than_least_squares_with_1000_poses(robot):
    errs = np.array([_heldout_errors(robot, 1000, seed) for seed in (0, 1)])
    assert np.all(errs[:, 1] <= 1.03 * errs[:, 0])


def test_map_not_worse_than_least_squares_when_cad_is_far_off(robot):
    """15 % of the mass misplaced by up to 5 cm: the evidence widens the prior, MAP ≤ LS."""
    errs = np.array([_heldout_errors(robot, 1000, seed, 0.15, 0.05) for seed in (2, 3)])
    assert np.all(errs[:, 1] <= 1.03 * errs[:, 0])


def test_map_with_cv_chosen_scale_beats_least_squares(robot):
    ratios = []
    for seed in range(3):
        r_true = perturbed_sesc(robot, seed=seed)
        sim = simulate(robot, 38, 30.0, SIGMA, seed, r_true=r_true)
        fresh = simulate(robot, 2000, 30.0, 0.0, seed + 1000, r_true=r_true)
        mp = identify_map(robot, sim.q, sim.cop, select="cv")
        ls = identify_ls(robot, sim.q, sim.cop)
        ratios.append(
            truth_error(mp, fresh.q, fresh.cop_true) / truth_error(ls, fresh.q, fresh.cop_true)
        )
        assert mp.map.prior_scale_by == "5-fold cv"
    assert np.mean(ratios) < 0.5


def test_map_equals_augmented_least_squares(robot):
    """Given τ and σ, MAP = least squares on [Φ; (σ/τ) I] x ≈ [y; (σ/τ) x0]."""
    tau, sigma = 8e-4, SIGMA
    sim = simulate(robot, 50, 30.0, SIGMA, 3, r_true=perturbed_sesc(robot, seed=3))
    fit = identify_map(robot, sim.q, sim.cop, prior_scale=tau, noise=sigma)
    phi = robot.regressor(sim.q).reshape(100, -1)
    x0 = robot.sesc_vectors().reshape(-1)
    a = np.vstack([phi, sigma / tau * np.eye(x0.size)])
    b = np.concatenate([(sim.cop - robot.d[:2]).reshape(-1), sigma / tau * x0])
    x = np.linalg.lstsq(a, b, rcond=None)[0]
    assert np.max(np.abs(fit.r.reshape(-1) - x)) < 1e-12
    cov = sigma**2 * np.linalg.inv(a.T @ a)
    assert np.max(np.abs(fit.cov - cov)) < 1e-12 * np.abs(cov).max() * 1e3


def test_log_evidence_equals_gaussian_marginal_density(robot):
    tau, sigma = 1e-3, 0.004
    sim = simulate(robot, 30, 30.0, sigma, 4)
    ne = accumulate(robot, [(sim.q, sim.cop)])
    x0 = robot.sesc_vectors().reshape(-1)
    got = log_evidence(ne, x0, Prior(x0.size, np.zeros(0)), tau, sigma)
    phi = robot.regressor(sim.q).reshape(60, -1)
    y = (sim.cop - robot.d[:2]).reshape(-1)
    cov = sigma**2 * np.eye(60) + tau**2 * phi @ phi.T
    want = scipy.stats.multivariate_normal(phi @ x0, cov).logpdf(y)
    assert got == pytest.approx(want, rel=1e-9)
    # the per-body prior: vec(r) ~ N(x0, τ² Σ₀), Σ₀ = K D Kᵀ (masses and first moments)
    body = body_prior(robot, x0.size, np.zeros(0))
    tau_rel = 0.1
    sigma0 = np.linalg.inv(body.x_precision)
    cov = sigma**2 * np.eye(60) + tau_rel**2 * phi @ sigma0 @ phi.T
    want = scipy.stats.multivariate_normal(phi @ x0, cov).logpdf(y)
    assert log_evidence(ne, x0, body, tau_rel, sigma) == pytest.approx(want, rel=1e-7)


def test_evidence_recovers_prior_scale_and_noise(robot):
    """Truth drawn from the prior N(CAD, τ²I): the evidence finds τ and σ."""
    tau = 1.5e-3
    rng = np.random.default_rng(7)
    taus, sigmas = [], []
    for seed in range(3):
        r_true = robot.sesc_vectors() + rng.normal(0, tau, (len(robot.body_names), 3))
        sim = simulate(robot, 300, 30.0, SIGMA, seed, r_true=r_true)
        fit = identify_map(robot, sim.q, sim.cop)
        taus.append(fit.map.prior_scale)
        sigmas.append(fit.sigma_hat)
    assert np.exp(np.mean(np.log(taus))) == pytest.approx(tau, rel=0.3)
    assert np.mean(sigmas) == pytest.approx(SIGMA, rel=0.05)


def test_unseen_directions_keep_prior_value_and_scale(robot):
    tau = 2e-3
    sim = simulate(robot, 60, 30.0, SIGMA, 5)
    fit = identify_map(robot, sim.q, sim.cop, prior_scale=tau, noise=SIGMA)
    null = np.eye(fit.r.size) - fit.basis @ fit.basis.T
    dev = null @ (fit.r - fit.r_prior).reshape(-1)
    assert np.max(np.abs(dev)) < 1e-9
    w, u = np.linalg.eigh(null)
    u0 = u[:, w > 0.5]
    assert np.allclose(np.sqrt(np.diag(u0.T @ fit.cov @ u0)), tau, rtol=1e-6)


def test_bias_estimated_through_prior(robot):
    """CoP offsets are recovered within their stated errors once the prior pins r_support."""
    bias = np.array([0.003, -0.002])
    z = []
    for seed in range(3):
        r_true = perturbed_sesc(robot, seed=seed)
        sim = simulate(robot, 300, 30.0, SIGMA, seed, r_true=r_true)
        fit = identify_map(robot, sim.q, sim.cop + bias, prior_scale=5e-4, bias=True)
        z.append((fit.cop_offset.value - bias) / fit.cop_offset.std)
    assert np.max(np.abs(z)) < 4.0


def test_least_squares_absorbs_bias_into_the_model(robot):
    """Confounding: LS explains a constant offset by r, its CoM is off by the bias everywhere."""
    bias = np.array([0.003, -0.002])
    sim = simulate(robot, 400, 30.0, 0.0, 6)
    ls = identify_ls(robot, sim.q, sim.cop + bias)
    assert ls.rms < 1e-10  # the offset fits perfectly: the data cannot tell it from r
    fresh = simulate(robot, 100, 30.0, 0.0, 7)
    assert np.allclose(ls.predict_com(fresh.q)[:, :2] - fresh.cop_true, bias, atol=1e-9)


def test_bad_prior_scale_raises(robot):
    sim = simulate(robot, 40, 30.0, SIGMA, 0)
    with pytest.raises(SescidError, match="prior_scale"):
        identify_map(robot, sim.q, sim.cop, prior_scale=-1.0)


def test_cli_map_writes_fit_with_prior_scale(robot, tmp_path, write_dataset):
    sim = simulate(robot, 60, 30.0, SIGMA, 1)
    data = write_dataset(tmp_path / "d.csv", sim.q, sim.cop)
    out = tmp_path / "fit.json"
    args = ["identify", str(data), "--out", str(out), "--method", "map", "--allow-outside-limits"]
    res = CliRunner().invoke(cli, [*args, "--prior-select", "cv"])
    assert res.exit_code == 0, res.output
    assert load_fit(out).map.prior_scale_by == "5-fold cv"
    res = CliRunner().invoke(cli, [*args, "--prior-scale", "1e-3"])
    assert res.exit_code == 0, res.output
    fit = load_fit(out)
    assert fit.method == "map" and fit.map.prior_scale == pytest.approx(1e-3)
    res = CliRunner().invoke(cli, ["identify", str(data), "--out", str(out), "--method", "ls",
                                   "--bias"])  # fmt: skip
    assert res.exit_code == 2 and "--bias needs --method map" in res.output
    args = [
        "identify",
        str(data),
        "--out",
        str(out),
        "--method",
        "consistent",
        "--prior-scale",
        "1",
    ]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 2 and "--prior-scale needs --method map" in res.output
