"""The floor check covers every body's geometry: collision shapes, visual shapes where a body
has none, its origin as a last resort — against MuJoCo's geoms (a synthetic humanoid whose
collision geometry is only the feet) and Pinocchio + coal's collision meshes (TALOS; iCub's
Collada meshes are not a reference there: this coal ignores their Y-up axis and turns the foot
sideways)."""

from __future__ import annotations

import numpy as np
import pytest
from refs import PinGeometry, erd, mj_body_lowest, mj_geom_corners, mj_lowest, write_humanoid

import sescid
from sescid import planning as design
from sescid.planning.feasibility.ground import ground_checks, ground_clear, lowest_heights


@pytest.fixture(scope="module")
def humanoid(tmp_path_factory):
    path = write_humanoid(tmp_path_factory.mktemp("hum"))
    return path, sescid.load_robot(path, "legA_sole")


def test_feet_only_humanoid_checks_visual_shapes_and_origins(humanoid):
    """Every body but the feet is checked by its visual shapes or, without any, its origin."""
    _, robot = humanoid
    g = ground_checks(robot)
    assert g.source["legB_foot"] == "collision"
    assert g.source["head"] == g.source["torso"] == g.source["armA_forearm"] == "visual"
    assert g.source["legA_hip"] == g.source["armB_shoulder"] == "origin"
    assert "legA_foot" not in g.source  # the support body stands on the floor
    assert g.exempt == []


def test_lowest_point_equals_mujoco_geoms(humanoid):
    """The lowest checked point over 300 random poses equals the one computed from MuJoCo's
    geom frames (spheres, capsules, boxes, body origins) to 1e-12 m; the mask follows it."""
    path, robot = humanoid
    lim = design.sampling_limits(robot)
    q = lim[:, 0] + np.ptp(lim, axis=1) * np.random.default_rng(0).random((300, robot.nq))
    rot, org = robot.forward(q)
    ref = mj_lowest(path, "legA_sole", robot.joint_names, q, skip_body="legA_foot")
    np.testing.assert_allclose(lowest_heights(robot, rot, org), ref, atol=1e-12)
    free = mj_geom_corners(path, "legA_sole", robot.joint_names, q, "legB_foot_box")
    free_low = free[:, ::2, 2].min(axis=1)  # the bottom face's corners (local z = −h/2)
    expect = (ref > robot.floor) & (free_low > robot.floor + 0.005)
    got = ground_clear(robot, None, rot, org, 0.005)
    np.testing.assert_array_equal(got, expect)
    assert 0.05 < got.mean() < 0.95


def test_limbs_through_the_floor_are_caught(humanoid):
    """Poses whose feet (the only collision geometry) are above the floor but a head, arm or
    torso (visual shapes, by MuJoCo) is below it: all rejected (a feet-only check passed them)."""
    path, robot = humanoid
    lim = design.sampling_limits(robot)
    q = lim[:, 0] + np.ptp(lim, axis=1) * np.random.default_rng(1).random((300, robot.nq))
    per = mj_body_lowest(path, "legA_sole", robot.joint_names, q, skip_body="legA_foot")
    feet_up = per["legB_foot"] > robot.floor
    visual = [b for b in per if ground_checks(robot).source[b] == "visual"]
    limb_down = np.min([per[b] for b in visual], axis=0) < robot.floor - 0.02
    caught = feet_up & limb_down
    assert caught.sum() >= 10
    rot, org = robot.forward(q[caught])
    assert not ground_clear(robot, None, rot, org, 0.005).any()
    feet = [s for s in robot.shapes if s.role == "collision"]
    assert {robot.body_names[s.body] for s in feet} == {"legA_foot", "legB_foot"}


def test_talos_planned_poses_clear_by_pinocchio_meshes():
    """TALOS's planned poses: every collision mesh (loaded by Pinocchio + coal, not sescid)
    above the floor, the free sole's rectangle above it by the clearance."""
    path = erd("talos_data/robots/talos_full_v2.urdf")
    robot = sescid.load_robot(path, "right_sole_link")
    plan = sescid.plan_poses(robot, count=46, n_candidates=300, n_test=80, seed=3)
    geo = PinGeometry(path, robot)
    support_links = set(robot.model.bodies[0].links)
    low, per = geo.lowest(plan.q, support_links)
    exempt = set(ground_checks(robot).exempt)
    for link, z in per.items():
        body = next(b for b in robot.model.bodies if link in b.links)
        if link in support_links or body.name in exempt:
            continue
        assert np.all(z > robot.floor), link
    assert np.all(low > robot.floor)
    # the free sole's rectangle (fixed in its body's frame) placed by Pinocchio's kinematics
    free = robot.free_sole
    assert free is not None and free.link == "leg_left_6_link"
    _, x = robot.model.link_frames[free.link]
    local = (free.corners - x[:3, 3]) @ x[:3, :3]  # body frame → link frame
    o = geo.oracle
    fid = o.model.getFrameId(free.link)
    for qk in plan.q:
        geo.pin.framesForwardKinematics(o.model, o.data, o.q_pin(qk))
        link, sup = o.data.oMf[fid], o.data.oMf[o.frame]
        world = local @ link.rotation.T + link.translation
        z = ((world - sup.translation) @ sup.rotation)[:, 2]
        assert np.all(z > robot.floor + 0.005 - 1e-9)
