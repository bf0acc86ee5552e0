"""Online (recursive) estimator: batch equivalence, predicted error, convergence, CLI."""

import math

import numpy as np
import pytest
from click.testing import CliRunner
from fitting import identify_ls, identify_map

from sescid.cli import cli
from sescid.errors import SescidError
from sescid.estimation import load_fit
from sescid.estimation.result.validation import perturbed_sesc
from sescid.estimation.solvers.online import OnlineEstimator
from sescid.simulation import simulate

SIGMA = 0.00493


@pytest.fixture(scope="module")
def data(robot):
    return simulate(robot, 120, 30.0, SIGMA, 1, r_true=perturbed_sesc(robot, seed=1))


def test_pose_by_pose_with_prior_equals_batch_map(robot, data):
    est = OnlineEstimator(robot, prior_scale=5e-4, noise=SIGMA)
    for i in range(len(data.q)):
        est.update(data.q[i], data.cop[i])
    batch = identify_map(robot, data.q, data.cop, prior_scale=5e-4, noise=SIGMA)
    assert np.max(np.abs(est.estimate() - batch.r)) < 1e-10
    assert np.max(np.abs(est.fit().cov - batch.cov)) < 1e-14


def test_map_equality_holds_at_every_step(robot, data):
    est = OnlineEstimator(robot, prior_scale=5e-4, noise=SIGMA)
    for n in (1, 3, 10):
        est.update(data.q[est.ne.n_poses : n], data.cop[est.ne.n_poses : n])
        batch = identify_map(robot, data.q[:n], data.cop[:n], prior_scale=5e-4, noise=SIGMA)
        assert np.max(np.abs(est.estimate() - batch.r)) < 1e-10


def test_without_prior_equals_least_squares(robot, data):
    est = OnlineEstimator(robot)
    for i in range(len(data.q)):
        est.update(data.q[i : i + 1], data.cop[i : i + 1])
    ls = identify_ls(robot, data.q, data.cop)
    assert np.max(np.abs(est.estimate() - ls.r)) < 1e-10
    assert est.history[-1].noise == pytest.approx(ls.sigma_hat, rel=1e-9)


def test_vanishing_prior_tends_to_least_squares_predictions(robot, data):
    """Ridge bias ∝ σ²/τ²: the CoP difference to LS falls ~100× from τ = 1 m to 10 m."""
    ls = identify_ls(robot, data.q, data.cop).predict_cop(data.q)
    diffs = []
    for tau in (1.0, 10.0):
        est = OnlineEstimator(robot, prior_scale=tau, noise=SIGMA)
        est.update(data.q, data.cop)
        diffs.append(np.max(np.abs(robot.cop(data.q, est.estimate()) - ls)))
    assert diffs[1] < 1e-8 and diffs[1] < 0.05 * diffs[0]


def test_chunks_equal_single_poses(robot, data):
    one, chunked = OnlineEstimator(robot), OnlineEstimator(robot)
    for i in range(60):
        one.update(data.q[i], data.cop[i])
    chunked.update(data.q[:25], data.cop[:25])
    chunked.update(data.q[25:60], data.cop[25:60])
    assert np.max(np.abs(one.estimate() - chunked.estimate())) < 1e-12
    assert one.history[-1].cop_std == pytest.approx(chunked.history[-1].cop_std, rel=1e-9)


def test_predicted_cop_std_follows_least_squares_theory(robot):
    """RMS CoP standard error of LS ≈ σ √(p / (2n − p − 1)) for poses like the data's."""
    sim = simulate(robot, 500, 30.0, SIGMA, 2)
    est = OnlineEstimator(robot, noise=SIGMA)
    est.update(sim.q, sim.cop)
    p = est.history[-1].rank
    assert est.history[-1].cop_std == pytest.approx(SIGMA * math.sqrt(p / (1000 - p - 1)), rel=0.1)


def test_not_determined_before_rank_then_decreasing(robot, data):
    est = OnlineEstimator(robot)
    steps = [est.update(data.q[i], data.cop[i]) for i in range(len(data.q))]
    assert math.isinf(steps[10].cop_std)  # 22 equations < 42 combinations
    finite = [s.cop_std for s in steps if math.isfinite(s.cop_std)]
    assert finite and finite[-1] < 0.5 * finite[0]


def test_converges_where_the_criterion_says(robot):
    """LS error ∝ n^-1/2: a < 5 % drop over 20 poses first happens near n ≈ 20/(2·0.05)."""
    sim = simulate(robot, 400, 30.0, SIGMA, 3)
    est = OnlineEstimator(robot, noise=SIGMA, window=20, tol=0.05)
    for s in range(0, 400, 5):
        est.update(sim.q[s : s + 5], sim.cop[s : s + 5])
    assert 150 <= est.converged_at <= 320


def test_prior_needs_noise(robot):
    with pytest.raises(SescidError, match="noise"):
        OnlineEstimator(robot, prior_scale=1e-3)


def test_cli_online_prints_convergence(robot, tmp_path, write_dataset):
    sim = simulate(robot, 300, 30.0, SIGMA, 4)
    path = write_dataset(tmp_path / "d.csv", sim.q, sim.cop)
    out = tmp_path / "fit.json"
    args = [
        "identify",
        str(path),
        "--out",
        str(out),
        "--online",
        "--allow-outside-limits",
        "--noise",
        str(SIGMA),
    ]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    assert "converged" in res.output and "not determined yet" in res.output
    fit = load_fit(out)
    assert fit.online.converged_at is not None
    assert np.max(np.abs(fit.r - identify_ls(robot, sim.q, sim.cop).r)) < 1e-10
    res = CliRunner().invoke(cli, [*args, "--method", "map"])
    assert res.exit_code == 2 and "--prior-scale" in res.output
