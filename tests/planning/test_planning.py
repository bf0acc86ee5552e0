"""Pose planning (sescid.design): limits, stability, collisions, D-optimal choice, ordering, CLI."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from click.testing import CliRunner
from fitting import identify_ls

from sescid import load_robot
from sescid import planning as design
from sescid.cli import cli
from sescid.errors import SescidError
from sescid.planning.design.doptimal import information, per_row_information, select_d_optimal
from sescid.planning.design.engine import expected_error, random_errors
from sescid.planning.design.kinds import BlockRows
from sescid.planning.feasibility.collision import (
    box_capsules,
    collision_free_mask_numpy,
    first_contact,
    segment_distance,
)
from sescid.planning.feasibility.ground import free_sole_corners, ground_clear
from sescid.planning.feasibility.stability import stable_mask
from sescid.planning.ordering import order_poses, path_length
from sescid.robots import MX28
from sescid.tables import read_poses, read_table


@pytest.fixture(scope="module")
def op2():
    return load_robot("op2")


@pytest.fixture(scope="module")
def pool(op2):
    """3000 candidate poses + 600 held-out test poses, projected on the identifiable basis."""
    cand = design.candidates(op2, 3600, seed=1)
    q, q_test = cand.q[:3000], cand.q[3000:]
    basis = design.identifiable_basis(op2, q)
    a = design.projected_regressor(op2, q, basis)
    c = per_row_information(design.projected_regressor(op2, q_test, basis))
    return cand, q, q_test, basis, a, c


def _rad(deg):
    return math.radians(deg)


# --- limits and conventions ------------------------------------------------------------------
def test_paper_limits_converted_to_servo_and_intersected_by_hand(op2):
    lim = design.sampling_limits(op2)
    j = op2.joint_names.index
    # (joint, expected lower, expected upper) worked from joint_limits.csv + the URDF by hand:
    cases = [
        # ID11: paper [-29, 96], paper = -servo → servo [-96, 29]; URDF upper 0.45 rad (25.8°)
        ("r_hip_pitch", _rad(-96), 0.45),
        # ID3: paper [-120, 84], paper = servo - 45 → servo [-75, 129]; URDF lower -0.68 rad
        ("r_sho_roll", -0.68, _rad(129)),
        # ID6: paper [-156, 4], paper = servo - 90 → servo [-66, 94]; URDF upper 1.63 rad
        ("l_el", _rad(-66), 1.63),
        # ID20: paper [-40, 25], paper = -servo → servo [-25, 40]; URDF lower -0.36 rad
        ("head_tilt", -0.36, _rad(40)),
        # ID13: paper [0, 132] = servo; URDF upper 2.25 rad
        ("r_knee", 0.0, 2.25),
    ]
    for name, lo, hi in cases:
        np.testing.assert_allclose(lim[j(name)], [lo, hi], atol=1e-12, err_msg=name)


def test_paper_convention_round_trip_maps_servo_limits_onto_the_paper_table(op2):
    pc = design.paper_convention(op2)
    back = np.sort(pc.to_paper(pc.servo_limits.T).T, axis=1)
    np.testing.assert_allclose(back, pc.paper_limits, atol=1e-12)
    q = np.random.default_rng(0).uniform(-1, 1, (5, op2.nq))
    np.testing.assert_allclose(pc.to_servo(pc.to_paper(q)), q, atol=1e-15)
    # ID5 (r_el): paper = servo + 90°, so servo 0 is 90° in the paper's convention
    assert np.degrees(pc.to_paper(np.zeros(op2.nq)))[op2.joint_names.index("r_el")] == 90.0


def test_mx28_ticks():
    q = np.radians([[0.0, 90.0, -180.0, 1.0, -45.0]])
    np.testing.assert_array_equal(MX28.to_ticks(q), [[2048, 3072, 0, 2059, 1536]])
    with pytest.raises(SescidError, match="MX-28"):
        MX28.to_ticks(np.radians([[180.0]]))


# --- stability and ground ----------------------------------------------------------------------
def _cop_from_bodies(robot, q):
    """CoP as mass-weighted body CoMs from forward kinematics (independent of the SESC form)."""
    rot, org = robot.forward(q)
    com = np.array([b.com for b in robot.model.bodies])
    m = robot.masses
    pts = org + np.einsum("nbij,bj->nbi", rot, com)
    return (pts * m[None, :, None]).sum(axis=1)[:, :2] / m.sum()


def test_candidates_are_stable_by_an_independent_cop(pool, op2):
    cand = pool[0]
    cop = _cop_from_bodies(op2, cand.q[:500])
    np.testing.assert_allclose(cand.cop[:500], cop, atol=1e-12)
    assert np.all(np.abs(cop) < 0.023)
    assert 0 < cand.n_free <= cand.n_ground <= cand.n_stable < cand.n_sampled


def test_stable_mask_agrees_with_the_box_on_random_poses(op2):
    lim = design.sampling_limits(op2)
    q = lim[:, 0] + np.ptp(lim, axis=1) * np.random.default_rng(3).random((4000, op2.nq))
    mask, _ = stable_mask(op2, q, (0.023, 0.023))
    expect = np.all(np.abs(_cop_from_bodies(op2, q)) < 0.023, axis=1)
    np.testing.assert_array_equal(mask, expect)
    assert 0 < mask.sum() < len(q)


def test_support_polygon_margin_shrinks_the_op2_sole(op2):
    np.testing.assert_allclose(design.cop_half_extents(op2, margin=0.01), [0.0425, 0.023])
    with pytest.raises(SescidError):
        design.cop_half_extents(op2, margin=0.04)


def test_free_sole_clearance_closed_form(op2):
    cap = design.collision_capsules(op2)
    q0 = np.zeros((1, op2.nq))
    rot, org = op2.forward(q0)
    np.testing.assert_allclose(
        free_sole_corners(op2, rot, org, op2.profile.sole_size)[0, :, 2], 0.0, atol=1e-12
    )
    assert not ground_clear(op2, cap, rot, org, 0.005)[0]
    # lift the left foot, sole kept level: hip flexion 0.5, knee flexion 1.0, ankle -0.5
    q = q0.copy()
    j = op2.joint_names.index
    q[0, j("l_hip_pitch")], q[0, j("l_knee")], q[0, j("l_ank_pitch")] = 0.5, -1.0, -0.5
    rot, org = op2.forward(q)
    z = free_sole_corners(op2, rot, org, op2.profile.sole_size)[0, :, 2]
    np.testing.assert_allclose(z, 2 * 0.093 * (1 - math.cos(0.5)), atol=1e-12)
    assert ground_clear(op2, cap, rot, org, 0.005)[0]
    assert not ground_clear(op2, cap, rot, org, 0.03)[0]


# --- collisions --------------------------------------------------------------------------------
def test_segment_distance_matches_dense_sampling():
    rng = np.random.default_rng(4)
    p0, p1, q0, q1 = rng.normal(size=(4, 120, 3))
    q1[:20] = q0[:20]  # point vs segment
    p1[20:40] = p0[20:40] + 1e-13  # degenerate first segment
    q1[40:60] = q0[40:60] + (p1[40:60] - p0[40:60])  # parallel segments
    got = segment_distance(p0, p1, q0, q1)
    t = np.linspace(0, 1, 301)
    a = p0[:, None, :] + t[None, :, None] * (p1 - p0)[:, None, :]
    b = q0[:, None, :] + t[None, :, None] * (q1 - q0)[:, None, :]
    dense = np.linalg.norm(a[:, :, None] - b[:, None, :], axis=3).min(axis=(1, 2))
    assert np.all(got <= dense + 1e-12)
    np.testing.assert_allclose(got, dense, atol=2e-3)


def test_box_capsules_stay_inside_and_reach_the_box_faces():
    e0, e1, r = box_capsules((0.1, 0.04, 0.03))
    ends = np.vstack([e0, e1])
    hi = np.abs(ends).max(axis=0) + r
    np.testing.assert_allclose(hi, [0.05, 0.02, 0.015], atol=1e-15)


def test_op2_shapes_do_not_touch_at_zero_and_the_zero_pose_is_free(op2):
    cap = design.collision_capsules(op2)
    assert cap.skipped_zero == [] and cap.notes == []
    assert len(cap.pairs) > 500  # every non-adjacent body pair is checked
    rot, org = op2.forward(np.zeros((1, op2.nq)))
    assert design.collision_free_mask(cap, rot, org)[0]


def test_arm_pushed_into_the_torso_collides(op2):
    cap = design.collision_capsules(op2)
    q = np.zeros((2, op2.nq))
    q[:, op2.joint_names.index("r_sho_roll")] = [-0.6, -1.6]  # arm 15° out, arm 47° across body
    rot, org = op2.forward(q)
    hit = first_contact(cap, rot, org)
    assert hit[0] == -1
    i, j = cap.pairs[hit[1]]
    assert {cap.link[i], cap.link[j]} == {"MP_BODY", "MP_ARM_HIGH_R"}


def test_compiled_collision_check_matches_numpy(op2):
    cap = design.collision_capsules(op2)
    lim = design.sampling_limits(op2)
    q = lim[:, 0] + np.ptp(lim, axis=1) * np.random.default_rng(5).random((1500, op2.nq))
    rot, org = op2.forward(q)
    fast = design.collision_free_mask(cap, rot, org)
    ref = collision_free_mask_numpy(cap, rot, org)
    np.testing.assert_array_equal(fast, ref)
    assert 0.5 < fast.mean() < 0.99


def test_other_urdf_uses_its_own_boxes_cylinders_spheres(tmp_path):
    urdf = tmp_path / "arm.urdf"
    inertial = (
        '<inertial><mass value="1"/>'
        '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'
    )
    lim = '<limit lower="-3.14" upper="3.14" effort="1" velocity="1"/>'
    geo = "<collision><origin xyz='0 0 {}'/><geometry>{}</geometry></collision>"
    urdf.write_text(
        f"""<robot name="arm">
  <link name="base">{inertial}
    {geo.format(0.01, '<box size="0.2 0.2 0.02"/>')}
  </link>
  <link name="l1">{inertial}
    {geo.format(0.15, '<cylinder radius="0.01" length="0.3"/>')}
    {geo.format(0, '<mesh filename="l1.stl"/>')}
  </link>
  <link name="l2">{inertial}
    {geo.format(0.175, '<box size="0.02 0.02 0.35"/>')}
    {geo.format(0.35, '<sphere radius="0.02"/>')}
  </link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.02"/><axis xyz="0 1 0"/>{lim}</joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>{lim}</joint>
</robot>
"""
    )
    robot = load_robot(urdf, support="base")
    cap = design.collision_capsules(robot)
    assert any("mesh" in n for n in cap.notes)
    # base–l2 is the only non-adjacent body pair
    assert set(cap.body[cap.pairs].ravel().tolist()) == {0, 2}
    q = np.array([[0.0, 0.0], [0.0, math.pi]])  # straight up; l2 folded down through the base
    rot, org = robot.forward(q)
    np.testing.assert_array_equal(design.collision_free_mask(cap, rot, org), [True, False])
    # the sphere at the tip of l2 (0.02 m) is 0.65 m above ground when straight, below when folded
    clear = ground_clear(robot, cap, rot, org, 0.005)
    np.testing.assert_array_equal(clear, [True, False])


# --- selection and expected error -------------------------------------------------------------
def test_d_optimal_beats_random_and_greedy(pool):
    _, _, _, basis, a, c = pool
    assert basis.shape[1] == 42
    sel = select_d_optimal(a, 38, seed=0)
    assert len(set(sel.index.tolist())) == 38
    greedy = select_d_optimal(a, 38, seed=0, max_passes=0)
    assert sel.logdet >= greedy.logdet
    sign, ld = np.linalg.slogdet(information(a[sel.index]))
    assert sign > 0 and ld == pytest.approx(sel.logdet, abs=1e-9)
    err = expected_error(BlockRows.plain(a), sel.index, c, 0.00493)
    rand = random_errors(BlockRows.plain(a), 38, c, 30, 0, 0.00493)
    assert err < 0.8 * np.median(rand)
    assert err < rand.min()


def test_d_optimal_matches_exhaustive_search_on_a_small_problem():
    rng = np.random.default_rng(6)
    a = rng.normal(size=(14, 2, 4)) * rng.uniform(0.2, 2.0, size=(14, 1, 1))
    best = max(
        np.linalg.slogdet(information(a[list(s)]))[1] for s in itertools.combinations(range(14), 3)
    )
    sel = select_d_optimal(a, 3, seed=0)
    assert sel.logdet == pytest.approx(best, abs=1e-9)


def test_greedy_woodbury_updates_match_determinants_from_scratch():
    rng = np.random.default_rng(9)
    a = rng.normal(size=(300, 2, 10)) * rng.uniform(0.5, 1.5, size=(300, 1, 1))
    x = a.reshape(-1, 10)
    m = 1e-8 * float(np.einsum("ij,ij->", x, x)) / (300 * 10) * np.eye(10)  # the same ridge
    chosen = []
    for _ in range(12):
        ld = np.array([np.linalg.slogdet(m + a[i].T @ a[i])[1] for i in range(300)])
        ld[chosen] = -np.inf
        chosen.append(int(np.argmax(ld)))
        m = m + a[chosen[-1]].T @ a[chosen[-1]]
    np.testing.assert_array_equal(select_d_optimal(a, 12, max_passes=0).index, chosen)


def test_expected_error_formula_matches_monte_carlo(op2, pool):
    """Identify on simulated noisy CoPs at the chosen poses; RMS error on held-out poses."""
    _, q, q_test, _, a, c = pool
    sigma = 0.00493
    sel = select_d_optimal(a, 38, seed=0)
    q_sel = q[sel.index]
    formula = expected_error(BlockRows.plain(a), sel.index, c, sigma)
    rng = np.random.default_rng(7)
    true_sel, true_test = op2.cop(q_sel), op2.cop(q_test)
    # least squares on the full 63-column regressor, 2000 noise draws at once (min-norm solution;
    # CoP predictions do not depend on the null-space choice)
    phi = op2.regressor(q_sel).reshape(-1, 63)
    phi_test = op2.regressor(q_test).reshape(-1, 63)
    y = (true_sel - op2.d[:2]).reshape(-1, 1) + sigma * rng.standard_normal((phi.shape[0], 2000))
    theta = np.linalg.lstsq(phi, y, rcond=1e-10)[0]
    err = phi_test @ theta + np.tile(op2.d[:2], len(q_test))[:, None] - true_test.reshape(-1, 1)
    assert math.sqrt(np.mean(err**2)) == pytest.approx(formula, rel=0.03)
    # identify_ls() on the first noisy draw predicts as that least squares does
    fit = identify_ls(op2, q_sel, y[:, 0].reshape(-1, 2) + op2.d[:2])
    np.testing.assert_allclose(
        fit.predict_cop(q_test).ravel(),
        (phi_test @ theta[:, 0]) + np.tile(op2.d[:2], 600),
        atol=1e-9,
    )


# --- ordering ----------------------------------------------------------------------------------
def test_ordering_recovers_points_on_a_line():
    x = np.linspace(0.1, 2.0, 20)
    perm_in = np.random.default_rng(8).permutation(20)
    q = np.column_stack([x[perm_in], 2 * x[perm_in]])
    order = order_poses(q)
    np.testing.assert_array_equal(x[perm_in][order], x)
    assert path_length(q[order], np.zeros(2)) == pytest.approx(2.0 * math.sqrt(5))


def test_ordering_shortens_the_path_of_chosen_poses(pool):
    q = pool[1][:38]
    order = order_poses(q)
    assert sorted(order.tolist()) == list(range(38))
    z = np.zeros(q.shape[1])
    assert path_length(q[order], z) < 0.8 * path_length(q, z)


# --- CLI -------------------------------------------------------------------------------------
def test_cli_poses_writes_ordered_pose_list(tmp_path, op2):
    out = tmp_path / "poses.csv"
    args = ["poses", "--count", "25", "--candidates", "600", "--test-poses", "200"]
    res = CliRunner().invoke(cli, [*args, "--seed", "2", "--out", str(out), "--paper-convention"])
    assert res.exit_code == 0, res.output
    assert "expected noise-free CoP error" in res.output
    table = read_table(out)
    q = read_poses(table, op2.joint_names)
    assert q.shape == (25, op2.nq)
    np.testing.assert_array_equal(table.get("pose"), np.arange(25))
    np.testing.assert_allclose(table.get("r_knee_deg"), np.degrees(q[:, 12]), atol=1e-9)
    np.testing.assert_array_equal(
        table.get("l_el_ticks"), np.rint(2048 + np.degrees(q[:, 5]) * 4096 / 360)
    )
    np.testing.assert_allclose(table.get("l_el_paper_deg"), np.degrees(q[:, 5]) - 90, atol=1e-9)
    cop = np.column_stack([table.get("cop_x_model"), table.get("cop_y_model")])
    assert "cop_x" not in table  # a prediction, never a measured column
    np.testing.assert_allclose(cop, op2.cop(q), atol=1e-12)
    lim = design.sampling_limits(op2)
    assert np.all((q >= lim[:, 0]) & (q <= lim[:, 1]))


@pytest.mark.parametrize(
    "bad",
    [
        ["--count", "20"],
        ["--robot", "nosuchbot"],
        ["--select", "best"],
        ["--margin", "0.05"],
        ["--noise", "0"],
    ],
)
def test_cli_poses_bad_input_exit_2_without_output(tmp_path, bad):
    out = tmp_path / "poses.csv"
    res = CliRunner().invoke(cli, ["poses", "--candidates", "600", "--out", str(out), *bad])
    assert res.exit_code == 2, res.output
    assert not out.exists()
    assert "Traceback" not in res.output


def test_cli_poses_random_in_shrunk_sole_with_figure(tmp_path, op2):
    out, fig = tmp_path / "poses.csv", tmp_path / "fig.png"
    args = ["poses", "--count", "22", "--select", "random", "--margin", "0.01"]
    args += ["--candidates", "400", "--test-poses", "100", "--out", str(out), "--figure", str(fig)]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    q = read_poses(read_table(out), op2.joint_names)
    cop = op2.cop(q)
    assert np.all(np.abs(cop) < [0.0425, 0.023])
    assert np.abs(cop[:, 0]).max() > 0.023  # the rectangle is wider than the paper's box in x
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
