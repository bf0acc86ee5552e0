"""Soles from geometry: the support frame checked level (its z along the sole's normal), the free
foot found from the tree and the geometry (no names), on a synthetic MJCF humanoid whose names
follow no left/right convention and on URDF humanoids (TALOS, iCub, a Y-up human model)."""

from __future__ import annotations

import numpy as np
import pytest
from refs import erd, mj_geom_corners, write_humanoid

import sescid
from sescid.errors import ModelError
from sescid.model.sole import LEVEL_SHARE, supporting_leg


@pytest.fixture(scope="module")
def hum_path(tmp_path_factory):
    return write_humanoid(tmp_path_factory.mktemp("feet"))


@pytest.mark.parametrize("support", ["legA_sole", "legA_foot"])
def test_level_sole_and_foot_frames_pass(hum_path, support):
    sescid.load_robot(hum_path, support).check_support_level()


def test_heel_frame_with_horizontal_z_is_refused_naming_a_fix(hum_path):
    """A heel site whose z points backwards: one-line ModelError naming a level frame."""
    robot = sescid.load_robot(hum_path, "legA_heel")
    with pytest.raises(ModelError) as exc:
        robot.check_support_level()
    msg = str(exc.value)
    assert "\n" not in msg and "'legA_heel' is not level" in msg and "--support" in msg
    assert "legA_sole" in msg and "legA_foot" in msg  # the frames that would do
    assert "+x axis" in msg  # the sole's normal, pointing up, is the heel frame's +x


def test_y_up_human_model_is_refused():
    """example-robot-data's human model is Y-up: its foot frame's z is horizontal."""
    robot = sescid.load_robot(erd("human_description/robots/human.urdf"), "right_foot")
    with pytest.raises(ModelError, match=r"not level .*\+y axis"):
        robot.check_support_level()


def test_icub_foot_frame_refused_sole_frame_suggested():
    """iCub's r_foot frame is not the sole's (z not along the normal): r_sole is named."""
    path = erd("icub_description/robots/icub.urdf")
    with pytest.raises(ModelError, match="one of: r_sole"):
        sescid.load_robot(path, "r_foot").check_support_level()
    sescid.load_robot(path, "r_sole").check_support_level()


def test_level_share_measured_on_the_foot_box(hum_path):
    """The heel frame sees the foot box's back face: height × width of length × width."""
    from sescid.model.sole import level_check

    robot = sescid.load_robot(hum_path, "legA_heel")
    b, x = robot.model.link_frames["legA_heel"]
    chk = level_check(robot.shapes, b, x, {})
    length, width, height = 0.2, 0.09, 0.03  # humanoid_gen's default foot
    assert chk.share == pytest.approx(height * width / (length * width), rel=1e-9)
    assert chk.share < LEVEL_SHARE and not chk.level


def test_free_foot_from_geometry_synthetic(hum_path):
    """legA/legB name nothing: the free foot is legB_foot, its sole the box's bottom face
    (corners equal MuJoCo's geom corners at the zero pose)."""
    robot = sescid.load_robot(hum_path, "legA_sole")
    free = robot.free_sole
    assert free is not None and free.link == "legB_foot" and free.derived
    rot, org = robot.forward(np.zeros((1, robot.nq)))
    mine = org[0, free.body] + free.corners @ rot[0, free.body].T
    box = mj_geom_corners(hum_path, "legA_sole", robot.joint_names, np.zeros((1, robot.nq)),
                          "legB_foot_box")[0]  # fmt: skip
    bottom = box[::2]  # local z = −h/2
    key = np.lexsort((mine[:, 1], mine[:, 0]))
    np.testing.assert_allclose(mine[key], bottom[np.lexsort((bottom[:, 1], bottom[:, 0]))],
                               atol=1e-12)  # fmt: skip


@pytest.mark.parametrize(
    ("rel", "support", "free_link", "sole_frame"),
    [
        ("talos_data/robots/talos_full_v2.urdf", "right_sole_link", "leg_left_6_link",
         "left_sole_link"),
        ("talos_data/robots/talos_full_v2.urdf", "left_sole_link", "leg_right_6_link",
         "right_sole_link"),
    ],
)  # fmt: skip
def test_free_foot_from_geometry_talos(rel, support, free_link, sole_frame):
    """TALOS from either foot: the free foot is the other leg's last body; its derived sole lies
    in the floor plane at the zero pose and is centred under the model's own sole frame
    (placed by Pinocchio) to within 10 mm."""
    from oracle import PinOracle

    robot = sescid.load_robot(erd(rel), support)
    free = robot.free_sole
    assert free is not None and free.link == free_link
    rot, org = robot.forward(np.zeros((1, robot.nq)))
    corners = org[0, free.body] + free.corners @ rot[0, free.body].T
    np.testing.assert_allclose(corners[:, 2], robot.floor, atol=1e-9)
    pin = PinOracle(robot.model_path, support, robot.joint_names, _mimic(robot))
    import pinocchio

    pinocchio.framesForwardKinematics(pin.model, pin.data, pin.q_pin(np.zeros(robot.nq)))
    frame = pin.data.oMf[pin.frame].actInv(pin.data.oMf[pin.model.getFrameId(sole_frame)])
    assert np.linalg.norm(corners.mean(axis=0)[:2] - frame.translation[:2]) < 0.01


def _mimic(robot):
    return {
        b.joint_name: (robot.joint_names[b.joint], b.multiplier, b.offset)
        for b in robot.model.bodies
        if b.joint >= 0 and b.joint_name not in robot.joint_names
    }


def test_supporting_leg_ends_at_the_pelvis(hum_path):
    """The supporting leg runs from the foot to the pelvis (where the mass splits), past light
    side branches."""
    robot = sescid.load_robot(hum_path, "legA_sole")
    parents = [b.parent for b in robot.model.bodies]
    leg, top = supporting_leg(parents, robot.masses)
    names = robot.body_names
    assert names[top] == "pelvis"
    assert [names[b] for b in leg][1:] == ["legA_ankle", "legA_shank", "legA_thigh", "legA_hip2",
                                          "legA_hip"]  # fmt: skip
    toe = [*parents, 0]  # a light extra branch (a toe) on the support foot does not end the leg
    leg2, top2 = supporting_leg(toe, np.append(robot.masses, 0.05))
    assert top2 == top and leg2 == leg


def test_support_candidates_found_from_the_geometry(hum_path):
    """The synthetic humanoid (names follow no convention): two feet, each with its level sole
    site first and the heel site (z backwards) ranked after it; the OP2's URDF: its sole links."""
    from sescid.model.feet import support_candidates
    from sescid.robots import profile_for

    feet = support_candidates(hum_path)
    assert [f.body for f in feet] == ["legA_foot", "legB_foot"]
    assert feet[0].support == "legA_sole" and feet[1].support == "legB_sole"
    names = [n for n, _, _ in feet[0].frames]
    assert names.index("legA_sole") < names.index("legA_heel")
    assert dict((n, lv) for n, _, lv in feet[0].frames)["legA_heel"] is False
    assert feet[0].size == pytest.approx((0.2, 0.09), abs=1e-9)  # humanoid_gen's foot box
    op2 = support_candidates(profile_for("op2").model_file)
    assert sorted(f.support for f in op2) == ["l_sole", "r_sole"]


def test_info_and_the_support_error_name_the_candidates(hum_path):
    from click.testing import CliRunner

    from sescid.cli import cli

    res = CliRunner().invoke(cli, ["info", "--robot", str(hum_path)])
    assert res.exit_code == 0, res.output
    assert "no --support: rooted at the model's root" in res.output
    assert "legA_foot: lowest face 0.200 x 0.090 m; frames: legA_sole (on the sole, level)" in (
        res.output
    )
    bad = CliRunner().invoke(cli, ["poses", "--robot", str(hum_path), "--out", "x.csv"])
    assert bad.exit_code != 0
    assert "feet found from the tree and the geometry: legA_sole, legB_sole" in bad.output


@pytest.mark.parametrize("sole", [True, False])
def test_sole_corner_sites_are_not_given_as_the_sole(tmp_path, sole):
    """Sites at the corners of a foot's bottom face (MuJoCo Playground's Apollo) are level and
    on the sole, but no sole frame: the sole site comes first, else the level foot frame
    above the sole; the corners follow, labelled at its edge (they used to come first)."""
    pytest.importorskip("mujoco")
    from humanoid_mjcf_gen import write_humanoid

    from sescid.model.feet import support_candidates

    path = write_humanoid(tmp_path / "h", sole=sole, corners=True)
    feet = support_candidates(path)
    assert sorted(f.body for f in feet) == ["l_foot", "r_foot"]
    for f in feet:
        s = f.body[0]
        names = [n for n, _, _ in f.frames]
        assert f.support == (f"{s}_sole" if sole else f"{s}_foot"), f.frames
        corners = {f"{s}_foot_{c}" for c in ("fl", "fr", "bl", "br")}
        assert set(f.edge) == corners and set(names[-4:]) == corners
        assert f"{s}_foot_bl (on the sole, level, at its edge)" in f.describe()
