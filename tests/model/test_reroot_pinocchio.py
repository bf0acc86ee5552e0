"""The re-rooted body tree against Pinocchio (an independent URDF reader and kinematics).

Pinocchio (free-flyer root at identity, see tests/helpers/oracle.py) groups links as sescid does:
the links welded by fixed joints form one body whatever the root. For random trees (with mimic
joints), the OP2, TALOS and iCub, re-rooted at several links, every sescid body must have
Pinocchio's links, total mass, CoM and inertia; every link frame Pinocchio's pose in the support
frame; and every joint must be crossed in the direction that its Pinocchio body implies.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from oracle import PinOracle
from urdf_gen import random_urdf

import sescid
from sescid.model import inertia_parts

ERD = "example-robot-data/robots"


def _erd(name: str, path: str):
    from pathlib import Path

    import cmeel

    f = Path(cmeel.__file__).resolve().parent.parent / "cmeel.prefix" / "share" / ERD / path
    if not f.is_file():
        pytest.skip(f"example-robot-data has no {path}")
    return f


def _groups(model: pin.Model) -> dict[str, int]:
    """Link name → the Pinocchio joint whose body holds it."""
    return {f.name: f.parentJoint for f in model.frames if f.type == pin.FrameType.BODY}


def _body_inertia(parts, com):
    out = np.zeros((3, 3))
    for m, c, i_c in parts:
        d = c - com
        out += i_c + m * ((d @ d) * np.eye(3) - np.outer(d, d))
    return out


def _has_tensor(model, link: str) -> bool:
    """The link has no mass or an inertia tensor (so its body's tensor is complete)."""
    inertial = model.inertials.get(link)
    return inertial is None or not inertial.mass > 0 or inertial.inertia is not None


def _compare(path, support: str, q: np.ndarray, mimic: dict | None = None) -> int:
    """Assert the tree equals Pinocchio's; the number of body inertias compared."""
    robot = sescid.load_robot(path, support)
    oracle = PinOracle(path, support, robot.joint_names, mimic)
    pm, pd = oracle.model, oracle.data
    group = _groups(pm)
    bodies = robot.model.bodies
    # the partition of links into rigid bodies, and which joint links each body to its parent
    body_group = []
    for b in bodies:
        links = [lk for lk in b.links if lk in group]
        assert links, b.name
        assert {group[lk] for lk in links} == {group[links[0]]}, b.name
        body_group.append(group[links[0]])
    assert len(set(body_group)) == len(bodies) == pm.njoints - 1
    for i, b in enumerate(bodies[1:], 1):
        jid = pm.getJointId(b.joint_name)
        mine = body_group[i] if b.sign > 0 else body_group[b.parent]
        assert jid == mine, (b.name, b.joint_name, b.sign)
        assert pm.parents[jid] == (body_group[b.parent] if b.sign > 0 else body_group[i])
    masses = np.array([pm.inertias[g].mass for g in body_group])
    np.testing.assert_allclose(robot.masses, masses, rtol=1e-12, atol=1e-15)
    parts = inertia_parts(robot.model)
    rot, org = robot.forward(q)
    sup = pm.getFrameId(support)
    checked = 0
    for k, qk in enumerate(q):
        pin.forwardKinematics(pm, pd, oracle.q_pin(qk))
        pin.updateFramePlacements(pm, pd)
        world = pd.oMf[sup]
        for i, b in enumerate(bodies):
            g = body_group[i]
            rel = world.actInv(pd.oMi[g])
            if b.mass > 0:
                com = rot[k, i] @ b.com + org[k, i]
                np.testing.assert_allclose(com, rel.act(pm.inertias[g].lever), atol=1e-12)
            if b.mass > 0 and all(_has_tensor(robot.model, lk) for lk in b.links):
                checked += 1
                ours = rot[k, i] @ _body_inertia(parts[i], b.com) @ rot[k, i].T
                ref = rel.rotation @ pm.inertias[g].inertia @ rel.rotation.T
                np.testing.assert_allclose(ours, ref, atol=1e-12 * max(1.0, np.abs(ref).max()))
        for lk in (f.name for f in pm.frames if f.type == pin.FrameType.BODY):
            r_lk, o_lk = robot.link_poses(q[k : k + 1], lk)
            rel = world.actInv(pd.oMf[pm.getFrameId(lk)])
            np.testing.assert_allclose(r_lk[0], rel.rotation, atol=1e-12)
            np.testing.assert_allclose(o_lk[0], rel.translation, atol=1e-12)
    return checked


@pytest.mark.parametrize("seed", range(12))
def test_random_trees_rerooted_anywhere(tmp_path, seed):
    """Random trees (fixed, continuous, massless links; mimics on odd seeds), any support."""
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(2, 18))
    text, links, mimic = random_urdf(rng, n_links=n, mimic=bool(seed % 2))
    path = tmp_path / "tree.urdf"
    path.write_text(text)
    for support in {links[0], links[-1], links[int(rng.integers(n))]}:
        try:
            robot = sescid.load_robot(path, support)
        except sescid.SescidError as exc:  # a tree with no mass at all
            assert "no mass" in str(exc)
            return
        assert _compare(path, support, rng.uniform(-np.pi, np.pi, (4, robot.nq)), mimic) > 0


@pytest.mark.parametrize(
    ("which", "supports"),
    [
        ("op2", ["r_sole", "l_sole", "MP_BODY", "MP_ARM_LOW_L"]),
        ("talos", ["right_sole_link", "left_sole_link", "torso_2_link", "arm_right_7_link"]),
        ("icub", ["r_sole", "l_sole", "chest", "l_hand"]),
    ],
)
def test_humanoids_rerooted_at_feet_torso_and_hand(op2, which, supports):
    path = {
        "op2": lambda: op2.model_path,
        "talos": lambda: _erd("talos", "talos_data/robots/talos_reduced.urdf"),
        "icub": lambda: _erd("icub", "icub_description/robots/icub.urdf"),
    }[which]()
    rng = np.random.default_rng(7)
    for support in supports:
        nq = sescid.load_robot(path, support).nq
        assert _compare(path, support, rng.uniform(-1.5, 1.5, (3, nq))) >= 3 * 15
