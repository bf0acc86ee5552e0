"""URDF → body tree: the OP2's facts, merging of fixed links, unsupported input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from oracle import PinOracle
from urdf_gen import random_urdf

import sescid
from sescid.errors import SescidError
from sescid.robots import body_table, profile_for

SERVO_ORDER = [
    "r_sho_pitch", "l_sho_pitch", "r_sho_roll", "l_sho_roll", "r_el", "l_el",
    "r_hip_yaw", "l_hip_yaw", "r_hip_roll", "l_hip_roll", "r_hip_pitch", "l_hip_pitch",
    "r_knee", "l_knee", "r_ank_pitch", "l_ank_pitch", "r_ank_roll", "l_ank_roll",
    "head_pan", "head_tilt",
]  # fmt: skip


def test_op2_total_mass_is_the_manufacturer_sum(op2):
    # 0.975599 torso + 0.0243577 neck + 0.158042 head + 2 x 0.2535785 arms + 2 x 0.6300842 legs
    expected = 0.975599 + 0.0243577 + 0.158042 + 2 * 0.2535785 + 2 * 0.6300842
    assert op2.total_mass == pytest.approx(expected, abs=1e-9)
    assert op2.total_mass == pytest.approx(2.9253, abs=5e-5)
    oracle = PinOracle(op2.model_path, "r_sole", op2.joint_names)
    assert oracle.total_mass() == pytest.approx(op2.total_mass, abs=1e-12)


def test_op2_zero_pose_heights(op2):
    zero = np.zeros((1, op2.nq))
    _, torso = op2.link_poses(zero, "MP_BODY")
    assert torso[0, 2] == pytest.approx(0.1222 + 0.093 + 0.093 + 0.0335, abs=1e-12)  # 0.3417
    com = op2.com(zero)[0]
    # reference: CoM (-0.0089, -0.0010, -0.1137) in the torso frame = 0.228 m above the sole
    # and (-0.0040, +0.0360) from the right ankle axis, i.e. (-0.0035, +0.0469) from the sole
    assert com[2] == pytest.approx(0.228, abs=5e-4)
    assert com[:2] == pytest.approx([-0.0035, 0.0469], abs=5e-4)
    _, l_sole = op2.link_poses(zero, "l_sole")
    assert l_sole[0] == pytest.approx([0.0, 2 * 0.037 + 2 * 0.0109, 0.0], abs=1e-12)


def test_op2_names_and_order(op2):
    assert op2.joint_names == SERVO_ORDER
    assert len(op2.body_names) == 21 and all(b.startswith("MP_") for b in op2.body_names)
    assert op2.body_names[0] == "MP_ANKLE2_R"  # support body = right foot
    assert op2.support == "r_sole"
    assert op2.model.link_frames["r_sole"][0] == 0
    table = body_table(profile_for("op2"))
    assert [int(row["paper_index"]) for row in table] == list(range(1, 22))
    assert sorted(row["link"] for row in table) == sorted(op2.body_names)
    assert table[0]["link"] == "MP_ANKLE2_R" and table[20]["link"] == "MP_ANKLE2_L"
    assert np.all(np.isfinite(op2.joint_limits)) and np.all(op2.joint_limits[:, 0] < 0)


def test_fixed_links_are_merged_and_their_mass_counts(tmp_path):
    rng = np.random.default_rng(3)
    text, links, _ = random_urdf(rng, n_links=14, p_fixed=0.4)
    path = tmp_path / "tree.urdf"
    path.write_text(text)
    robot = sescid.load_robot(path, support="link0")
    n_fixed = text.count('type="fixed"')
    assert len(robot.body_names) == 14 - n_fixed
    assert robot.nq == 13 - n_fixed
    assert sum(len(b.links) for b in robot.model.bodies) == 14
    oracle = PinOracle(path, "link0", robot.joint_names)
    assert robot.total_mass == pytest.approx(oracle.total_mass(), rel=1e-12)


def _write(tmp_path, body: str):
    path = tmp_path / "bad.urdf"
    path.write_text(f'<?xml version="1.0"?><robot name="r">{body}</robot>')
    return path


_TWO_LINKS = (
    '<link name="a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" '
    'iyz="0" izz="1"/></inertial></link><link name="b"/>'
)


@pytest.mark.parametrize("jtype", ["prismatic", "floating", "planar"])
def test_unsupported_joint_types_are_named(tmp_path, jtype):
    path = _write(
        tmp_path,
        _TWO_LINKS + f'<joint name="j1" type="{jtype}"><parent link="a"/><child link="b"/>'
        '<axis xyz="0 0 1"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>',
    )
    with pytest.raises(SescidError, match=rf"'j1' has type '{jtype}'"):
        sescid.load_robot(path, support="a")


def test_malformed_urdf_names_the_file(tmp_path):
    path = tmp_path / "broken.urdf"
    path.write_text("<robot name='x'><link name='a'></robot")
    with pytest.raises(SescidError, match=r"broken\.urdf: malformed URDF"):
        sescid.load_robot(path, support="a")


def test_unknown_support_and_robot(tmp_path):
    with pytest.raises(SescidError, match="unknown support link 'foot'"):
        sescid.load_robot("op2", support="foot")
    with pytest.raises(SescidError, match="unknown robot 'nao'"):
        sescid.load_robot("nao")
    with pytest.raises(SescidError, match="URDF file not found"):
        sescid.load_robot(tmp_path / "missing.urdf", support="a")


def test_massless_robot_is_rejected(tmp_path):
    path = _write(tmp_path, '<link name="a"/>')
    with pytest.raises(SescidError, match="no mass"):
        sescid.load_robot(path, support="a")


def test_mimic_joints_follow_their_master(tmp_path):
    rng = np.random.default_rng(11)
    text, links, mimics = random_urdf(rng, n_links=12, p_fixed=0.1, mimic=True)
    assert mimics, "the generator should have produced a mimic joint for this seed"
    path = tmp_path / "mimic.urdf"
    path.write_text(text)
    robot = sescid.load_robot(path, support=links[5])
    assert not set(mimics) & set(robot.joint_names)
    q = rng.uniform(-2, 2, (30, robot.nq))
    oracle = PinOracle(path, links[5], robot.joint_names, mimic=mimics)
    np.testing.assert_allclose(robot.com(q), oracle.com(q), atol=1e-12)


def _same(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return np.array_equal(np.asarray(a, dtype=float), np.asarray(b, dtype=float))


def _erd_talos():
    import cmeel

    base = Path(cmeel.__file__).resolve().parent.parent / "cmeel.prefix" / "share"
    path = base / "example-robot-data" / "robots" / "talos_data" / "robots" / "talos_full_v2.urdf"
    if not path.is_file():
        pytest.skip("example-robot-data has no talos_full_v2.urdf")
    return path


@pytest.mark.parametrize("which", ["op2", "icub", "talos", "random0", "random1", "random2"])
def test_urdf_parser_matches_yourdfpy(op2, icub_path, tmp_path, which):
    """The one URDF parser reads every number statics, shapes, the bench and export use exactly
    as yourdfpy (the test oracle) does: OP2, iCub, TALOS and random trees with mimic joints."""
    import yourdfpy

    from sescid.model import load_urdf

    if which.startswith("random"):
        rng = np.random.default_rng(int(which[-1]))
        text, _, mimics = random_urdf(rng, n_links=16, mimic=True)
        path = tmp_path / "tree.urdf"
        path.write_text(text)
    else:
        path = {"op2": op2.model_path, "icub": icub_path}.get(which) or _erd_talos()
    ref = yourdfpy.URDF.load(str(path), build_scene_graph=False, load_meshes=False).robot
    ours = load_urdf(path).robot
    assert ours.name == ref.name
    for a, b in zip(ref.joints, ours.joints, strict=True):
        assert (a.name, a.type, a.parent, a.child) == (b.name, b.type, b.parent, b.child)
        assert _same(a.origin, b.origin) and _same(a.axis, b.axis), a.name
        assert (a.limit is None) == (b.limit is None) and (a.mimic is None) == (b.mimic is None)
        if a.limit is not None:
            assert (a.limit.lower, a.limit.upper) == (b.limit.lower, b.limit.upper)
        if a.mimic is not None:
            assert a.mimic.joint == b.mimic.joint, a.name
            assert (a.mimic.multiplier or 1.0, a.mimic.offset or 0.0) == (
                b.mimic.multiplier,
                b.mimic.offset,
            )
    for a, b in zip(ref.links, ours.links, strict=True):
        assert a.name == b.name and (a.inertial is None) == (b.inertial is None)
        if a.inertial is not None:
            assert a.inertial.mass == b.inertial.mass, a.name
            assert _same(a.inertial.origin, b.inertial.origin)
            assert _same(a.inertial.inertia, b.inertial.inertia)
        for ea, eb in zip(a.visuals + a.collisions, b.visuals + b.collisions, strict=True):
            assert _same(ea.origin, eb.origin), a.name
            for kind in ("box", "cylinder", "sphere", "mesh"):
                ga, gb = getattr(ea.geometry, kind), getattr(eb.geometry, kind)
                assert (ga is None) == (gb is None)
            if ea.geometry.box is not None:
                assert _same(ea.geometry.box.size, eb.geometry.box.size)
            if ea.geometry.cylinder is not None:
                cyl_a, cyl_b = ea.geometry.cylinder, eb.geometry.cylinder
                assert (cyl_a.radius, cyl_a.length) == (cyl_b.radius, cyl_b.length)
            if ea.geometry.sphere is not None:
                assert ea.geometry.sphere.radius == eb.geometry.sphere.radius
            if ea.geometry.mesh is not None:
                assert ea.geometry.mesh.filename == eb.geometry.mesh.filename
                assert _same(ea.geometry.mesh.scale, eb.geometry.mesh.scale)
    if which.startswith("random"):
        assert mimics and {j.name for j in ours.joints if j.mimic is not None} == set(mimics)


def test_an_stls_distinct_vertices_are_numpys_unique_rows():
    """The distinct vertices of an STL (every vertex repeated by its triangles) are
    ``np.unique(v, axis=0)`` bit for bit: sorted by x, then y, then z, each row once — also
    where rows share x, or x and y, or differ by 1e-17."""
    from sescid.model.meshes import _distinct_rows

    rng = np.random.default_rng(5)
    base = rng.integers(-3, 4, size=(400, 3)) * 0.25 + rng.integers(0, 2, size=(400, 3)) * 1e-17
    base[:7] = [0.0, -0.5, 0.25]
    v = base[rng.integers(0, 400, size=5000)]
    got = _distinct_rows(v)
    assert got.tobytes() == np.unique(v, axis=0).tobytes()
    assert 7 < len(got) < 400
