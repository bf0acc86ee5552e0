"""Consistent masses/CoMs: checked against simulations of a "true" robot that differs from CAD."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from fitting import identify_consistent

import sescid
from sescid.errors import SescidError
from sescid.estimation.solvers.consistent import (
    body_boxes,
    consistent_from_fit,
    consistent_model,
    mirror_pairs,
    sesc_map,
)
from sescid.sesc import sesc_vectors

HEAVIER = {"MP_BODY": 1.03, "MP_ARM_LOW_R": 1.03, "MP_HEAD": 1.03}  # +3 % on three links


@pytest.fixture(scope="module")
def truth(robot):
    """(r_true (N, 3) m, total mass kg) of the robot with 3 % more mass on three links."""
    bodies = [
        dataclasses.replace(b, mass=b.mass * HEAVIER.get(b.name, 1.0)) for b in robot.model.bodies
    ]
    model = dataclasses.replace(robot.model, bodies=bodies)
    return sesc_vectors(model), sum(b.mass for b in bodies)


@pytest.fixture(scope="module")
def fresh(robot, truth):
    """Held-out noise-free poses of the true robot."""
    return sescid.simulate(robot, 2000, noise=0.0, seed=99, r_true=truth[0])


@pytest.fixture(scope="module")
def noisy(robot, truth):
    sim = sescid.simulate(robot, 1000, noise=0.00493, seed=1, r_true=truth[0])
    return sim, sescid.identify(robot, sim.q, sim.cop, method="ls")


@pytest.fixture(scope="module")
def sym_fit(robot, noisy, truth):
    return consistent_from_fit(noisy[1], total_mass=truth[1], mass_floor=0.01, symmetric=True)


def _rms(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)))


def _masses(fit):
    return np.array(fit.inertials.masses)


def _coms(fit):
    return np.array(fit.inertials.coms)


def test_sesc_map_is_the_sesc_vectors_of_the_parameters(robot, truth):
    # an arbitrary parameter vector: K x must equal sesc_vectors of the model it describes
    rng = np.random.default_rng(3)
    masses = robot.masses * rng.uniform(0.5, 1.5, robot.masses.size)
    coms = rng.normal(0.0, 0.03, (robot.masses.size, 3))
    big_m = masses.sum()
    x = np.concatenate([masses / big_m, (masses[:, None] * coms).ravel() / (big_m * 0.1)])
    expected = sesc_vectors(consistent_model(robot, masses, coms))
    np.testing.assert_allclose(sesc_map(robot) @ x, expected.ravel(), atol=1e-16)


def test_noise_free_data_reproduce_the_true_cop(robot, truth, fresh):
    sim = sescid.simulate(robot, 300, noise=0.0, seed=2, r_true=truth[0])
    fit = identify_consistent(robot, sim.q, sim.cop, total_mass=truth[1])
    assert fit.method == "consistent"
    assert _rms(fit.predict_cop(fresh.q), fresh.cop_true) < 2e-7  # fit_tol = 1e-7 m


def test_total_mass_is_the_given_value_and_masses_respect_the_floor(sym_fit, truth):
    masses = _masses(sym_fit)
    assert abs(masses.sum() - truth[1]) < 1e-9
    assert masses.min() >= 0.01 - 1e-12


def test_coms_lie_inside_their_boxes(sym_fit):
    # noisy data push CoMs onto box faces: the constraints must be active and still hold
    assert any("box face" in c for c in sym_fit.inertials.active_constraints)
    b = sym_fit.inertials
    for i, name in enumerate(sym_fit.robot.body_names):
        com, lo, hi = b.coms[i], b.box_lo[i], b.box_hi[i]
        assert np.all(com >= lo - 1e-12) and np.all(com <= hi + 1e-12), name


def test_symmetric_fit_mirrors_masses_and_coms(robot, sym_fit):
    masses, coms = _masses(sym_fit), _coms(sym_fit)
    rot, org = robot.forward(np.zeros((1, robot.nq)))
    world = org[0] + np.einsum("nij,nj->ni", rot[0], coms)  # CoMs at the zero pose
    pairs = mirror_pairs(robot.body_names)
    assert len(pairs) == 9
    # OP2 sagittal plane: y = mid-point of the two sole frames
    y0 = 0.5 * (robot.link_poses(np.zeros((1, robot.nq)), "l_sole")[1][0, 1])
    for i, j in pairs:
        assert masses[i] == pytest.approx(masses[j], abs=1e-12)
        np.testing.assert_allclose(world[i] * [1, -1, 1], world[j] - [0, 2 * y0, 0], atol=1e-12)


def test_held_out_cop_as_good_as_least_squares(robot, noisy, truth, fresh):
    sim, ls = noisy
    fit = identify_consistent(robot, sim.q, sim.cop, total_mass=truth[1])
    err_ls = _rms(ls.predict_cop(fresh.q), fresh.cop_true)
    err = _rms(fit.predict_cop(fresh.q), fresh.cop_true)
    assert err <= 1.05 * err_ls
    assert fit.rms == pytest.approx(_rms(fit.predict_cop(sim.q), sim.cop), rel=1e-12)


def test_without_active_constraints_the_cop_fit_equals_least_squares(robot, fresh):
    # low noise and boxes grown by 5 cm: the least-squares r is reachable inside the constraints
    sim = sescid.simulate(robot, 1000, noise=1e-4, seed=5)
    ls = sescid.identify(robot, sim.q, sim.cop, method="ls")
    fit = consistent_from_fit(ls, box_margin=0.05)
    assert fit.inertials.active_constraints == []
    assert abs(fit.rms - ls.rms) < 1e-9
    assert _rms(fit.predict_cop(fresh.q), ls.predict_cop(fresh.q)) < 2e-7


def test_cad_prior_gives_plausible_masses_and_beats_ls_with_few_poses(robot, truth, fresh):
    sim = sescid.simulate(robot, 38, noise=0.00493, seed=4, r_true=truth[0])
    ls = sescid.identify(robot, sim.q, sim.cop, method="ls")
    fit = consistent_from_fit(ls, total_mass=truth[1], prior_std=0.05)
    true_m = np.array([b.mass * HEAVIER.get(b.name, 1.0) for b in robot.model.bodies])
    assert np.max(np.abs(_masses(fit) / true_m - 1)) < 0.15
    err_ls = _rms(ls.predict_cop(fresh.q), fresh.cop_true)
    assert _rms(fit.predict_cop(fresh.q), fresh.cop_true) < 0.5 * err_ls


def test_mirror_pairs_recognises_side_markers():
    names = ["torso", "arm_R", "arm_L", "r_leg", "l_leg", "right_eye", "left_eye", "head_R"]
    assert sorted(mirror_pairs(names)) == [(1, 2), (3, 4), (5, 6)]


SHAPES_URDF = """<?xml version="1.0"?>
<robot name="shapes">
  <link name="base">
    <inertial><mass value="1.0"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>
    </inertial>
    <collision><origin xyz="0.1 0 0" rpy="0 0 0"/><geometry><box size="0.2 0.4 0.6"/></geometry>
    </collision>
    <collision><origin xyz="0 0 0.5" rpy="0 0 0"/><geometry><sphere radius="0.05"/></geometry>
    </collision>
  </link>
  <link name="arm">
    <inertial><origin xyz="0.3 0 0"/><mass value="0.5"/>
      <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>
    <visual><origin xyz="0 0 0" rpy="0 1.5707963267948966 0"/>
      <geometry><cylinder radius="0.02" length="0.6"/></geometry></visual>
  </link>
  <link name="hand">
    <inertial><origin xyz="0.05 0.01 0"/><mass value="0.2"/>
      <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>
  </link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="j2" type="revolute"><parent link="arm"/><child link="hand"/>
    <origin xyz="0.6 0 0"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""


def test_boxes_from_collision_visual_shapes_and_fallback(tmp_path):
    path = tmp_path / "shapes.urdf"
    path.write_text(SHAPES_URDF)
    rob = sescid.load_robot(path, support="base")
    base, arm, hand = body_boxes(rob)
    # base: hull of the box [0, 0.2]×[-0.2, 0.2]×[-0.3, 0.3] and the r = 0.05 sphere at z = 0.5
    assert base.source == "collision"
    np.testing.assert_allclose(base.lo, [-0.05, -0.2, -0.3], atol=1e-15)
    np.testing.assert_allclose(base.hi, [0.2, 0.2, 0.55], atol=1e-15)
    # arm: a cylinder of length 0.6 along z turned onto x (±0.3 along x, radius 0.02 across)
    assert arm.source == "visual"
    np.testing.assert_allclose(arm.lo, [-0.3, -0.02, -0.02], atol=1e-12)
    np.testing.assert_allclose(arm.hi, [0.3, 0.02, 0.02], atol=1e-12)
    # hand: no shape → hull of its joint point and CAD CoM, grown by 0.02 m
    assert hand.source == "fallback"
    np.testing.assert_allclose(hand.lo, [-0.02, -0.02, -0.02], atol=1e-15)
    np.testing.assert_allclose(hand.hi, [0.07, 0.03, 0.02], atol=1e-15)


def test_given_box_is_read_in_the_main_link_frame(robot):
    # MP_ANKLE1_R's body frame sits on its ankle-roll axis, offset from its link frame
    box = body_boxes(robot, boxes={"MP_ANKLE1_R": ([0, 0, 0], [0.01, 0.02, 0.03])})[1]
    x = robot.model.link_frames["MP_ANKLE1_R"][1]
    assert box.source == "given"
    np.testing.assert_allclose(box.lo, x[:3, 3], atol=1e-15)
    np.testing.assert_allclose(box.hi, x[:3, 3] + [0.01, 0.02, 0.03], atol=1e-15)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"total_mass": -1.0}, "total mass must be a positive"),
        ({"total_mass": float("nan")}, "total mass must be a positive"),
        ({"mass_floor": 0.2}, "exceeds the total mass"),
        ({"mass_floor": -0.1}, "mass floor must be"),
        ({"boxes": {"MP_HEAD": ([0, 0, 0], [-1, 1, 1])}}, "lo ≤ hi"),
        ({"boxes": {"nose": ([0, 0, 0], [1, 1, 1])}}, "unknown body 'nose'"),
        ({"box_margin": -0.01}, "box margin"),
        ({"prior_std": 0.0}, "prior std"),
    ],
)
def test_bad_inputs_raise_clear_errors(noisy, kwargs, message):
    with pytest.raises(SescidError, match=message):
        consistent_from_fit(noisy[1], **kwargs)


def test_infeasible_constraints_raise_a_clear_error(noisy):
    # symmetric forearms, but their boxes are not mirror images and neither may be massless
    boxes = {
        "MP_ARM_LOW_R": ([0.10, -0.02, -0.02], [0.11, 0.02, 0.02]),
        "MP_ARM_LOW_L": ([0.00, -0.02, -0.02], [0.01, 0.02, 0.02]),
    }
    with pytest.raises(SescidError, match="infeasible"):
        consistent_from_fit(noisy[1], symmetric=True, mass_floor=0.01, boxes=boxes)


@pytest.mark.parametrize("prior_std", [None, 0.05])
def test_uniform_cop_weights_leave_the_fit_unchanged(robot, noisy, prior_std):
    sim, ls = noisy
    weighted = sescid.identify(robot, sim.q, sim.cop, sigma=np.full(len(sim.q), 0.002), method="ls")
    a = consistent_from_fit(ls, prior_std=prior_std)
    b = consistent_from_fit(weighted, prior_std=prior_std)
    np.testing.assert_allclose(_masses(b), _masses(a), atol=1e-6 * robot.total_mass)
    assert b.rms == pytest.approx(_rms(b.predict_cop(sim.q), sim.cop), rel=1e-6)
