"""Payload identification (estimation.payload) against a robot that carries a known payload:
the model file with one more link, loaded and simulated by sescid, and Pinocchio's holding
torques of that file."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from oracle import PinStatics
from payload_gen import robot_with_payload
from refs import erd

import sescid
from sescid import Measurements, identify_payload, load_robot
from sescid.base import G0
from sescid.errors import DataError, ModelError, OptionError
from sescid.estimation import PayloadOptions, load_fit, payload_fit, save_fit
from sescid.simulation import TorqueNoise, simulate, simulate_balance

HAND, MASS, COM = "MP_ARM_LOW_R", 1.2, np.array([0.08, 0.0, 0.0])


@pytest.fixture(scope="module")
def op2():
    return load_robot("op2")


@pytest.fixture(scope="module")
def carrying(op2, tmp_path_factory):
    """The OP2 with a 1.2 kg box 80 mm from its right lower arm's origin."""
    return robot_with_payload(op2, tmp_path_factory.mktemp("payload"), HAND, MASS, COM)


def _data(truth, op2, n, seed, kind, noise=1e-3, tau_noise=0.05):
    sim = simulate(truth, n=n, noise=noise, seed=seed, torques=TorqueNoise(noise=tau_noise))
    if kind == "cop":
        return Measurements(q=sim.q, cop=sim.cop).checked(op2)
    return Measurements(q=sim.q, tau=sim.torques.tau, tau_joints=sim.torques.joints).checked(op2)


@pytest.mark.parametrize("kind", ["cop", "tau"])
@pytest.mark.parametrize("weighed", [False, True])
def test_recovers_the_payload_within_its_stated_errors(op2, carrying, kind, weighed):
    """Over 30 draws of 8 poses, mass and CoM errors divided by their stated standard errors
    behave like N(0, 1): about 95 % within 2 (t-tails with few rows: ≥ 85 %), RMS near 1."""
    z = []
    for seed in range(30):
        m = _data(carrying, op2, 8, seed, kind)
        fit = payload_fit(op2, [m], PayloadOptions(HAND, MASS if weighed else None))
        p = fit.payload
        assert p is not None and p.unseen == ()
        est = np.concatenate([[p.mass], p.com])
        std = np.concatenate([[p.mass_std], p.com_std])
        truth = np.concatenate([[MASS], COM])
        if weighed:
            assert p.mass == MASS and p.mass_std == 0.0
            est, std, truth = est[1:], std[1:], truth[1:]
        z.append((est - truth) / std)
    z = np.array(z)
    assert np.mean(np.abs(z) < 2) >= 0.85, z
    assert 0.6 < math.sqrt(np.mean(z**2)) < 1.5, np.sqrt(np.mean(z**2, axis=0))


def test_fit_predicts_the_carrying_robot_and_pinocchio_torques(op2, carrying, tmp_path):
    """The payload fit's CoP and holding torques at fresh poses: those of the robot with the
    payload link (sescid's own model of that file), and Pinocchio's computeGeneralizedGravity
    statics of the same URDF."""
    m = _data(carrying, op2, 16, 3, "tau", tau_noise=1e-4)
    fit = payload_fit(op2, [m], PayloadOptions(HAND))
    q = sescid.simulation.random_poses(op2, 6, 25.0, 9, clip=True)
    np.testing.assert_allclose(fit.predict_cop(q), carrying.cop(q), atol=2e-4)
    assert fit.total_mass == pytest.approx(carrying.total_mass, abs=2e-3)
    pin = PinStatics(carrying.model_path, op2.support, op2.joint_names, G0)
    np.testing.assert_allclose(fit.predict_torque(q), pin.torques(q), atol=5e-3)
    # the exact payload gives Pinocchio's torques to rounding (the rows' algebra, no noise)
    exact = payload_fit(
        op2, [Measurements(q=m.q, tau=pin.torques(m.q), tau_joints=m.tau_joints)],
        PayloadOptions(HAND),
    )  # fmt: skip
    assert exact.payload is not None
    assert exact.payload.mass == pytest.approx(MASS, abs=1e-6)
    np.testing.assert_allclose(exact.payload.com, COM, atol=1e-6)
    np.testing.assert_allclose(exact.predict_torque(q), pin.torques(q), atol=1e-6)


def test_exact_cop_on_a_tilted_support_and_pooled_kinds(op2, carrying):
    """Noise-free CoP under tilted gravity with torques pooled: the exact payload (the CoP's
    division by the new total mass fitted exactly, not linearised)."""
    sim = simulate(carrying, n=6, noise=0.0, seed=2, tilt=0.1)
    cop = Measurements(q=sim.q, cop=sim.cop, gravity=sim.gravity).checked(op2)
    tau = Measurements(q=sim.q, tau=carrying.torques(sim.q), tau_joints=tuple(op2.joint_names))
    for data in ([cop], [cop, tau.checked(op2)]):
        p = payload_fit(op2, data, PayloadOptions(HAND)).payload
        assert p is not None
        assert p.mass == pytest.approx(MASS, abs=1e-7)
        np.testing.assert_allclose(p.com, COM, atol=1e-7)


def test_a_body_the_poses_never_turn_is_seen_only_in_part(op2, carrying):
    """Poses that move only the left leg never turn the right arm: the payload's mass and its
    horizontal moment are seen, its CoM along the vertical is not — nan, with a reason and a
    number of poses that would determine it."""
    sim = simulate(carrying, n=12, noise=1e-4, seed=1)
    q = np.zeros_like(sim.q)
    left = [i for i, j in enumerate(op2.joint_names) if j.startswith("l_") and "sho" not in j
            and j != "l_el"]  # fmt: skip
    q[:, left] = sim.q[:, left]
    cop = carrying.cop(q) + np.random.default_rng(0).normal(0, 1e-4, (len(q), 2))
    p = payload_fit(op2, [Measurements(q=q, cop=cop).checked(op2)], PayloadOptions(HAND)).payload
    assert p is not None
    assert p.unseen and "mass" not in p.unseen
    assert p.mass == pytest.approx(MASS, rel=0.05)
    assert all(math.isnan(p.com["xyz".index(c[-1])]) for c in p.unseen)
    assert p.more_poses is not None and p.more_poses >= 1
    assert HAND in p.reason and "poses --payload" in p.reason


def test_payload_on_the_support_body_cannot_be_completed_by_poses(op2, tmp_path):
    foot = op2.model.bodies[0].name
    truth = robot_with_payload(op2, tmp_path, foot, 0.3, [0.01, 0.0, 0.02])
    sim = simulate(truth, n=10, noise=1e-4, seed=0)
    fit = payload_fit(op2, [Measurements(q=sim.q, cop=sim.cop).checked(op2)],
                      PayloadOptions(foot))  # fmt: skip
    p = fit.payload
    assert p is not None and "com_z" in p.unseen and p.more_poses is None
    assert math.isnan(p.com[2]) and math.isnan(p.com_std[2])
    assert p.mass == pytest.approx(0.3, rel=0.05)


def test_base_fit_from_another_stance(op2, carrying):
    """The base is a least-squares fit made on the right foot; the payload's data stand on
    the left foot: the body parameters behind the fit carry over."""
    own = simulate(op2, n=300, noise=1e-4, seed=7)
    base = sescid.identify(op2, own.q, cop=own.cop, method="ls")
    left = carrying.stance("l_sole")
    sim = simulate(left, n=12, noise=1e-3, seed=4)
    m = Measurements(q=sim.q, cop=sim.cop, support="l_sole").checked(left)
    p = payload_fit(op2, [m], PayloadOptions(HAND), base).payload
    assert p is not None and p.stances == ("l_sole",) and p.base.startswith("fit")
    assert abs(p.mass - MASS) < 4 * p.mass_std
    assert np.all(np.abs(p.com - COM) < 4 * p.com_std + 1e-3)


def test_talos_torques_recover_a_hand_payload(tmp_path):
    """Another humanoid: example-robot-data's TALOS (reduced), a 1.2 kg box 80 mm from its
    right gripper's origin, joint torques with the right sole held."""
    path = erd("talos_data/robots/talos_reduced.urdf")
    robot = load_robot(path, "right_sole_link")
    hand = "gripper_right_base_link"
    truth = robot_with_payload(robot, tmp_path, hand, MASS, COM)
    sim = simulate(truth, n=8, noise=1e-3, seed=1, torques=TorqueNoise(noise=0.1), clip=True,
                   range_deg=20)  # fmt: skip
    m = Measurements(q=sim.q, tau=sim.torques.tau, tau_joints=sim.torques.joints).checked(robot)
    p = payload_fit(robot, [m], PayloadOptions(hand)).payload
    assert p is not None and not p.unseen
    assert abs(p.mass - MASS) < 4 * p.mass_std
    assert np.all(np.abs(p.com - COM) < 4 * p.com_std)


def test_fit_file_keeps_the_payload(op2, carrying, tmp_path):
    m = _data(carrying, op2, 8, 0, "cop")
    fit = identify_payload(op2, m, HAND)
    save_fit(fit, tmp_path / "fit.json")
    back = load_fit(tmp_path / "fit.json")
    assert back.payload is not None and fit.payload is not None
    assert back.payload.mass == fit.payload.mass
    np.testing.assert_array_equal(back.payload.com, fit.payload.com)
    np.testing.assert_array_equal(back.payload.com_std, fit.payload.com_std)
    assert back.total_mass == fit.total_mass
    np.testing.assert_allclose(back.predict_cop(m.q), fit.predict_cop(m.q), atol=1e-15)
    # a file without the payload object (every file written before it) reads as before
    doc = json.loads((tmp_path / "fit.json").read_text())
    del doc["payload"]
    (tmp_path / "old.json").write_text(json.dumps(doc))
    assert load_fit(tmp_path / "old.json").payload is None


def test_bad_input(op2, carrying, tmp_path):
    m = _data(carrying, op2, 8, 0, "cop")
    with pytest.raises(ModelError, match="no link named 'hand'"):
        identify_payload(op2, m, "hand")
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(OptionError, match="payload_mass"):
            identify_payload(op2, m, HAND, mass=bad)
    other = load_robot(erd("talos_data/robots/talos_reduced.urdf"), "right_sole_link")
    base = identify_payload(other, Measurements(q=np.zeros((3, other.nq)), cop=np.zeros((3, 2))),
                            "gripper_right_base_link", mass=1.0)  # fmt: skip
    with pytest.raises(DataError, match="base fit is of the robot"):
        identify_payload(op2, m, HAND, base=base)


def test_balance_on_a_wheel_axle(tmp_path):
    """A wheeled humanoid balancing on its axle: the balancing tilts give the payload (exactly
    from noise-free tilts; within its stated errors from an IMU with 0.2° noise)."""
    robot = load_robot("wheeled_humanoid", "axle", line="y")
    truth = robot_with_payload(robot, tmp_path, "forearm_r", 0.8, [0.05, 0.02, -0.03])
    for noise in (0.0, math.radians(0.2)):
        sim = simulate_balance(truth, n=16, tilt_noise=noise, seed=3)
        m = Measurements(q=sim.q, balance=np.zeros(16), gravity=sim.gravity).checked(robot)
        p = payload_fit(robot, [m], PayloadOptions("forearm_r")).payload
        assert p is not None and p.kinds[0].kind == "balance" and not p.unseen
        truth_p = np.array([0.8, 0.05, 0.02, -0.03])
        est = np.concatenate([[p.mass], p.com])
        if noise == 0:
            np.testing.assert_allclose(est, truth_p, atol=1e-7)
        else:
            std = np.concatenate([[p.mass_std], p.com_std])
            assert np.all(np.abs(est - truth_p) < 4 * std), (est, std)


def test_two_stances_determine_a_payload_on_one_foot(op2, tmp_path):
    """On its own foot a payload never turns (its height unseen); the other foot's stance turns
    it: pooled, every component is determined."""
    foot = op2.model.bodies[0].name
    truth = robot_with_payload(op2, tmp_path, foot, 0.3, [0.01, 0.0, 0.02])
    right = simulate(truth, n=10, noise=1e-4, seed=0)
    left_robot = truth.stance("l_sole")
    left = simulate(left_robot, n=10, noise=1e-4, seed=1)
    data = [
        Measurements(q=right.q, cop=right.cop).checked(op2),
        Measurements(q=left.q, cop=left.cop, support="l_sole").checked(op2.stance("l_sole")),
    ]
    p = payload_fit(op2, data, PayloadOptions(foot)).payload
    assert p is not None and p.unseen == () and set(p.stances) == {op2.support, "l_sole"}
    assert abs(p.mass - 0.3) < 4 * p.mass_std
    assert np.all(np.abs(p.com - [0.01, 0.0, 0.02]) < 4 * p.com_std)


def test_a_noisy_base_fit_of_the_same_support(op2, carrying):
    """The base is a least-squares fit of 40 poses with 2 mm CoP noise (its own errors enter the
    payload's rows, correlated: propagated with its covariance): over 20 draws the payload's
    errors stay within their stated standard errors."""
    z = []
    for seed in range(20):
        own = simulate(op2, n=40, noise=2e-3, seed=100 + seed)
        base = sescid.identify(op2, own.q, cop=own.cop, method="ls")
        sim = simulate(carrying, n=8, noise=2e-3, seed=seed)
        m = Measurements(q=sim.q, cop=sim.cop).checked(op2)
        p = payload_fit(op2, [m], PayloadOptions(HAND), base).payload
        assert p is not None and p.base == "fit: ls"
        est = np.concatenate([[p.mass], p.com])
        z.append((est - np.concatenate([[MASS], COM])) / np.concatenate([[p.mass_std], p.com_std]))
    z = np.array(z)
    assert np.mean(np.abs(z) < 2) >= 0.85, z
    assert 0.6 < math.sqrt(np.mean(z**2)) < 1.5
