"""The torque rows' normal equations in the fused pass against the explicit rows (numpy), against
Pinocchio's holding torques, and the shared CoP pass against the CoP's own."""

from __future__ import annotations

import re

import numpy as np
import pytest
from oracle import PinStatics
from urdf_gen import random_urdf

import sescid
from sescid.estimation.data.measurements import Measurements
from sescid.estimation.data.torque_rows import torque_columns
from sescid.kinematics import TorqueBlock, gram_fused, gram_reduced, torque_plan

G0 = 9.81


def _explicit(robot, m, mass, weighted):
    """ΦᵀWΦ, ΦᵀWy, yᵀWy of the explicit torque columns (``torque_columns``), by BLAS."""
    x, y, sw = torque_columns(robot, m, mass, weighted, G0)
    if sw is not None:
        x, y = x * sw, y * sw
    return x @ x.T, x @ y, float(y @ y)


def _fused(robot, m, mass, weighted, cop=None):
    plan = torque_plan(robot.tree, robot.joint_columns(m.tau_joints), m.approach is not None, 2)
    assert plan is not None
    rows = TorqueBlock(m.tau, 1.0 / m.tau_se if weighted else None, m.approach, mass * G0)
    out = gram_fused(robot.tree, robot.reduction, plan, m.q, rows, cop)
    assert out is not None
    return out


def _close(a, b, rel):
    for x, y in zip(a, b, strict=True):
        scale = np.abs(y).max()
        assert np.abs(np.asarray(x) - y).max() <= rel * scale, (np.abs(x - y).max(), scale)


@pytest.mark.parametrize("weighted", [False, True])
@pytest.mark.parametrize("friction", [False, True])
@pytest.mark.parametrize("joints", ["all", "some"])
def test_fused_torque_sums_equal_the_explicit_rows(op2, rng, weighted, friction, joints):
    """OP2 (several sub-blocks and a partial one), all 20 joints or a subset, weighted or not,
    with friction columns or not: the fused pass = the explicit rows' product to ~1e-15."""
    n = 300
    names = tuple(op2.joint_names) if joints == "all" else tuple(op2.joint_names[3:17:2])
    m = Measurements(
        q=rng.uniform(-1.5, 1.5, (n, op2.nq)),
        tau=rng.normal(0, 1, (n, len(names))),
        tau_joints=names,
        tau_se=rng.uniform(0.02, 0.2, (n, len(names))),
        approach=rng.choice([-1.0, 1.0], n) if friction else None,
    ).checked(op2)
    _, sums = _fused(op2, m, 3.1, weighted)
    _close(sums, _explicit(op2, m, 3.1, weighted), 2e-15)


@pytest.mark.parametrize("seed", range(6))
def test_random_trees_and_supports(tmp_path, seed):
    """Random trees (continuous joints, fixed links, any support: bodies not in depth-first
    order, branching at the support) against the explicit rows."""
    rng = np.random.default_rng(seed)
    text, links, _ = random_urdf(rng, n_links=12)
    path = tmp_path / "tree.urdf"
    path.write_text(text)
    robot = sescid.load_robot(path, links[int(rng.integers(0, len(links)))])
    n = 140
    names = tuple(j for j in robot.joint_names if rng.random() < 0.7) or robot.joint_names[:1]
    m = Measurements(
        q=rng.uniform(-3, 3, (n, robot.nq)),
        tau=rng.normal(0, 1, (n, len(names))),
        tau_joints=tuple(names),
        approach=rng.choice([-1.0, 1.0], n),
    ).checked(robot)
    _, sums = _fused(robot, m, 2.0, False)
    _close(sums, _explicit(robot, m, 2.0, False), 5e-15)


def test_mixed_pass_gives_each_kinds_own_bits(op2, rng):
    """CoP and torques of the same poses in one pass: the CoP's sums are the CoP pass's bits,
    the torques' the torque-only pass's."""
    n = 260
    m = Measurements(
        q=rng.uniform(-1, 1, (n, op2.nq)),
        cop=rng.normal(0, 0.02, (n, 2)),
        cop_se=rng.uniform(0.001, 0.01, (n, 2)),
        tau=rng.normal(0, 1, (n, op2.nq)),
        tau_joints=tuple(op2.joint_names),
    ).checked(op2)
    y = m.cop - op2.d[:2]
    for sw in (None, 1.0 / m.cop_se):
        cop_sums, tau_sums = _fused(op2, m, 2.9, False, (y, sw))
        alone = gram_reduced(op2.tree, op2.reduction, m.q, y, sw)
        _, tau_alone = _fused(op2, m, 2.9, False)
        assert all(np.array_equal(a, b) for a, b in zip(cop_sums, alone, strict=True))
        assert all(np.array_equal(a, b) for a, b in zip(tau_sums, tau_alone, strict=True))


def _with_coms(text: str, rng) -> str:
    """The same tree with every inertial origin moved (new CoMs, same masses)."""

    def move(match):
        xyz = " ".join(f"{v:.17g}" for v in rng.uniform(-0.1, 0.1, 3))
        return f'<inertial>\n      <origin xyz="{xyz}"'

    return re.sub(r'<inertial>\s*<origin xyz="[^"]*"', move, text)


@pytest.mark.parametrize("seed", range(3))
def test_sums_reproduce_pinocchio_torques(tmp_path, seed):
    """For two mass distributions a, b of one tree (r_a, r_b, the same masses) Pinocchio's
    holding torques give Σ τ_a·τ_b = r_aᵀ A r_b, Σ τ_a·y = r_aᵀ b, Σ y·y = yᵀy with y = τ_b:
    the fused sums (expanded to vec(r)) against an independent dynamics library."""
    rng = np.random.default_rng(100 + seed)
    text, links, _ = random_urdf(rng, n_links=9, p_massless=0.0)
    paths = []
    for k, t in enumerate((text, _with_coms(text, rng))):
        paths.append(tmp_path / f"tree{k}.urdf")
        paths[-1].write_text(t)
    support = links[int(rng.integers(0, len(links)))]
    ra, rb = (sescid.load_robot(p, support) for p in paths)
    q = rng.uniform(-2, 2, (150, ra.nq))
    tau = [PinStatics(p, support, ra.joint_names, G0).torques(q) for p in paths]
    m = Measurements(q=q, tau=tau[1], tau_joints=tuple(ra.joint_names)).checked(ra)
    _, (ata, atb, yty) = _fused(ra, m, ra.total_mass, False)
    g = ra.reduction.g
    a_full, b_full = g.T @ ata[: -ra.nq, : -ra.nq] @ g, g.T @ atb[: -ra.nq]
    va, vb = ra.sesc_vectors().reshape(-1), rb.sesc_vectors().reshape(-1)
    ref = float(np.sum(tau[0] * tau[1]))
    assert va @ a_full @ vb == pytest.approx(ref, rel=1e-12)
    assert va @ b_full == pytest.approx(ref, rel=1e-12)
    assert yty == pytest.approx(float(np.sum(tau[1] ** 2)), rel=1e-13)


def test_a_measured_mimic_joint_has_no_plan(tmp_path):
    """A measured joint that drives several bodies is no nested subtree row: no fused plan (the
    accumulator takes the explicit rows)."""
    for seed in range(40):
        rng = np.random.default_rng(seed)
        text, links, mimic = random_urdf(rng, n_links=10, mimic=True)
        if mimic:
            break
    path = tmp_path / "mimic.urdf"
    path.write_text(text)
    robot = sescid.load_robot(path, links[0])
    master = next(iter(mimic.values()))[0]
    assert torque_plan(robot.tree, robot.joint_columns([master]), False, 2) is None


@pytest.mark.parametrize("tilted", [False, True])
def test_holding_torques_numpy_and_compiled_are_the_same_bits(op2, rng, tilted):
    """``torque_values`` in numpy and on the kernels: the same bits (so its path, a question of
    speed, cannot change a result); and M Φ_τ r from the regressor rows to ~1e-15."""
    from sescid.kinematics import load_kernels
    from sescid.kinematics._kernels import torque_values as tv

    n = 1500
    q = rng.uniform(-3, 3, (n, op2.nq))
    g = np.tile([0.0, 0.0, -G0], (n, 1))
    if tilted:
        g = g + rng.normal(0, 1.0, (n, 3))
    cols = np.arange(op2.nq)[::-1]
    r = op2.sesc_vectors()
    load_kernels()
    fast = tv.torque_values(op2.tree, q, r, 2.5, cols, g)
    rot = sescid.kinematics.chain(op2.tree, q, None, False)
    slow = tv.torques_numpy(rot, op2.tree, tv.joint_bodies_padded(op2.tree, cols), r, g, 2.5)
    assert np.array_equal(fast, slow)
    rows = tv.torque_rows(op2.tree, q, cols, g)
    np.testing.assert_allclose(2.5 * rows @ r.reshape(-1), fast, rtol=0, atol=1e-13)
