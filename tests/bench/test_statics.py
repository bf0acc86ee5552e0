"""Holding torques of rigid statics against Pinocchio: a fixed base (gantry) and single support."""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest
from oracle import PinOracle

import sescid
from sescid.bench import ExternalForce, holding_torques

G = 9.80665


def pin_fixed_base_gravity(urdf, joint_names, q):
    """(n, nq) ``computeGeneralizedGravity`` of a fixed-base model (the URDF root held level)."""
    model = pin.buildModelFromUrdf(str(urdf))
    model.gravity.linear[:] = [0.0, 0.0, -G]
    data = model.createData()
    cols = {name: i for i, name in enumerate(joint_names)}
    out = np.zeros((len(q), len(joint_names)))
    for k, qk in enumerate(q):
        qp = pin.neutral(model)
        for jid in range(1, model.njoints):
            jm = model.joints[jid]
            if jm.nq == 1:
                qp[jm.idx_q] = qk[cols[model.names[jid]]]
            else:  # continuous joint: (cos, sin)
                a = qk[cols[model.names[jid]]]
                qp[jm.idx_q : jm.idx_q + 2] = np.cos(a), np.sin(a)
        g = pin.computeGeneralizedGravity(model, data, qp)
        for jid in range(1, model.njoints):
            out[k, cols[model.names[jid]]] = g[model.joints[jid].idx_v]
    return out


def pin_support_gravity(urdf, support, joint_names, q):
    """(n, nq) joint torques with the link ``support`` held level: a free-flyer model placed so
    that the support frame is the world frame, g(q) minus the support wrench's share
    (``τ = g_a − J_aᵀ w`` with ``J_bᵀ w = g_b``, theory.md)."""
    o = PinOracle(urdf, support, joint_names)
    m, d = o.model, o.data
    m.gravity.linear[:] = [0.0, 0.0, -G]
    out = np.zeros((len(q), len(joint_names)))
    for k, qk in enumerate(q):
        qp = o.q_pin(qk)
        pin.framesForwardKinematics(m, d, qp)
        base = d.oMf[o.frame].inverse() * pin.XYZQUATToSE3(qp[:7])
        qp[:7] = pin.SE3ToXYZQUAT(base)
        pin.framesForwardKinematics(m, d, qp)
        assert np.allclose(d.oMf[o.frame].homogeneous, np.eye(4), atol=1e-12)
        g = pin.computeGeneralizedGravity(m, d, qp)
        jac = pin.computeFrameJacobian(m, d, qp, o.frame, pin.LOCAL)
        w = np.linalg.solve(jac[:, :6].T, g[:6])
        tau = g[6:] - jac[:, 6:].T @ w
        for jid in range(2, m.njoints):
            out[k, o.cols[m.names[jid]]] = tau[m.joints[jid].idx_v - 6]
    return out


def _poses(robot, n, seed):
    rng = np.random.default_rng(seed)
    lim = robot.joint_limits
    lo, hi = np.maximum(lim[:, 0], -0.6), np.minimum(lim[:, 1], 0.6)
    return rng.uniform(lo, hi, (n, robot.nq))


def test_gantry_torques_are_pinocchio_fixed_base_gravity(op2):
    """OP2 held by its torso (the URDF root): τ = computeGeneralizedGravity of a fixed base."""
    robot = sescid.load_robot("op2", "MP_BODY")
    q = _poses(robot, 6, 0)
    ref = pin_fixed_base_gravity(robot.model_path, robot.joint_names, q)
    tau = holding_torques(robot, q)
    assert np.abs(ref).max() > 0.3  # N·m: the arms and legs hang off the torso
    np.testing.assert_allclose(tau, ref, atol=1e-12)


@pytest.mark.parametrize("robot_name, support", [("op2", "r_sole"), ("icub", "r_sole")])
def test_single_support_torques_are_pinocchio_with_the_foot_held(robot_name, support, icub_path):
    """Standing on one foot: the torques equal Pinocchio's g(q) with the support wrench
    removed, on the OP2 and on iCub (a public URDF humanoid)."""
    robot = sescid.load_robot(icub_path if robot_name == "icub" else "op2", support)
    q = _poses(robot, 4, 1)
    ref = pin_support_gravity(robot.model_path, support, robot.joint_names, q)
    tau = holding_torques(robot, q)
    scale = np.abs(ref).max()
    assert scale > 0.5
    np.testing.assert_allclose(tau, ref, atol=1e-11 * max(scale, 1.0))


def test_torques_follow_the_bodies_given_and_gravity(op2):
    """A point mass added beyond a joint adds its moment; tilted gravity rotates the load."""
    q = _poses(op2, 3, 2)
    bodies = list(op2.model.bodies)
    i = op2.body_names.index("MP_ARM_LOW_L")
    b = bodies[i]
    extra = 0.1
    bodies[i] = dataclasses.replace(b, mass=b.mass + extra, com=(b.mass * b.com) / (b.mass + extra))
    d = holding_torques(op2, q, bodies) - holding_torques(op2, q)
    # the 0.1 kg at the body origin: − axis · ((p − p_j) × m g) for the joints on its chain
    rot, org = op2.forward(q)
    j = op2.joint_names.index("l_el")
    bj = next(k for k, bb in enumerate(op2.model.bodies) if bb.joint == j)
    axis = np.einsum("nij,j->ni", rot[:, bj], op2.model.bodies[bj].axis)
    lever = org[:, i] - org[:, bj]
    expect = -np.einsum("ni,ni->n", axis, np.cross(lever, [0, 0, -extra * G]))
    expect *= op2.model.bodies[bj].sign
    np.testing.assert_allclose(d[:, j], expect, atol=1e-13)
    assert np.all(d[:, op2.joint_names.index("r_el")] == 0)  # the other arm: nothing
    # gravity along −z of the support frame is the level default
    level = np.tile([0.0, 0.0, -1.0], (3, 1))
    np.testing.assert_array_equal(holding_torques(op2, q, gravity=level), holding_torques(op2, q))


def test_an_external_force_balancing_a_body_cancels_its_torques(op2):
    """Pushing up on a lifted foot's CoM with its subtree's weight unloads the joints below it
    (the floor under the other foot in double support)."""
    q = _poses(op2, 3, 3)
    rot, org = op2.forward(q)
    i = op2.body_names.index("MP_ANKLE2_L")  # the lifted foot: a leaf body
    b = op2.model.bodies[i]
    c = org[:, i] + np.einsum("nij,j->ni", rot[:, i], b.com)
    push = ExternalForce(i, c, np.tile([0.0, 0.0, b.mass * G], (3, 1)))
    with_push = holding_torques(op2, q, external=(push,))
    bodies = list(op2.model.bodies)
    bodies[i] = dataclasses.replace(b, mass=0.0)
    np.testing.assert_allclose(with_push, holding_torques(op2, q, bodies), atol=1e-13)


def test_the_bench_truth_is_linear_in_the_real_robots_sesc_vectors(op2):
    """The contract with the estimation: the bench's true torques (from its bodies) are
    ``M · Φ_τ(q) · vec(r_true)`` of ``sesc.torques`` for the real robot, tilted gravity too."""
    from sescid.bench import ExperimentConfig, real_bodies, real_robot
    from sescid.sesc import torques

    cfg = ExperimentConfig()
    bodies, _ = real_bodies(op2, cfg)
    r_true, mass, _ = real_robot(op2, cfg)
    q = _poses(op2, 5, 4)
    g = np.random.default_rng(4).normal([0.0, 0.0, -1.0], 0.05, (5, 3))
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    ours = holding_torques(op2, q, bodies, g)
    np.testing.assert_allclose(ours, torques(op2.tree, q, r_true, mass, gravity=g), atol=1e-12)
