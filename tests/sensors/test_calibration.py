"""Foot-pad gains/offsets estimated with the mass model, checked against the bench's truth."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import sescid
from sescid.bench import ExperimentConfig, real_robot, run_experiment
from sescid.estimation import to_consistent
from sescid.planning import candidates
from sescid.sensors import (
    KnownSensors,
    calibrate_sensors,
    calibrated_sensor_document,
    fsr,
    load_sensors,
    pad_session,
    table_from_columns,
)

BENCH = ExperimentConfig(fsr_gain=0.05, fsr_bias=0.1)
BENCH_TWO = ExperimentConfig(double_support=True, fsr_gain=0.05, fsr_noise=0.5, backlash_deg=0.0)


@pytest.fixture(scope="module")
def setup():
    right = sescid.load_robot("op2")
    left = sescid.load_robot("op2", support="l_sole")
    cfg = load_sensors(profile=right.profile)
    kw = {"n_candidates": 1500, "n_test": 100, "random_draws": 1}  # the protocol: D-optimal
    q_r = sescid.plan_poses(right, count=38, seed=0, **kw).q
    q_l = sescid.plan_poses(left, count=38, seed=1, **kw).q
    return right, left, cfg, q_r, q_l


def _sessions(setup, seed, feet=("right", "left")):
    right, left, cfg, q_r, q_l = setup
    out, truth = [], {}
    for foot, robot, q in (("right", right, q_r), ("left", left, q_l)):
        if foot not in feet:
            continue
        ex = run_experiment(robot, q, cfg, samples=100, seed=seed, config=BENCH)
        out.append(pad_session(right, table_from_columns(ex.columns), cfg, foot))
        truth[foot] = ex.truth
    return out, truth


def _coverage(setup, seeds):
    """Pooled |estimate − truth| < 2σ shares of gains and offsets, and held-out CoP ratios."""
    right = setup[0]
    r_true, mass, _ = real_robot(right, BENCH)
    hold = candidates(right, 200, seed=99).q
    cop_true = right.cop(hold, r_true)
    zg, zo, ratio = [], [], []
    for seed in seeds:
        sessions, truth = _sessions(setup, seed)
        cal = calibrate_sensors(right, sessions, total_mass=mass, offset_prior=0.1)
        gains = truth["right"].pad_gain
        for foot in ("right", "left"):
            v, s = cal.gain("default", foot)
            zg += list((v - np.array(gains[foot])) / s)
            v, s = cal.offset(foot, foot)
            zo += list((v - truth[foot].pad_bias[foot]) / s)
        known = KnownSensors(
            gains={("default", f): np.array(g) for f, g in gains.items()},
            offsets={(f, f): truth[f].pad_bias[f] for f in ("right", "left")},
        )
        ideal = calibrate_sensors(right, sessions, total_mass=mass, known=known)
        err = [math.sqrt(np.mean((c.fit.predict_cop(hold) - cop_true) ** 2)) for c in (cal, ideal)]
        ratio.append(err[0] / err[1])
    zg, zo = np.abs(np.array(zg)), np.abs(np.array(zo))
    return float(np.mean(zg < 2)), float(np.mean(zo < 2)), float(np.mean(ratio))


def test_gains_offsets_cover_truth_4_seeds(setup):
    """Both feet, 38 poses each, 5 % gain / 0.1 N offset errors: ≥ 85 % of the 32 gains and of
    the 32 offsets within 2σ over 4 seeds (at the nominal 95 %, fewer than 28 of 32 has a
    chance of about 2 %; the slow test asks 90 % of 400)."""
    g, o, ratio = _coverage(setup, range(4))
    assert g >= 0.85 and o >= 0.85
    assert ratio <= 1.2  # held-out CoP error ≤ perfectly calibrated sensors + 20 %


@pytest.mark.slow
def test_gains_offsets_cover_truth_50_seeds(setup):
    """The same over 50 bench seeds: ≥ 90 % of gains and of offsets within 2σ of the truth."""
    g, o, ratio = _coverage(setup, range(50))
    assert g >= 0.9 and o >= 0.9
    assert ratio <= 1.2


def test_one_foot_names_unidentifiable_directions(setup):
    """Right foot only, no weighed mass: left gains, offset twist, confounded offsets, scale."""
    sessions, _ = _sessions(setup, 0, feet=("right",))
    cal = calibrate_sensors(setup[0], sessions)
    kinds = [d.kind for d in cal.unidentifiable]
    left_gains = [
        d
        for d in cal.unidentifiable
        if d.kind == "unloaded-foot" and "gain[default/left" in d.label()
    ]
    assert len(left_gains) == 4
    assert kinds.count("offset-twist") == 1
    assert kinds.count("support-confounded") == 2  # the offsets' two moments vs r[support]
    assert kinds.count("scale") == 1
    confounded = [d for d in cal.unidentifiable if d.kind == "support-confounded"]
    assert all(d.mass_terms for d in confounded)  # the SESC components that hide them
    # the twist is (+, −, −, +) over the rectangle's pads: orthogonal to 1, x, y
    twist = next(d for d in cal.unidentifiable if d.kind == "offset-twist")
    np.testing.assert_allclose(np.abs([c for _, c in twist.terms]), 0.5, atol=1e-9)


def test_both_feet_only_twists_left(setup):
    """Each foot in turn with a weighed mass: no confounded direction, no scale, no gain unseen."""
    sessions, truth = _sessions(setup, 1)
    cal = calibrate_sensors(setup[0], sessions, total_mass=truth["right"].true_mass)
    kinds = {d.kind for d in cal.unidentifiable}
    assert "support-confounded" not in kinds and "scale" not in kinds
    assert all(p.unseen < 1e-6 for p in cal.gains)
    assert sum(d.kind == "offset-twist" for d in cal.unidentifiable) == 2
    assert [s.poses for s in cal.sessions] == [len(s.q) for s in sessions]
    assert sum(s.share for s in cal.sessions) == pytest.approx(1.0)


def test_calibrated_sensor_file_removes_gain_error(setup, tmp_path):
    """fsr with the true gains/offsets in a sescid-fsr/2 file gives the true CoP (noise-free)."""
    right, _, cfg, q_r, _ = setup
    bench = ExperimentConfig(fsr_gain=0.08, fsr_bias=0.3, fsr_noise=0.0, backlash_deg=0.0,
                             readback_jitter_ticks=0.0)  # fmt: skip
    ex = run_experiment(right, q_r[:10], cfg, samples=5, seed=4, config=bench)
    sessions = [pad_session(right, table_from_columns(ex.columns), cfg, "s")]
    cal = calibrate_sensors(right, sessions)
    doc = calibrated_sensor_document(cfg.source, cal, "s")
    for foot in ("right", "left"):  # the truth in the written file's fields
        doc["feet"][foot]["gains"] = list(ex.truth.pad_gain[foot])
        doc["feet"][foot]["offsets_N"] = list(ex.truth.pad_bias[foot])
    path = tmp_path / "cal.json"
    path.write_text(json.dumps(doc))
    cal_cfg = load_sensors(path)
    assert cal_cfg.foot("right").gains is not None
    table = table_from_columns(ex.columns)
    raw, _ = fsr(right, table, cfg)
    fixed, _ = fsr(right, table, cal_cfg)
    truth = np.array(ex.truth.cop_true)
    assert np.abs(fixed.data.cop - truth).max() < 2e-5  # mN rounding only
    assert np.abs(raw.data.cop - truth).max() > 10 * np.abs(fixed.data.cop - truth).max()


def test_double_support_bench_and_calibration(setup):
    """Two-foot poses: fsr's combined CoP equals the statics; the calibration uses both feet."""
    right, _, cfg, _, _ = setup
    rng = np.random.default_rng(0)
    q = np.zeros((30, right.nq))
    moving = ("r_sho", "l_sho", "r_el", "l_el", "head")
    arms = [i for i, j in enumerate(right.joint_names) if j.startswith(moving)]
    q[:, arms] = rng.uniform(-0.6, 0.6, size=(30, len(arms)))
    q = np.clip(q, right.joint_limits[:, 0], right.joint_limits[:, 1])
    bench = ExperimentConfig(double_support=True, fsr_noise=0.0, fsr_bias=0.0, backlash_deg=0.0,
                             readback_jitter_ticks=0.0)  # fmt: skip
    ex = run_experiment(right, q, cfg, samples=6, seed=0, config=bench)
    table = table_from_columns(ex.columns)
    res, _ = fsr(right, table, cfg)
    assert np.abs(res.data.cop - np.array(ex.truth.cop_true)).max() < 2e-5
    session = pad_session(right, table, cfg, "two")
    assert all(f.loaded.all() for f in session.feet)
    noisy = run_experiment(right, q, cfg, samples=100, seed=0, config=BENCH_TWO)
    session = pad_session(right, table_from_columns(noisy.columns), cfg, "two")
    cal = calibrate_sensors(right, [session], total_mass=noisy.truth.true_mass)
    assert cal.sessions[0].double_support_poses == len(session.q) > 20
    # the elastic split is linear in the CoP: the pads' pattern barely separates the gains
    assert max(p.std for p in cal.gains) > 0.1
    r_true, _, _ = real_robot(right, BENCH_TWO)
    err = cal.fit.predict_cop(session.q) - right.cop(session.q, r_true)
    # feet fixed: the offsets' moments are a constant CoP shift, confounded with r[support]
    assert any(d.kind == "support-confounded" for d in cal.unidentifiable)
    assert np.sqrt(np.mean((err - err.mean(axis=0)) ** 2)) < 5e-4


def test_consistent_default_is_controller_ready():
    """Default consistent step on a noisy 38-pose LS fit: worst body-mass change ≤ 10 %."""
    robot = sescid.load_robot("op2")
    sim = sescid.simulate(robot, n=38, range_deg=30, noise=0.00493, seed=3)
    ls = sescid.identify(robot, sim.q, sim.cop, method="ls")
    fit = to_consistent(ls)
    _, worst = fit.inertials.worst_mass_change()
    assert worst <= 0.10
    old = to_consistent(ls, sescid.ConsistentOptions(via="fit"))
    assert old.inertials.worst_mass_change()[1] > 3 * worst  # the noise-following path
