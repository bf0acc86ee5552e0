"""Poses for a payload (planning.payload): the D-optimal choice beats random candidates, and
the standard errors it promises are those a fit on its poses states."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from oracle import PinStatics
from payload_gen import robot_with_payload
from refs import erd

from sescid import Measurements, identify_payload, load_robot, read_table
from sescid.base import G0
from sescid.cli import cli
from sescid.kinds import TORQUE
from sescid.planning import PlanOptions, plan_payload_poses
from sescid.planning.design.payload import payload_rows

HAND = "MP_ARM_LOW_R"


@pytest.fixture(scope="module")
def op2():
    return load_robot("op2")


@pytest.mark.parametrize("mass", [None, 0.6])
def test_plan_promises_what_a_fit_states(op2, tmp_path, mass):
    sigma = 2e-3
    plan = plan_payload_poses(op2, HAND, 8, 0, PlanOptions(n_candidates=400, sigma=sigma),
                              mass=mass)  # fmt: skip
    assert plan.q.shape == (8, op2.nq)
    free = slice(0, 4) if mass is None else slice(1, 4)
    assert np.all(plan.std[free] <= plan.random_std[free] * 1.05)
    assert np.prod(plan.std[free]) < np.prod(plan.random_std[free])
    # the nominal payload on the planned poses, the CoP with the planned noise
    truth = robot_with_payload(op2, tmp_path, HAND, plan.nominal_mass, [0.0, 0.0, 0.0])
    cop = truth.cop(plan.q) + np.random.default_rng(1).normal(0, sigma, (8, 2))
    fit = identify_payload(op2, Measurements(q=plan.q, cop=cop), HAND, mass=mass,
                           cop_noise=sigma)  # fmt: skip
    p = fit.payload
    assert p is not None
    stated = np.concatenate([[p.mass_std], p.com_std])
    np.testing.assert_allclose(stated[free], plan.std[free], rtol=0.25)


def test_another_humanoid_plan_promises_what_a_fit_states(tmp_path):
    """example-robot-data's TALOS on its right sole, a payload in its right gripper: the plan
    (the planner's one engine over the payload's rows) beats random candidates, and the CoP
    fit on its poses states the standard errors it promised."""
    robot = load_robot(erd("talos_data/robots/talos_reduced.urdf"), "right_sole_link")
    hand, sigma = "gripper_right_base_link", 2e-3
    plan = plan_payload_poses(robot, hand, 8, 0, PlanOptions(n_candidates=300, sigma=sigma))
    assert plan.q.shape == (8, robot.nq) and plan.n_candidates == 300
    assert np.all(plan.std <= plan.random_std * 1.05)
    assert np.prod(plan.std) < 0.5 * np.prod(plan.random_std)
    truth = robot_with_payload(robot, tmp_path, hand, plan.nominal_mass, [0.0, 0.0, 0.0])
    cop = truth.cop(plan.q) + np.random.default_rng(1).normal(0, sigma, (8, 2))
    p = identify_payload(robot, Measurements(q=plan.q, cop=cop), hand, cop_noise=sigma).payload
    assert p is not None
    stated = np.concatenate([[p.mass_std], p.com_std])
    np.testing.assert_allclose(stated, plan.std, rtol=0.05)


def test_torque_plan_counts_the_offsets_the_fit_estimates(tmp_path):
    """TALOS's joint torques, a payload in its right gripper: the fit estimates every measured
    joint's offset from the plan's poses, so the plan counts them (nuisance columns) and the
    fit on Pinocchio's holding torques of the carrying robot (plus the planned noise) states
    the standard errors it promised; the same poses' std with the offsets known (the former
    design) promises too little (stated 2–18 % above it)."""
    robot = load_robot(erd("talos_data/robots/talos_reduced.urdf"), "right_sole_link")
    hand, tau_noise = "gripper_right_base_link", 0.05
    opt = PlanOptions(n_candidates=300, kinds="tau", tau_noise=tau_noise)
    plan = plan_payload_poses(robot, hand, 8, 0, opt)
    assert np.all(plan.std <= plan.random_std * 1.05)
    truth = robot_with_payload(robot, tmp_path, hand, plan.nominal_mass, [0.0, 0.0, 0.0])
    joints = tuple(robot.joint_names)
    tau = PinStatics(truth.model_path, robot.support, list(joints), G0).torques(plan.q)
    tau += np.random.default_rng(1).normal(0, tau_noise, tau.shape)
    fit = identify_payload(robot, Measurements(q=plan.q, tau=tau, tau_joints=joints), hand,
                           tau_noise=tau_noise)  # fmt: skip
    p = fit.payload
    assert p is not None and len(fit.nuisance) == len(joints)  # one offset per measured joint
    stated = np.concatenate([[p.mass_std], p.com_std])
    np.testing.assert_allclose(stated, plan.std, rtol=0.02)
    # the offsets known: F = Σ AᵀA of the poses' torque rows alone, c = h / m at the origin
    a = payload_rows(robot, hand, plan.q, (TORQUE,), plan.nominal_mass, opt.sigma, tau_noise).x
    cov = np.linalg.inv(np.einsum("nra,nrb->ab", a, a))
    known = np.sqrt(np.diag(cov)) / np.array([1.0, *[plan.nominal_mass] * 3])
    assert np.all(stated > known * 1.01) and np.max(stated / known) > 1.1


def test_poses_payload_cli(tmp_path):
    out = tmp_path / "p.csv"
    res = CliRunner().invoke(cli, ["poses", "--payload", HAND, "--candidates", "300", "--out",
                                   str(out)])  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "expected std, chosen: mass ±" in res.output
    assert len(read_table(out).get("r_el")) == 8
    res = CliRunner().invoke(cli, ["poses", "--payload", "hand", "--out", str(tmp_path / "x")])
    assert res.exit_code == 2 and "no link named 'hand'" in res.output
    assert len(res.output.strip().splitlines()) == 1
