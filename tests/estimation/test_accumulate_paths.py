"""The accumulator's paths: the job's size alone picks numpy or the kernels, a file streamed in
chunks gives the same bits as its arrays in memory on both, and every path agrees with the
explicit rows' product (BLAS) to rounding."""

from __future__ import annotations

import numpy as np
import pytest

import sescid
from sescid.estimation.data.measurements import Measurements
from sescid.estimation.data.torque_rows import torque_columns
from sescid.estimation.sums.block_sums import work
from sescid.estimation.sums.system import Accumulator, RowOptions
from sescid.kinematics import NUMPY_JOB


def _data(robot, n, seed, kinds=("cop", "tau"), approach=True, weighted=True):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1.2, 1.2, (n, robot.nq))
    names = tuple(robot.joint_names[::2])
    return Measurements(
        q=q,
        cop=rng.normal(0, 0.02, (n, 2)) if "cop" in kinds else None,
        cop_se=rng.uniform(0.002, 0.01, (n, 2)) if ("cop" in kinds and weighted) else None,
        tau=rng.normal(0, 1, (n, len(names))) if "tau" in kinds else None,
        tau_joints=names if "tau" in kinds else (),
        tau_se=rng.uniform(0.02, 0.1, (n, len(names))) if ("tau" in kinds and weighted) else None,
        approach=rng.choice([-1.0, 1.0], n) if ("tau" in kinds and approach) else None,
    ).checked(robot)


def _system(robot, chunks, weighted=True):
    acc = Accumulator(robot, RowOptions(weighted=weighted, total_mass=3.0))
    for c in chunks:
        acc.add(c)
    return acc


def _same_bits(a, b):
    assert a.kinds == b.kinds and a.nuisance == b.nuisance
    for k in a.kinds:
        x, y = a.parts[k].ne, b.parts[k].ne
        assert np.array_equal(x.ata, y.ata) and np.array_equal(x.atb, y.atb)
        assert x.yty == y.yty and x.n_rows == y.n_rows and x.n_poses == y.n_poses


@pytest.mark.parametrize("kinds", [("cop",), ("tau",), ("cop", "tau")])
def test_streamed_equals_in_memory_on_the_compiled_path(op2, kinds):
    """A source large enough for the kernels, fed in odd chunks or at once: the same bits."""
    probe = _data(op2, 1, 0, kinds)
    n = NUMPY_JOB // work(op2, probe, 1) + 2500  # past the numpy budget, several blocks
    m = _data(op2, n, 1, kinds)
    whole = _system(op2, [m])
    assert whole.maker is not None and whole.maker.kernels  # decided before the end
    cuts = [0, 777, 3000, 3001, n // 2, n]
    parts = _system(op2, [m.take(slice(a, b)) for a, b in zip(cuts[:-1], cuts[1:], strict=True)])
    _same_bits(whole.finish(), parts.finish())


def test_a_small_source_stays_in_numpy_whatever_was_loaded(op2):
    """Below the budget the path is numpy even with the kernels loaded (the job decides), and
    streamed equals in memory there too."""
    sescid.kinematics.load_kernels()
    m = _data(op2, 300, 2)
    acc = _system(op2, [m])
    assert acc.maker is None  # waiting: the job may still grow
    whole = acc.finish()
    assert acc.maker is not None and not acc.maker.kernels
    parts = _system(op2, [m.take(slice(0, 7)), m.take(slice(7, 300))]).finish()
    _same_bits(whole, parts)


@pytest.mark.parametrize("kernels", [False, True])
def test_every_path_equals_the_explicit_rows(op2, kernels):
    """Weighted CoP and torques with friction columns, small (numpy) or large (compiled): the
    reduced sums equal the explicit rows' product by BLAS to rounding."""
    from sescid.estimation.sums.block_sums import RowMaker
    from sescid.kinematics import fold_torque, reduced_order

    m = _data(op2, 600, 3)
    maker = RowMaker(op2, kernels, True, 3.0, 9.80665, m.tau_joints, True)
    sums = maker.sums(m)
    p = op2.reduction.g.shape[0]
    if kernels:  # the compiled passes' raw accumulators
        assert sums.tau_red is None and sums.cop_red is None
        tau = fold_torque(sums.tau_raw, maker.plan, p)
        cop = reduced_order(sums.cop_raw, op2.tree, 2, p)
    else:
        tau = sums.tau_red.ata, sums.tau_red.atb, sums.tau_red.yty
        cop = sums.cop_red.ata, sums.cop_red.atb, sums.cop_red.yty
    x, y, sw = torque_columns(op2, m, 3.0, True, 9.80665)
    x, y = x * sw, y * sw
    scale = np.abs(x @ x.T).max()
    assert np.abs(tau[0] - x @ x.T).max() <= 1e-14 * scale
    assert np.abs(tau[1] - x @ y).max() <= 1e-14 * np.abs(x @ y).max()
    assert tau[2] == pytest.approx(y @ y, rel=1e-14)
    xc = sescid.kinematics.reduced_columns(op2.tree, op2.reduction, m.q) * (1 / m.cop_se).T.reshape(
        -1
    )
    yc = ((m.cop - op2.d[:2]) / m.cop_se).T.reshape(-1)
    assert np.abs(cop[0] - xc @ xc.T).max() <= 1e-13 * np.abs(xc @ xc.T).max()
    assert np.abs(cop[1] - xc @ yc).max() <= 1e-13 * np.abs(xc @ yc).max()


def test_the_paths_agree_on_a_fit(op2):
    """The same data below and above the budget (a copy of the poses, so the job is large):
    numpy's and the kernels' fits agree to rounding."""
    m = _data(op2, 2000, 4, kinds=("cop",), weighted=False)
    small = sescid.identify(op2, m, method="ls")
    k = NUMPY_JOB // work(op2, m, 1) // m.n + 1
    big = Measurements(q=np.tile(m.q, (k, 1)), cop=np.tile(m.cop, (k, 1))).checked(op2)
    large = sescid.identify(op2, big, method="ls")
    np.testing.assert_allclose(large.r, small.r, rtol=0, atol=1e-12)
    assert large.rms == pytest.approx(small.rms, rel=1e-10)


def test_residual_pass_kernel_equals_numpy_and_streams(op2):
    """The compiled residual sums (a large fit) equal numpy's to rounding, the true-error too,
    and a source streamed in odd chunks gives the MAE's and RMS's bits of the arrays."""
    from sescid.estimation.sums.residual_sums import block_sums
    from sescid.simulation import simulate

    sim = simulate(op2, 30_000, seed=5)
    m = Measurements(q=sim.q, cop=sim.cop, cop_true=sim.cop_true).checked(op2)
    fit = sescid.identify(op2, m, method="ls")
    fast = block_sums(fit, m, True)
    slow = block_sums(fit, m, False)
    for a, b in zip(fast, slow, strict=True):
        assert a[0] == b[0] and a[3] == b[3]
        assert a[1] == pytest.approx(b[1], rel=1e-12) and a[2] == pytest.approx(b[2], rel=1e-12)
    cuts = [0, 1001, 9000, 17777, 30_000]
    chunks = (m.take(slice(a, b)) for a, b in zip(cuts[:-1], cuts[1:], strict=True))
    streamed = sescid.identify(op2, chunks, method="ls")
    assert (streamed.mae, streamed.rms, streamed.truth_cop_rmse) == (
        fit.mae,
        fit.rms,
        fit.truth_cop_rmse,
    )


def test_torque_residual_pass_kernel_equals_numpy(op2):
    """The compiled torque residual sums (offsets, friction sides) equal numpy's to rounding."""
    from sescid.estimation.sums.residual_sums import block_sums

    m = _data(op2, 3000, 6, kinds=("tau",), approach=True, weighted=False)
    fit = sescid.identify(op2, m, total_mass=3.0, method="ls")
    fast, slow = block_sums(fit, m, True), block_sums(fit, m, False)
    assert fast[0][3] == slow[0][3] == m.tau.size
    assert fast[0][1] == pytest.approx(slow[0][1], rel=1e-12)
    assert fast[0][2] == pytest.approx(slow[0][2], rel=1e-12)


@pytest.mark.parametrize("n", [300, 12_000])
def test_accumulate_is_the_accumulators_cop_sums(op2, n):
    """``accumulate`` (CoP arrays: planning, the online estimator) gives the bits of the
    accumulator ``identify`` uses, and CoP chunks give the bits of their arrays in memory, on
    the numpy path (300 poses) and the compiled one; its sums equal the explicit rows' to
    rounding."""
    from sescid.estimation import accumulate

    m = _data(op2, n, 7, kinds=("cop",), weighted=False)
    whole = accumulate(op2, [(m.q, m.cop)])
    cut = n // 3 + 5
    parts = accumulate(op2, [(m.q[:cut], m.cop[:cut]), (m.q[cut:], m.cop[cut:])])
    ref = _system(op2, [m], weighted=False).finish().parts["cop"].ne
    for ne in (whole, parts):
        assert np.array_equal(ne.ata, ref.ata) and np.array_equal(ne.atb, ref.atb)
        assert (ne.yty, ne.n_rows, ne.n_poses) == (ref.yty, ref.n_rows, ref.n_poses) == (
            ref.yty, 2 * n, n,
        )  # fmt: skip
    phi = op2.regressor(m.q, (0, 1)).reshape(-1, 3 * len(op2.body_names))
    y = (m.cop - op2.d[:2]).reshape(-1)
    np.testing.assert_allclose(
        whole.ata, phi.T @ phi, rtol=0, atol=1e-12 * np.abs(phi.T @ phi).max()
    )
    np.testing.assert_allclose(whole.atb, phi.T @ y, rtol=0, atol=1e-12 * np.abs(phi.T @ y).max())
