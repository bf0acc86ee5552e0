"""Batched kinematics against Pinocchio (an independent implementation) and closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from oracle import PinOracle
from urdf_gen import random_urdf

import sescid
from sescid import kinematics
from sescid.kinematics._kernels import trig as ktrig


@pytest.mark.parametrize("support", ["r_sole", "l_sole", "MP_BODY", "MP_HEAD", "MP_ARM_LOW_L"])
def test_op2_com_matches_pinocchio(support, rng):
    robot = sescid.load_robot("op2", support)
    q = rng.uniform(-np.pi, np.pi, (100, robot.nq))
    oracle = PinOracle(robot.model_path, support, robot.joint_names)
    np.testing.assert_allclose(robot.com(q), oracle.com(q), rtol=0, atol=1e-12)


def test_public_humanoid_com_matches_pinocchio(icub_path, rng):
    robot = sescid.load_robot(icub_path, support="r_sole")
    assert robot.nq == 32 and robot.total_mass > 20
    q = rng.uniform(-1.5, 1.5, (60, robot.nq))
    oracle = PinOracle(icub_path, "r_sole", robot.joint_names)
    assert robot.total_mass == pytest.approx(oracle.total_mass(), rel=1e-12)
    np.testing.assert_allclose(robot.com(q), oracle.com(q), rtol=0, atol=1e-12)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31 - 1), n_links=st.integers(2, 16))
def test_random_trees_match_pinocchio(tmp_path_factory, seed, n_links):
    rng = np.random.default_rng(seed)
    text, links, _ = random_urdf(rng, n_links=n_links)
    path = tmp_path_factory.mktemp("tree") / "tree.urdf"
    path.write_text(text)
    support = links[int(rng.integers(0, n_links))]
    try:
        robot = sescid.load_robot(path, support=support)
    except sescid.SescidError as exc:  # only a tree with no mass at all is refused
        assert "no mass" in str(exc)
        return
    q = rng.uniform(-np.pi, np.pi, (20, robot.nq))
    oracle = PinOracle(path, support, robot.joint_names)
    np.testing.assert_allclose(robot.com(q), oracle.com(q), rtol=0, atol=1e-12)


def test_link_poses_match_pinocchio(op2, rng):
    import pinocchio as pin

    q = rng.uniform(-1, 1, (10, op2.nq))
    oracle = PinOracle(op2.model_path, "r_sole", op2.joint_names)
    rot, pos = op2.link_poses(q, "l_sole")
    fr, fl = oracle.model.getFrameId("r_sole"), oracle.model.getFrameId("l_sole")
    for k in range(len(q)):
        pin.framesForwardKinematics(oracle.model, oracle.data, oracle.q_pin(q[k]))
        rel = oracle.data.oMf[fr].inverse() * oracle.data.oMf[fl]
        np.testing.assert_allclose(rot[k], rel.rotation, atol=1e-13)
        np.testing.assert_allclose(pos[k], rel.translation, atol=1e-13)


def test_forward_rotations_are_orthonormal_and_origins_chain(op2, rng):
    q = rng.uniform(-3, 3, (2500, op2.nq))  # > one block of the compiled chain
    rot, org = op2.forward(q)
    assert rot.shape == (2500, 21, 3, 3) and org.shape == (2500, 21, 3)
    eye = np.einsum("nbij,nbkj->nbik", rot, rot)
    np.testing.assert_allclose(eye, np.broadcast_to(np.eye(3), eye.shape), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(rot), 1.0, atol=1e-14)
    for b, body in enumerate(op2.model.bodies[1:], start=1):  # o_b = o_p + R_p t_b
        expect = org[:, body.parent] + rot[:, body.parent] @ body.trans_const
        np.testing.assert_allclose(org[:, b], expect, atol=1e-15)


def _one_joint_tree() -> kinematics.Tree:
    """A bare one-joint tree, to drive ``joint_trig`` directly."""
    return kinematics.Tree(
        parent=np.array([-1, 0]), jcol=np.array([-1, 0]), coef=np.ones(2), off=np.zeros(2),
        a0=np.zeros((2, 3, 3)), a1=np.zeros((2, 3, 3)), a2=np.zeros((2, 3, 3)),
        t=np.zeros((2, 3)), root_r=np.eye(3), root_o=np.zeros(3), nq=1,
        nz_ptr=np.zeros(3, dtype=np.int64), nz_k=np.zeros(0, dtype=np.int64),
        nz_j=np.zeros(0, dtype=np.int64), nz_a=np.zeros((0, 3)), axis=np.eye(3)[[0, 2]],
    )  # fmt: skip


def test_in_kernel_sincos_is_accurate():
    x = np.concatenate([np.linspace(-7, 7, 20001), [0, 1e-9, -1e-9, np.pi / 4, np.pi, 1e4]])
    tree = _one_joint_tree()
    s = np.empty((2, x.size))
    c1 = np.empty((2, x.size))
    ktrig.joint_trig(x[None, :], tree.jcol, tree.coef, tree.off, s, c1)
    np.testing.assert_allclose(s[1], np.sin(x), rtol=0, atol=4.5e-16)
    exact_c1 = 2 * np.sin(x / 2) ** 2  # 1 − cos x without cancellation
    np.testing.assert_allclose(c1[1], exact_c1, rtol=1e-14, atol=4.5e-16)


def test_small_angle_trig_gives_the_reduced_paths_bits(rng):
    """Blocks whose angles all lie within ±SMALL_ANGLE skip the reduction: the same bits."""
    tree = _one_joint_tree()
    lim = np.nextafter(kinematics.SMALL_ANGLE, 0)
    x = np.concatenate([rng.uniform(-lim, lim, 4000), [0.0, -0.0, lim, -lim, 1e-300]])
    fast = np.empty((2, x.size)), np.empty((2, x.size))
    ktrig.joint_trig(x[None, :], tree.jcol, tree.coef, tree.off, *fast)
    with_big = np.append(x, 3.0)  # one large angle: the whole block takes the reduction
    full = np.empty((2, with_big.size)), np.empty((2, with_big.size))
    ktrig.joint_trig(with_big[None, :], tree.jcol, tree.coef, tree.off, *full)
    assert np.array_equal(fast[0][1], full[0][1, :-1]) and np.array_equal(
        fast[1][1], full[1][1, :-1]
    )


def test_huge_angles_use_exact_reduction(op2, rng):
    q = rng.uniform(-1, 1, (5, op2.nq))
    big = q + 2 * np.pi * 1e6  # same pose, angles beyond the kernel's reduction range
    np.testing.assert_allclose(op2.com(big), op2.com(q), atol=1e-9)


def test_regressor_times_sesc_vectors_is_the_com(op2, rng):
    q = rng.uniform(-1, 1, (50, op2.nq))
    phi = op2.regressor(q, rows=(0, 1, 2))
    assert phi.shape == (50, 3, 63)
    np.testing.assert_allclose(phi @ op2.sesc_vectors().ravel() + op2.d, op2.com(q), atol=1e-15)
    np.testing.assert_allclose(op2.regressor(q, rows=(2,))[:, 0], phi[:, 2], atol=0)


def test_reduced_coordinates_reproduce_the_regressor(op2, rng):
    q = rng.uniform(-2, 2, (300, op2.nq))
    red = op2.reduction
    assert red.g.shape == (42, 63)
    x = kinematics.reduced_columns(op2.tree, red, q)  # (42, 2n), columns (row, pose)
    phi = op2.regressor(q).transpose(1, 0, 2).reshape(600, 63)  # rows (row, pose)
    r = rng.normal(size=63)
    np.testing.assert_allclose(x.T @ (red.g @ r), phi @ r, atol=1e-14)


def test_poses_are_validated(op2):
    with pytest.raises(sescid.SescidError, match=r"expected shape \(n, 20\)"):
        op2.com(np.zeros((3, 19)))
    bad = np.zeros((2, 20))
    bad[1, 4] = np.nan
    with pytest.raises(sescid.SescidError, match="pose 1, joint 4"):
        op2.cop(bad)


@pytest.mark.parametrize("weighted", [False, True])
@pytest.mark.parametrize("rows", [(0, 1), (0, 1, 2), (2,)])
def test_fused_normal_equations_equal_the_columns_product(op2, rng, rows, weighted):
    """One compiled pass (chain rows, reduced columns, symmetric product of the augmented
    columns [Φ_red, y]) = Φ_redᵀWΦ_red, Φ_redᵀWy, yᵀWy by BLAS, in any process."""
    n = 3 * kinematics.GRAM_BLOCK + 17  # several blocks and a partial one
    q = rng.uniform(-2, 2, (n, op2.nq))
    y = rng.normal(0, 0.05, (n, len(rows)))
    sw = rng.uniform(0.5, 2.0, (n, len(rows))) if weighted else None
    red = kinematics.reduction(op2.tree, np.array([b.axis for b in op2.model.bodies]), rows)
    x = kinematics.reduced_columns(op2.tree, red, q)  # (p, len(rows)·n), columns (row, pose)
    yv = y.T.reshape(-1)
    if weighted:
        x, yv = x * sw.T.reshape(-1), yv * sw.T.reshape(-1)
    sums = kinematics.gram_reduced(op2.tree, red, q, y, sw)  # runs whenever called
    assert sums is not None
    ata, atb, yty = sums
    np.testing.assert_allclose(ata, x @ x.T, rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(atb, x @ yv, rtol=1e-13, atol=1e-14)
    assert yty == pytest.approx(yv @ yv, rel=1e-14)
    assert kinematics.gram_reduced(op2.tree, red, q + 1e6, y, sw) is None  # huge: numpy's


@pytest.mark.parametrize("kernels", [True, False])
def test_symmetric_product_matches_blas_for_any_width(rng, kernels):
    """``gram_columns`` (compiled 4 × 4 tiles of 8-lane FMA sums, or numpy column by column)
    = X Xᵀ on and above the diagonal, for any number of rows and columns."""
    for p, m in [(1, 1), (5, 3), (42, 512), (63, 1000), (9, 17)]:
        x = rng.normal(size=(p, m))
        out = kinematics.gram_columns(x, kernels)
        assert out.shape == (kinematics.padded(p),) * 2
        np.testing.assert_allclose(np.triu(out[:p, :p]), np.triu(x @ x.T), rtol=1e-12, atol=1e-12)


def test_compiled_cop_equals_the_full_chain(op2, rng):
    """The CoP over rows 0, 1 only gives the same bits as the 3-row CoM in numpy and compiled,
    agrees with the chain, and refuses (or hands to numpy) angles beyond the kernel's range."""
    q = rng.uniform(-3, 3, (2 * kinematics.CHAIN_BLOCK + 5, op2.nq))
    r = op2.sesc_vectors()
    fast = kinematics.cop_xy(op2.tree, q, r)
    com = kinematics.com_rows(op2.tree, q, r, 3)
    assert np.array_equal(fast, com[:, :2])
    rot = kinematics.chain(op2.tree, q, None, False)
    assert np.array_equal(kinematics.com_sum(rot, r, op2.tree.root_o, 3).T, com)
    np.testing.assert_allclose(fast, op2.com(q)[:, :2], rtol=0, atol=1e-15)
    with pytest.raises(sescid.SescidError, match="beyond"):
        kinematics.cop_xy(op2.tree, q + 1e6, r)
    np.testing.assert_allclose(kinematics.com_rows(op2.tree, q + 2e6 * np.pi, r), fast, atol=1e-9)


def test_nan_hidden_in_a_finite_looking_sum_is_found(op2):
    """Validation: angles whose sum overflows are checked one by one, a nan is still named."""
    q = np.zeros((3, op2.nq))
    q[0, 0], q[0, 1] = 1e308, 1e308  # the sum overflows to inf: every angle is finite
    assert kinematics.as_poses(q, op2.nq).shape == (3, op2.nq)
    q[2, 7] = np.nan
    with pytest.raises(sescid.SescidError, match="pose 2, joint 7"):
        kinematics.as_poses(q, op2.nq)
