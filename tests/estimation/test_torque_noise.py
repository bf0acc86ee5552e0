"""Torque noise per joint (``estimation.torque_noise``: feasible GLS) and the negative
friction-band warning's threshold (``checks.negative_bands``), against independent references:
the hat matrix's trace of a dense least squares, a weighted ``numpy.linalg.lstsq`` of the same
rows, and simulated sensors of known noise, friction and sign."""

from __future__ import annotations

import numpy as np
import pytest

import sescid
from sescid.estimation import IdentifyOptions, Measurements
from sescid.estimation.data.checks import FRICTION_ALARM_RATE, friction_threshold, negative_bands
from sescid.estimation.data.sources import HeldSource
from sescid.estimation.solvers.torque_noise import joint_stats, leverages
from sescid.simulation import random_poses

G0 = 9.81


@pytest.fixture(scope="module")
def op2():
    return sescid.load_robot("op2")


def _data(robot, n, sigma, seed, friction=None, side_sign=1.0):
    """n random poses, torques with noise σ_j per joint (J,), random offsets, and a friction
    band (J,) on random approach sides (reported with ``side_sign``: −1 a reversed column)."""
    rng = np.random.default_rng(seed)
    q = random_poses(robot, n, 30, seed + 1000)
    names = tuple(robot.joint_names)
    tau = robot.torques(q, joints=names, g0=G0) + rng.normal(0, 0.1, len(names))
    tau += rng.normal(size=(n, len(names))) * sigma
    side = None
    if friction is not None:
        side = np.where(rng.random(n) < 0.5, 1.0, -1.0)
        tau += side[:, None] * friction
        side = side * side_sign
    return Measurements(q=q, tau=tau, tau_joints=names, approach=side)


def _dense(robot, m, mass):
    """The torque rows as one dense matrix [Φ M, offset columns] (n·J, 3N + J), joint-major."""
    n, nj = m.tau.shape
    phi = robot.torque_regressor(m.q, m.tau_joints, g0=G0) * mass
    nx = phi.shape[2]
    a = np.zeros((n * nj, nx + nj))
    for j in range(nj):
        a[j * n : (j + 1) * n, :nx] = phi[:, j]
        a[j * n : (j + 1) * n, nx + j] = 1.0
    return a, m.tau.T.reshape(-1)


def test_each_joints_share_of_the_parameters_is_the_hat_matrix_trace(op2):
    """t_j + k_j (``leverages``) is the trace of the least-squares hat matrix over joint j's
    rows, computed densely (H = A A⁺ of the rows with their offset columns); their sum is the
    fit's n − dof exactly, and close to MAP's effective number of parameters."""
    m = _data(op2, 40, 0.05, 1).checked(op2)
    opts = IdentifyOptions(tau_noise_model="shared", robust=False, gravity_accel=G0,
                           total_mass=op2.total_mass)  # fmt: skip
    fit = sescid.identify(op2, m, method="ls", options=opts)
    scale = dict.fromkeys(m.tau_joints, 1.0)
    st = joint_stats(fit, [HeldSource(m)], m.tau_joints, False, scale)
    t = leverages(st, fit.cov, fit.kind("tau").sigma)
    a, _ = _dense(op2, m, op2.total_mass)
    h = np.einsum("ij,ji->i", a, np.linalg.pinv(a, rcond=1e-10, hermitian=False))
    ref = h.reshape(op2.nq, -1).sum(axis=1)
    np.testing.assert_allclose(t + st.k, ref, atol=1e-6)
    assert (t + st.k).sum() == pytest.approx(fit.n_rows - fit.kind("tau").dof, abs=1e-6)
    mapped = sescid.identify(op2, m, method="map", options=opts)
    t_map = leverages(st, mapped.cov, mapped.kind("tau").sigma)
    assert (t_map + st.k).sum() == pytest.approx(mapped.map.effective_parameters, abs=1.0)


def test_per_joint_noise_is_estimated_and_weighs_the_rows(op2):
    """Noise from 0.005 to 0.5 N·m across the joints: each σ_j is recovered (within its own
    chi-square spread), σ̂ is a scale ≈ 1, and the least-squares fit is the weighted least
    squares of an independent ``lstsq`` with each joint's rows divided by the σ_j it used."""
    sigma = np.geomspace(0.005, 0.5, op2.nq)
    m = _data(op2, 120, sigma, 2)
    fit = sescid.identify(op2, m, method="ls", robust=False, gravity_accel=G0,
                          total_mass=op2.total_mass)  # fmt: skip
    got = np.array([r.sigma for r in fit.torque_noise])
    assert np.all(np.abs(got / sigma - 1) < 0.3)
    assert fit.kind("tau").sigma == pytest.approx(1.0, rel=0.1) and fit.kind("tau").weighted
    assert all(r.unit == "N·m" and r.by == "estimated" for r in fit.torque_noise)
    a, y = _dense(op2, m, op2.total_mass)
    w = np.repeat(1.0 / got, m.n)
    x0 = np.concatenate([op2.sesc_vectors().reshape(-1), np.zeros(op2.nq)])
    dx = np.linalg.lstsq(a * w[:, None], (y - a @ x0) * w, rcond=1e-10)[0]
    qf = random_poses(op2, 500, 30, 3)
    ref = op2.com(qf, (x0 + dx)[: 3 * len(op2.body_names)].reshape(-1, 3))
    np.testing.assert_allclose(fit.predict_com(qf)[:, :2], ref[:, :2], atol=1e-9)


def test_per_joint_noise_is_closer_to_the_truth_than_one_shared_level(op2):
    """A perturbed robot whose torque noise grows with the joint's load (as joint play makes
    it): over 10 draws, the default fit (MAP, noise per joint) predicts the CoM better than the
    same fit with one shared noise level, and never worse than the CAD model."""
    from sescid.estimation.result.validation import perturbed_sesc

    r_true = perturbed_sesc(op2, 0.05, offset=0.01, seed=5)
    qf = random_poses(op2, 1000, 30, 6)
    names = tuple(op2.joint_names)
    load = np.abs(op2.torques(random_poses(op2, 200, 30, 7), joints=names, g0=G0)).mean(axis=0)

    def err(r):
        d = op2.com(qf, r)[:, :2] - op2.com(qf, r_true)[:, :2]
        return float(np.sqrt(np.mean(np.sum(d**2, axis=1))))

    joint, shared, cad = [], [], err(op2.sesc_vectors())
    for seed in range(10):
        rng = np.random.default_rng(seed)
        q = random_poses(op2, 38, 30, 100 + seed)
        tau = op2.torques(q, r_true, joints=names, g0=G0)
        tau = tau + rng.normal(size=tau.shape) * (0.01 + 0.05 * load)
        m = Measurements(q=q, tau=tau, tau_joints=names)
        kw = {"gravity_accel": G0, "total_mass": op2.total_mass, "robust": False}
        joint.append(err(sescid.identify(op2, m, **kw).r))
        shared.append(err(sescid.identify(op2, m, tau_noise_model="shared", **kw).r))
    assert np.mean(joint) < np.mean(shared) and max(joint) < cad


def test_a_given_noise_or_noise_free_rows_keep_one_level(op2):
    """``tau_noise`` given: one known level, no per-joint records; noise-free rows (simulated
    exactly) have no noise to estimate per joint and keep one level."""
    m = _data(op2, 40, 0.05, 8)
    fit = sescid.identify(op2, m, method="ls", tau_noise=0.05, total_mass=op2.total_mass)
    assert fit.torque_noise == () and fit.kind("tau").sigma_by == "given"
    exact = Measurements(q=m.q, tau=op2.torques(m.q, joints=m.tau_joints), tau_joints=m.tau_joints)
    fit = sescid.identify(op2, exact, method="ls", total_mass=op2.total_mass)
    assert fit.torque_noise == ()


def test_weighted_torques_get_a_scale_per_joint_on_their_errors(op2, tmp_path):
    """--weighted with tau_se columns: σ_j is a scale on the given errors (≈ 2 where they
    understate the noise twice), stored in the fit file and read back."""
    sigma = np.full(op2.nq, 0.05)
    m = _data(op2, 80, sigma, 9)
    se = np.full(m.tau.shape, 0.05)
    se[:, :10] = 0.025  # the first ten sensors claim half their noise
    w = Measurements(q=m.q, tau=m.tau, tau_joints=m.tau_joints, tau_se=se)
    fit = sescid.identify(op2, w, method="ls", weighted=True, robust=False,
                          total_mass=op2.total_mass)  # fmt: skip
    got = np.array([r.sigma for r in fit.torque_noise])
    assert all(r.unit == "1" for r in fit.torque_noise)
    np.testing.assert_allclose(got[:10], 2.0, rtol=0.3)
    np.testing.assert_allclose(got[10:], 1.0, rtol=0.3)
    sescid.save_fit(fit, tmp_path / "fit.json")
    assert sescid.load_fit(tmp_path / "fit.json").torque_noise == fit.torque_noise


def test_friction_threshold_is_bonferroni():
    """z with P(any of n standard normals < −z) ≤ rate: 2.33 for one band at 1 %, higher
    for more; the simulated family-wise rate of 20 independent bands stays below the rate."""
    assert friction_threshold(1) == pytest.approx(2.3263, abs=1e-4)
    assert friction_threshold(33) > friction_threshold(20) > 3.2
    # a standard error of few degrees of freedom: Student's t, wider; many: the normal's
    assert friction_threshold(20, dof=35) > friction_threshold(20) + 0.25
    assert friction_threshold(20, dof=1e9) == pytest.approx(friction_threshold(20), abs=1e-6)
    from statistics import NormalDist

    exact = 1 - (1 - NormalDist().cdf(-friction_threshold(20))) ** 20
    assert exact <= FRICTION_ALARM_RATE and exact > 0.99 * FRICTION_ALARM_RATE
    draws = np.random.default_rng(0).normal(size=(200_000, 20))
    rate = float(np.mean((draws < -friction_threshold(20)).any(axis=1)))
    assert rate == pytest.approx(exact, abs=4 * np.sqrt(exact / 200_000))


def _warned(fit) -> bool:
    return any(w.startswith("negative static-friction bands") for w in fit.warnings)


@pytest.mark.slow
def test_negative_friction_warning_false_alarms_and_detection(op2):
    """Zero friction, 60 noise draws (the default fit, noise per joint): the warning fires in
    at most 3 (its family-wise rate is 1 %; the former 2σ rule fired in over a quarter);
    a reversed approach column (bands 0.1–0.3 N·m) is named in every draw."""
    alarms, old, reversed_found = 0, 0, 0
    for seed in range(60):
        m = _data(op2, 40, 0.05, 200 + seed, friction=np.zeros(op2.nq))
        fit = sescid.identify(op2, m, total_mass=op2.total_mass, gravity_accel=G0)
        alarms += _warned(fit)
        old += any(
            e.what == "friction" and e.value < -2 * e.std for e in fit.nuisance if e.determined
        )
        f = np.random.default_rng(seed).uniform(0.1, 0.3, op2.nq)
        bad = _data(op2, 40, 0.05, 200 + seed, friction=f, side_sign=-1.0)
        fit = sescid.identify(op2, bad, total_mass=op2.total_mass, gravity_accel=G0)
        negative, _ = negative_bands(fit)
        reversed_found += _warned(fit) and len(negative) == op2.nq
    assert alarms <= 3 and old >= 15 and reversed_found == 60


def test_a_reversed_approach_column_is_named(op2):
    """One draw: every band of a reversed approach column is significantly negative."""
    f = np.random.default_rng(1).uniform(0.1, 0.3, op2.nq)
    bad = _data(op2, 40, 0.05, 11, friction=f, side_sign=-1.0)
    fit = sescid.identify(op2, bad, total_mass=op2.total_mass, gravity_accel=G0)
    negative, z = negative_bands(fit)
    assert len(negative) == op2.nq and _warned(fit) and z >= friction_threshold(op2.nq)
