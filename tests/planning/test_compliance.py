"""Stability on a compliant robot: the CoM and its Jacobian against Pinocchio and MuJoCo, the
dynamic CoP against its formulas written out by hand, and the margin against the MuJoCo bench
(the poses it keeps stand; many it rejects topple)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from refs import G, compliant_cop_by_hand, erd, write_humanoid

import sescid
from sescid import planning as design
from sescid.bench.standing import stands
from sescid.planning.feasibility.com import com_state
from sescid.planning.feasibility.compliance import (
    DYNAMIC_FACTOR,
    GENERIC_SAG,
    GENERIC_SINK,
    compliant_margin,
    dynamic_cop,
)


def _fd_jacobian(com_fn, q, nq, eps=1e-6):
    return np.stack(
        [(com_fn(q + eps * np.eye(nq)[j]) - com_fn(q - eps * np.eye(nq)[j])) / (2 * eps)
         for j in range(nq)], axis=2)  # fmt: skip


def test_com_and_jacobian_against_pinocchio_talos():
    """TALOS (URDF, mimic joints): com_state equals Pinocchio's CoM to 1e-12 m and its closed-form
    Jacobian equals central differences of Pinocchio's CoM to 1e-7."""
    from oracle import PinOracle

    robot = sescid.load_robot(erd("talos_data/robots/talos_full_v2.urdf"), "right_sole_link")
    mimic = {
        b.joint_name: (robot.joint_names[b.joint], b.multiplier, b.offset)
        for b in robot.model.bodies
        if b.joint >= 0 and b.joint_name not in robot.joint_names
    }
    pin = PinOracle(robot.model_path, robot.support, robot.joint_names, mimic)
    q = np.random.default_rng(0).uniform(-0.5, 0.5, (4, robot.nq))
    st = com_state(robot, q)
    np.testing.assert_allclose(st.com, pin.com(q), atol=1e-12)
    np.testing.assert_allclose(st.jac, _fd_jacobian(pin.com, q, robot.nq), atol=1e-7)


def test_com_and_jacobian_against_mujoco_humanoid(tmp_path):
    """The synthetic MJCF humanoid: CoM equals MuJoCo's, Jacobian its central differences."""
    from mjcf_gen import mujoco_com

    path = write_humanoid(tmp_path)
    robot = sescid.load_robot(path, "legA_sole")
    q = np.random.default_rng(1).uniform(-0.5, 0.5, (3, robot.nq))

    def com(x):
        return mujoco_com(path, "legA_sole", robot.joint_names, x)

    st = com_state(robot, q)
    np.testing.assert_allclose(st.com, com(q), atol=1e-12)
    np.testing.assert_allclose(st.jac, _fd_jacobian(com, q, robot.nq), atol=1e-7)


def test_dynamic_cop_by_hand_op2_profile(op2):
    """OP2 (profile: kp 320, pads 17 kN/m on the FSR rectangle, backlash 1°): the dynamic CoP
    equals the formulas written out pose by pose; the margin subtracts 2σ of the backlash
    and the edge margin from the pad rectangle."""
    model = design.compliance(op2)
    assert model.kp == 320.0 and model.contact_stiffness == 17_000.0
    np.testing.assert_allclose(model.half, [0.0425, 0.0265])
    q = design.candidates(op2, 50, seed=4).q
    st = com_state(op2, q)
    ref = compliant_cop_by_hand(st.com, st.jac, op2.total_mass * G, 320.0, 17_000.0,
                                model.contacts, 0.0, DYNAMIC_FACTOR)  # fmt: skip
    e = dynamic_cop(model, st)
    np.testing.assert_allclose(e, ref, atol=1e-12)
    jn = np.linalg.norm(st.jac[:, :2], axis=2)
    room = model.half - np.abs(e) - 2 * math.radians(1) / math.sqrt(3) * jn
    np.testing.assert_allclose(compliant_margin(model, st), room.min(axis=1) - 0.003)


def test_generic_defaults_stated_and_applied(tmp_path):
    """Without a profile: the servo stiffness makes the weight at the CoM height sag 0.02 rad,
    the sole's corners sink 0.5 mm under the weight; the source line says so."""
    robot = sescid.load_robot(write_humanoid(tmp_path), "legA_sole")
    model = design.compliance(robot)
    w = robot.total_mass * G
    h = robot.com(np.zeros(robot.nq))[0, 2] - robot.floor
    assert model.kp == pytest.approx(w * h / GENERIC_SAG, rel=1e-12)
    assert model.contact_stiffness == pytest.approx(w / (4 * GENERIC_SINK), rel=1e-12)
    assert "generic" in model.source and "corners" in model.source
    np.testing.assert_allclose(model.half, [0.1, 0.045])  # the 0.2 x 0.09 m foot box


def test_margin_against_the_mujoco_bench(op2):
    """Of box-stable OP2 candidates (the paper's ±23 mm), the 8 the compliant margin keeps
    closest to its edge all stand on the MuJoCo bench; of the 8 it rejects most, most topple."""
    q = design.candidates(op2, 600, seed=5).q
    margin = compliant_margin(design.compliance(op2), com_state(op2, q))
    kept = np.flatnonzero(margin > 0)
    close = kept[np.argsort(margin[kept])[:8]]
    worst = np.argsort(margin)[:8]
    res = stands(op2, q[np.r_[close, worst]])
    assert res.mask[:8].all(), res.reasons
    assert (~res.mask[8:]).sum() >= 5


def test_margin_against_the_mujoco_bench_humanoid(tmp_path):
    """The synthetic humanoid (generic stiffness defaults): planned poses stand on the bench."""
    robot = sescid.load_robot(write_humanoid(tmp_path), "legA_sole")
    plan = sescid.plan_poses(robot, count=22, n_candidates=200, n_test=50, seed=2)
    margin = compliant_margin(plan.compliance, com_state(robot, plan.q))
    assert np.all(margin > 0)
    res = stands(robot, plan.q[np.argsort(margin)[:8]])  # the 8 nearest the edge
    assert res.mask.all(), res.reasons
