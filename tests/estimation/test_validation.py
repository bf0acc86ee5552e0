"""Prediction intervals, cross-validation and the perturbed-truth helper."""

import numpy as np
import pytest
from click.testing import CliRunner
from fitting import identify_ls, identify_map

from sescid import identify
from sescid.bench import ExperimentConfig, real_robot
from sescid.cli import cli
from sescid.errors import SescidError
from sescid.estimation import load_fit
from sescid.estimation.result.validation import (
    com_interval,
    cop_interval,
    folds,
    perturbed_sesc,
    quantile,
)
from sescid.simulation import random_poses, simulate
from sescid.tables import read_table

SIGMA = 0.00493


@pytest.mark.slow
def test_least_squares_cop_interval_covers_95_percent(robot):
    """Over 500 seeded replicates (40 poses each), 95 % intervals cover ~95 % of the truths."""
    hits = []
    for seed in range(500):
        sim = simulate(robot, 40, 30.0, SIGMA, seed)
        fit = identify_ls(robot, sim.q, sim.cop)
        fresh = random_poses(robot, 4, 30.0, seed + 10_000)
        hits.append(cop_interval(fit, fresh).covers(robot.cop(fresh)))
    coverage = np.mean(hits)
    assert 0.92 <= coverage <= 0.98


@pytest.mark.slow
def test_map_com_interval_covers_95_percent_including_height(robot):
    """Truth drawn from the prior: MAP intervals cover the CoM x, y and z, prior part included."""
    tau = 1e-3
    rng = np.random.default_rng(1)
    hits = []
    for seed in range(300):
        r_true = robot.sesc_vectors() + rng.normal(0, tau, (len(robot.body_names), 3))
        sim = simulate(robot, 30, 30.0, SIGMA, seed, r_true=r_true)
        fit = identify_map(robot, sim.q, sim.cop, prior_scale=tau, noise=SIGMA)
        fresh = random_poses(robot, 4, 30.0, seed + 20_000)
        hits.append(com_interval(fit, fresh).covers(robot.com(fresh, r_true)))
    coverage = np.mean(hits, axis=(0, 1))
    assert np.all((coverage >= 0.92) & (coverage <= 0.98))


def test_least_squares_height_interval_misses_prior_error(robot):
    """LS takes the prior-filled part of CoM z as exact: a CAD error there is not covered."""
    r_true = robot.sesc_vectors()
    r_true[0, 2] += 0.02  # support body's vertical component: invisible to the CoP
    sim = simulate(robot, 300, 30.0, SIGMA, 2, r_true=r_true)
    fit = identify_ls(robot, sim.q, sim.cop)
    fresh = random_poses(robot, 50, 30.0, 3)
    cov = com_interval(fit, fresh).covers(robot.com(fresh, r_true))
    assert cov[:, :2].mean() > 0.85 and cov[:, 2].mean() < 0.1


def test_new_measurement_interval_adds_noise(robot):
    sim = simulate(robot, 200, 30.0, SIGMA, 4)
    fit = identify_ls(robot, sim.q, sim.cop)
    fresh = simulate(robot, 4000, 30.0, SIGMA, 5)
    iv = cop_interval(fit, fresh.q, new_measurement=True)
    assert iv.covers(fresh.cop).mean() == pytest.approx(0.95, abs=0.015)
    assert np.allclose(iv.std**2 - fit.predict_std(fresh.q, (0, 1)) ** 2, fit.sigma_hat**2)


def test_quantile_is_student_t():
    assert quantile(0.95, 10) == pytest.approx(2.228139, rel=1e-6)
    assert quantile(0.95, float("inf")) == pytest.approx(1.959964, rel=1e-6)


def test_cross_validated_error_matches_noise_plus_model_error(robot):
    """CV RMSE² ≈ σ² + LS prediction variance σ²p/(2n_train − p − 1) (n_train = 160)."""
    sim = simulate(robot, 200, 30.0, SIGMA, 6)
    cv = identify(robot, sim.q, sim.cop, cv=5).cv
    p, m = 42, 2 * 160
    want = SIGMA * np.sqrt(1 + p / (m - p - 1))
    assert cv.rmse == pytest.approx(want, rel=0.08)
    assert len(cv.rmse_folds) == 5


def test_folds_partition_and_bad_k():
    parts = folds(23, 5, seed=1)
    assert sorted(np.concatenate(parts).tolist()) == list(range(23))
    with pytest.raises(SescidError, match="2 ≤ k"):
        folds(10, 1)


def test_perturbed_sesc_matches_direct_com(robot):
    """The perturbed r reproduces the CoM computed body by body from the modified masses."""
    fraction, seed = 0.05, 3
    r_true = perturbed_sesc(robot, fraction=fraction, seed=seed)
    rng = np.random.default_rng(seed)  # the same draws as perturbed_sesc
    bodies = robot.model.bodies
    picks = rng.choice(np.arange(1, len(bodies)), size=6, replace=False)
    dm = fraction * robot.total_mass / 6
    q = random_poses(robot, 5, 30.0, 0)
    rot, org = robot.forward(q)
    mom = sum(b.mass * (org[:, i] + rot[:, i] @ b.com) for i, b in enumerate(bodies))
    for i in picks:
        at = bodies[i].com + rng.uniform(-0.03, 0.03, 3)
        mom = mom + dm * (org[:, i] + rot[:, i] @ at)
    com = mom / (robot.total_mass + fraction * robot.total_mass)
    assert np.allclose(robot.com(q, r_true), com, atol=1e-12)


def test_cli_cv_prints_and_stores(robot, tmp_path, write_dataset):
    sim = simulate(robot, 80, 30.0, SIGMA, 1)
    data = write_dataset(tmp_path / "d.csv", sim.q, sim.cop)
    out = tmp_path / "fit.json"
    res = CliRunner().invoke(
        cli, ["identify", str(data), "--out", str(out), "--cv", "4", "--allow-outside-limits"]
    )
    assert res.exit_code == 0, res.output
    assert "4-fold CoP RMSE" in res.output
    assert load_fit(out).cv.k == 4
    res = CliRunner().invoke(cli, ["identify", str(data), "--out", str(out), "--cv", "1"])
    assert res.exit_code == 2 and "--cv" in res.output and "x>=2" in res.output


def test_cli_predict_level_writes_intervals(robot, tmp_path, write_dataset):
    sim = simulate(robot, 200, 30.0, SIGMA, 2)
    fresh = simulate(robot, 400, 30.0, SIGMA, 3)
    for name, s in (("d.csv", sim), ("f.csv", fresh)):
        write_dataset(tmp_path / name, s.q, s.cop)
    fit, pred = tmp_path / "fit.json", tmp_path / "p.csv"
    args = ["identify", str(tmp_path / "d.csv"), "--out", str(fit), "--allow-outside-limits"]
    assert CliRunner().invoke(cli, args).exit_code == 0
    args = ["predict", str(fit), str(tmp_path / "f.csv"), "--out", str(pred), "--level", "0.95"]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    t = read_table(pred)
    lo = np.column_stack([t.get("cop_x_lower"), t.get("cop_y_lower")])
    hi = np.column_stack([t.get("cop_x_upper"), t.get("cop_y_upper")])
    inside = (fresh.cop_true >= lo) & (fresh.cop_true <= hi)
    assert 0.85 <= inside.mean() <= 1.0
    res = CliRunner().invoke(cli, [*args[:-1], "2"])
    assert res.exit_code == 2 and "--level" in res.output and "0<x<1" in res.output


def test_cli_identify_reports_error_against_simulated_truth(robot, tmp_path):
    data, out = tmp_path / "sim.csv", tmp_path / "fit.json"
    args = ["simulate", "--count", "100", "--seed", "3", "--out", str(data)]
    assert CliRunner().invoke(cli, args).exit_code == 0
    res = CliRunner().invoke(
        cli, ["identify", str(data), "--out", str(out), "--allow-outside-limits"]
    )
    assert res.exit_code == 0, res.output
    r_true = real_robot(robot, ExperimentConfig())[0]  # the CLI simulates the bench's robot
    sim = simulate(robot, 100, 30.0, SIGMA, 3, r_true=r_true)  # the same draws as the CLI
    want = np.sqrt(np.mean((load_fit(out).predict_cop(sim.q) - sim.cop_true) ** 2))
    assert load_fit(out).truth_cop_rmse == pytest.approx(want, rel=1e-9)
    assert f"{want * 1e3:.3f} mm" in res.output
