"""SESC vectors against closed forms worked by hand and the mass-weighted CoM of all links."""

from __future__ import annotations

import numpy as np
import pytest

import sescid
from sescid.sesc import subtree_masses

# Two links: a base (support) and an arm turning about z at (0.1, 0, 0.2) from the base.
_TWO = """<?xml version="1.0"?>
<robot name="two">
  <link name="base"><inertial><origin xyz="0.01 0.02 0.03"/><mass value="2"/>
    <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <link name="arm"><inertial><origin xyz="0.3 0 0.05"/><mass value="1"/>
    <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <link name="tool"><inertial><origin xyz="0 0 0"/><mass value="0.5"/>
    <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="yaw" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0.1 0 0.2"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="weld" type="fixed"><parent link="arm"/><child link="tool"/>
    <origin xyz="0.4 0 0"/></joint>
</robot>
"""


@pytest.fixture
def two(tmp_path):
    path = tmp_path / "two.urdf"
    path.write_text(_TWO)
    return sescid.load_robot(path, support="base")


def test_two_link_sesc_vectors_by_hand(two):
    total = 3.5
    assert two.body_names == ["base", "arm"]  # the tool is welded into the arm
    r = two.sesc_vectors()
    # base: own m·c plus the arm subtree's 1.5 kg carried at the joint (0.1, 0, 0.2)
    np.testing.assert_allclose(
        r[0], (2 * np.array([0.01, 0.02, 0.03]) + 1.5 * np.array([0.1, 0, 0.2])) / total
    )
    # arm: 1 kg at (0.3, 0, 0.05) and the 0.5 kg tool at (0.4, 0, 0)
    np.testing.assert_allclose(
        r[1], (np.array([0.3, 0, 0.05]) + 0.5 * np.array([0.4, 0, 0])) / total
    )
    np.testing.assert_allclose(subtree_masses(two.model), [3.5, 1.5])


def test_two_link_com_by_hand(two):
    th = np.array([0.0, 0.7, -2.0])
    com = two.com(th[:, None])
    c, s = np.cos(th), np.sin(th)
    # arm + tool CoM in the arm frame: (0.3·1 + 0.4·0.5, 0, 0.05·1) / 1.5
    ax, az = (0.3 + 0.2) / 1.5, 0.05 / 1.5
    expect = np.column_stack(
        [
            (2 * 0.01 + 1.5 * (0.1 + c * ax)) / 3.5,
            (2 * 0.02 + 1.5 * (s * ax)) / 3.5,
            np.full(3, (2 * 0.03 + 1.5 * (0.2 + az)) / 3.5),
        ]
    )
    np.testing.assert_allclose(com, expect, atol=1e-15)


def test_com_equals_mass_weighted_link_coms(op2, rng):
    """Independent of the SESC algebra: Σ m_l (o_l + R_l c_l) / M over every URDF link."""
    import yourdfpy

    urdf = yourdfpy.URDF.load(str(op2.model_path), build_scene_graph=False, load_meshes=False)
    q = rng.uniform(-1.5, 1.5, (40, op2.nq))
    acc = np.zeros((40, 3))
    for link in urdf.robot.links:
        if link.inertial is None or not link.inertial.mass:
            continue
        rot, pos = op2.link_poses(q, link.name)
        acc += link.inertial.mass * (pos + rot @ link.inertial.origin[:3, 3])
    np.testing.assert_allclose(op2.com(q), acc / op2.total_mass, atol=1e-15)


def test_other_sesc_vectors_move_the_cop(op2, rng):
    q = rng.uniform(-0.5, 0.5, (10, op2.nq))
    r = op2.sesc_vectors()
    r2 = r.copy()
    r2[6, 0] += 0.001  # torso x component: +1 mm
    rot, _ = op2.forward(q)
    np.testing.assert_allclose(op2.cop(q, r2) - op2.cop(q), 0.001 * rot[:, 6, :2, 0], atol=1e-16)


def test_stances_share_the_body_parameters(op2, icub_path):
    """The SESC vectors of every stance (left sole, a held torso) are a linear image of the
    reference stance's body parameters: r_s = E θ / M to round-off (OP2 and iCub)."""
    for robot in (op2, sescid.load_robot(icub_path, "r_sole")):
        theta = robot.body_parameters()
        mass = theta[: len(robot.body_names)].sum()
        assert mass == pytest.approx(robot.total_mass, rel=1e-15)
        others = ("l_sole", "MP_BODY") if robot is op2 else ("l_sole", "root_link")
        for support in others:
            other = robot.at(support)
            r = other.sesc_matrix(robot) @ theta / mass
            np.testing.assert_allclose(r, other.sesc_vectors().reshape(-1), atol=1e-15)
