"""A robot balancing on a line (a wheel axle): its rows, the balance tilt, homogeneous data
anchored to a scale, and the fit against a simulation with known truth."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import sescid
from sescid import identify
from sescid.errors import DataError
from sescid.estimation import MapOptions, Measurements
from sescid.estimation.data.anchor import com_distance, homogeneous
from sescid.estimation.data.balance_rows import balance_rows
from sescid.estimation.sums.pooled import accumulate_sources
from sescid.robots import EXAMPLES
from sescid.sesc import balance_gravity, balance_tilt, sesc_vectors
from sescid.simulation import simulate_balance

WHEELED = EXAMPLES["wheeled_humanoid"]
NOISE = math.radians(0.5)


@pytest.fixture(scope="module")
def wheeled():
    return sescid.load_robot(WHEELED, "axle", line="y")


def perturbed(robot, rng) -> np.ndarray:
    """True SESC vectors: every body's mass ±10 %, its CoM moved ±1 cm (the wheels' stay on
    the axle: they are balanced)."""
    bodies = []
    for b in robot.model.bodies:
        wheel = b.name.startswith("wheel")
        com = b.com if wheel or b.mass == 0 else b.com + rng.normal(0, 0.01, 3)
        bodies.append(dataclasses.replace(b, mass=b.mass * (1 + 0.1 * rng.normal()), com=com))
    return sesc_vectors(dataclasses.replace(robot.model, bodies=bodies))


def test_rows_are_the_com_offset_across_the_line_at_any_tilt(wheeled, rng):
    """Each row is n·CoM / ρ with n = u × up horizontal: checked against the CoM itself, up to
    85° of tilt (a CoP on the sole plane would be refused beyond 60°)."""
    q = rng.uniform(-0.5, 0.5, (30, wheeled.nq))
    tilt = rng.uniform(-math.radians(85), math.radians(85), 30)
    g = balance_gravity(wheeled.line, tilt)
    offset = rng.normal(0, 0.01, 30)
    x, y = balance_rows(wheeled, q, offset, g)
    r = wheeled.sesc_vectors()
    com = wheeled.com(q)
    up = -g
    n = np.cross(wheeled.line, up)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    rho = np.linalg.norm(com - np.outer(com @ wheeled.line, wheeled.line), axis=1)
    np.testing.assert_allclose(x.T @ r.reshape(-1), np.sum(n * com, axis=1) / rho, atol=1e-14)
    np.testing.assert_allclose(y, offset / rho, atol=1e-15)
    np.testing.assert_allclose(np.sum(n * up, axis=1), 0, atol=1e-15)  # horizontal


def test_the_balance_tilt_puts_the_com_over_the_line(wheeled, rng):
    q = rng.uniform(-0.6, 0.6, (50, wheeled.nq))
    r = wheeled.sesc_vectors()
    tilt, _ = balance_tilt(wheeled.tree, wheeled.line, q, r)
    com = wheeled.com(q)
    # closed form for an axle along y: the frame pitched by −atan2(c_x, c_z)
    np.testing.assert_allclose(tilt, -np.arctan2(com[:, 0], com[:, 2]), atol=1e-15)
    up = -balance_gravity(wheeled.line, tilt)
    across = np.cross(wheeled.line, up)
    np.testing.assert_allclose(np.sum(across * com, axis=1), 0, atol=1e-15)
    assert np.all(np.sum(up * com, axis=1) > 0)  # above the axle, not below


def test_balance_data_are_homogeneous_cop_data_are_not(wheeled, op2, rng):
    sim = simulate_balance(wheeled, 20, seed=1)
    m = Measurements(q=sim.q, balance=np.zeros(20), gravity=sim.gravity).checked(wheeled)
    system = accumulate_sources(wheeled, [[m]])
    theta0 = wheeled.sesc_vectors().reshape(-1)
    assert homogeneous(wheeled, system, theta0)
    q = rng.uniform(-0.3, 0.3, (30, op2.nq))
    cop = op2.cop(q) + rng.normal(0, 0.005, (30, 2))
    system = accumulate_sources(op2, [[Measurements(q=q, cop=cop).checked(op2)]])
    assert not homogeneous(op2, system, op2.sesc_vectors().reshape(-1))


@pytest.mark.parametrize("method", ["ls", "map"])
def test_a_fit_from_40_balanced_poses(wheeled, method):
    """40 poses, IMU tilt noise 0.5°, a truth 10 % / 1 cm off the model: the fit predicts the
    balancing tilt of fresh poses near the noise floor (better than the model), keeps the
    CoM's distance from the axle within 25 % of the truth, and its residual is the noise, not
    the collapsed model's 0."""
    rng = np.random.default_rng(7)
    errors, ratios, cad_errors = [], [], []
    for draw in range(5):
        r_true = perturbed(wheeled, rng)
        sim = simulate_balance(wheeled, 40, 45, NOISE, seed=draw, r_true=r_true)
        fresh = simulate_balance(wheeled, 500, 45, 0.0, seed=100 + draw, r_true=r_true)
        m = Measurements(q=sim.q, balance=np.zeros(40), gravity=sim.gravity)
        fit = identify(wheeled, m, method=method)
        assert fit.scale is not None and fit.scale.by == "prior"
        (kind,) = fit.kinds
        assert kind.kind == "balance" and kind.unit == "rad"
        assert 0.6 * NOISE < kind.sigma < 1.5 * NOISE  # σ̂ in rad: the IMU's noise
        pred = fit.predict_balance(fresh.q)
        cad = balance_tilt(wheeled.tree, wheeled.line, fresh.q, wheeled.sesc_vectors())[0]
        errors.append(np.sqrt(np.mean((pred - fresh.tilt) ** 2)))
        cad_errors.append(np.sqrt(np.mean((cad - fresh.tilt) ** 2)))
        ratios.append(com_distance(wheeled, fit.r) / com_distance(wheeled, r_true))
    # least squares' noise floor at fresh poses, σ √(p / (n − p − 1)) with p = 23 directions
    # determined from n = 40 rows (0.60°); the prior takes MAP below it
    floor = NOISE * math.sqrt(23 / (40 - 23 - 1))
    assert np.mean(errors) < (1.15 if method == "ls" else 0.6) * floor
    if method == "map":  # the CAD prior: no worse than the model in (almost) every draw
        assert np.mean(np.array(errors) <= np.array(cad_errors)) >= 0.8
    assert np.all(np.abs(np.array(ratios) - 1) < 0.25)


@pytest.mark.parametrize("method", ["ls", "map"])
def test_the_tilt_interval_covers_the_truth(wheeled, method):
    """Standard errors of the predicted tilt match its errors at fresh poses (z ≈ 1), the
    truth 10 % / 1 cm off the model."""
    rng = np.random.default_rng(11)
    zs = []
    for draw in range(8):
        r_true = perturbed(wheeled, rng)
        sim = simulate_balance(wheeled, 40, 45, NOISE, seed=draw, r_true=r_true)
        fresh = simulate_balance(wheeled, 300, 45, 0.0, seed=50 + draw, r_true=r_true)
        m = Measurements(q=sim.q, balance=np.zeros(40), gravity=sim.gravity)
        fit = identify(wheeled, m, method=method)
        z = (fit.predict_balance(fresh.q) - fresh.tilt) / fit.predict_balance_std(fresh.q)
        zs.append(np.sqrt(np.mean(z**2)))
    low, high = (0.7, 1.4) if method == "ls" else (0.5, 2.0)
    assert low < np.mean(zs) < high, zs


def test_a_known_com_height_sets_the_scale(wheeled):
    sim = simulate_balance(wheeled, 40, 45, NOISE, seed=3)
    m = Measurements(q=sim.q, balance=np.zeros(40), gravity=sim.gravity)
    for method in ("ls", "map"):
        fit = identify(wheeled, m, method=method, com_height=0.25)
        assert fit.scale is not None and fit.scale.by == "com_height"
        assert com_distance(wheeled, fit.r) == pytest.approx(0.25, rel=1e-12)
    with pytest.raises(sescid.OptionError, match="com_height"):
        identify(wheeled, m, com_height=-1.0)


def test_map_on_zero_sesc_bodies_never_traces_back(wheeled):
    """The wheels sit on the axle (zero SESC vectors); the CoP-style workaround of balance
    data (cop_x = 0, cop_y with a huge standard error) once raised LinAlgError in MAP."""
    sim = simulate_balance(wheeled, 40, 25, NOISE, seed=0)
    se = np.column_stack([np.full(40, 1e-3), np.full(40, 1e3)])
    m = Measurements(q=sim.q, cop=np.zeros((40, 2)), cop_se=se, gravity=sim.gravity)
    for prior in ("sesc", "bodies"):
        fit = identify(wheeled, m, weighted=True, method=MapOptions(prior=prior))
        assert fit.scale is not None  # all targets 0: anchored, not collapsed
        assert com_distance(wheeled, fit.r) > 0.1


def test_balance_needs_a_line_and_gravity(op2, wheeled):
    q = np.zeros((3, op2.nq))
    with pytest.raises(DataError, match="support line"):
        Measurements(q=q, balance=np.zeros(3), gravity=np.tile([0, 0, -1.0], (3, 1))).checked(op2)
    q = np.zeros((3, wheeled.nq))
    with pytest.raises(DataError, match="gravity direction"):
        Measurements(q=q, balance=np.zeros(3)).checked(wheeled)
    along = np.tile([0.0, -1.0, 0.0], (3, 1))  # gravity along the axle
    with pytest.raises(DataError, match="runs along the support line"):
        Measurements(q=q, balance=np.zeros(3), gravity=along).checked(wheeled)


def test_the_docs_table_is_a_run_of_the_study():
    """docs/balance.md quotes what tools/balance_study.py gives now."""
    import subprocess
    import sys

    tool = Path(__file__).parents[2] / "tools" / "balance_study.py"
    res = subprocess.run([sys.executable, str(tool), "--check"], capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr
