"""The fast candidate path (coarse CoP pre-check, broad-phase self-collision) gives exactly the
poses of the plain checks, and the single-pose CoM path agrees with the batch path."""

from __future__ import annotations

import numpy as np
import pytest

from sescid import kinematics
from sescid import planning as design
from sescid.errors import DataError
from sescid.planning.feasibility.collision import collision_capsules, collision_free_mask
from sescid.planning.feasibility.ground import ground_clear
from sescid.planning.feasibility.stability import (
    DEFAULT_CLEARANCE,
    coarse_cop_tree,
    stable_mask,
    stable_subset,
)


def test_coarse_bound_covers_the_light_bodies(op2):
    """|coarse CoP − CoP| stays within the coarse tree's bound on random poses."""
    tree, r, bound = coarse_cop_tree(op2)
    lim = design.sampling_limits(op2)
    q = lim[:, 0] + (lim[:, 1] - lim[:, 0]) * np.random.default_rng(3).random((10_000, op2.nq))
    gap = np.abs(kinematics.cop_xy(tree, q, r) - op2.cop(q)).max()
    assert 0.2 * bound < gap < bound  # a real bound, not a vacuous one


def test_stable_subset_equals_stable_mask(op2):
    """Same mask and the same CoP bits as stable_mask, including poses at the box edge."""
    lim = design.sampling_limits(op2)
    q = lim[:, 0] + (lim[:, 1] - lim[:, 0]) * np.random.default_rng(4).random((30_000, op2.nq))
    half = design.cop_half_extents(op2)
    cop = op2.cop(q)
    near = np.argsort(np.abs(np.abs(cop[:, 0]) - half[0]))[:50]  # closest to the edge
    half_edge = np.array([abs(cop[near[0], 0]), half[1]])  # one pose exactly on the edge
    for h in (half, half_edge):
        ref, ref_cop = stable_mask(op2, q, h)
        mask, kept = stable_subset(op2, q, h)
        assert np.array_equal(mask, ref) and mask.sum() > 100
        assert np.array_equal(kept, ref_cop[ref])


def test_uniform_candidates_equal_the_plain_checks(op2):
    """candidates(op2, …) keeps exactly the draws that stable_mask, the ground check and the
    narrow-phase collision mask keep, in draw order."""
    n, seed = 400, 7
    cand = design.candidates(op2, n, seed)
    lim = design.sampling_limits(op2)
    q = lim[:, 0] + (lim[:, 1] - lim[:, 0]) * np.random.default_rng(seed).random((100_000, op2.nq))
    ok, cop = stable_mask(op2, q, design.cop_half_extents(op2))
    q, cop = q[ok], cop[ok]
    cap = collision_capsules(op2)
    rot, org = op2.forward(q)
    g = ground_clear(op2, cap, rot, org, DEFAULT_CLEARANCE)
    f = collision_free_mask(cap, rot[g], org[g])
    assert cand.n_sampled == 100_000 and cand.n_free == f.sum() > n
    assert np.array_equal(cand.q, q[g][f][:n]) and np.array_equal(cand.cop, cop[g][f][:n])


def test_single_pose_com_equals_the_batch(op2):
    """robot.com / robot.cop on one pose equal the blocked batch path; bad input still raises."""
    q = np.random.default_rng(5).uniform(-1, 1, (3, op2.nq))
    op2.com(q[0])  # loads the kernels
    batch = op2.com(q)
    for k in range(3):
        one = op2.com(q[k])
        assert one.shape == (1, 3) and np.allclose(one[0], batch[k], atol=1e-15)
        assert np.array_equal(op2.cop(q[k]), one[:, :2])
    flat = op2.sesc_vectors().reshape(-1)  # (3N,) SESC vectors take the checked path
    assert np.allclose(op2.com(q[0], flat), batch[:1], atol=1e-15)
    bad = q[0].copy()
    bad[3] = np.nan
    with pytest.raises(DataError, match="non-finite"):
        op2.com(bad)
    with pytest.raises(DataError, match="expected shape"):
        op2.com(q[0, :-1].copy())
