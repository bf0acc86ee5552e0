"""Mesh files and the floor: Collada up axes, the missing ``meshes`` extra, ``package://``
meshes outside their package and ``ROS_PACKAGE_PATH``, and toes on the support foot."""

from __future__ import annotations

import shutil
import sys

import numpy as np
import pytest
from click.testing import CliRunner
from humanoid_mjcf_gen import TOE_DIP, write_humanoid
from mesh_robot_gen import FOOT, write_mesh_robot
from refs import mj_body_lowest

import sescid
from sescid.cli import cli
from sescid.errors import MissingExtraError
from sescid.model import meshes, support_candidates
from sescid.planning.feasibility.ground import clear_above, ground_checks, ground_clear

pytest.importorskip("trimesh")
pytest.importorskip("collada")


def _info(path, *args):
    return CliRunner().invoke(cli, ["info", "--robot", str(path), *map(str, args)])


@pytest.fixture(autouse=True)
def _fresh_mesh_cache():
    meshes._hull_vertices.cache_clear()
    meshes._ros_packages.cache_clear()
    yield
    meshes._hull_vertices.cache_clear()
    meshes._ros_packages.cache_clear()


@pytest.mark.parametrize("up", ["Y_UP", "X_UP", "Z_UP"])
def test_collada_up_axis_read_as_the_stl_robot(tmp_path, up):
    """The same boxes as Collada files written Y-, X- or Z-up give the STL robot's geometry:
    its soles, floor and every body's lowest point in random poses (1e-7 m: the STL's float32)."""
    stl = sescid.load_robot(write_mesh_robot(tmp_path / "stl"), "r_sole")
    dae = sescid.load_robot(write_mesh_robot(tmp_path / up, up=up), "r_sole")
    assert not dae.geometry_notes
    for s in dae.shapes:
        assert s.vertices is not None
        # the foot box read upright: 0.10 long, 0.06 wide, 0.02 high (a turned box is not)
        if s.link == "r_foot":
            ext = s.vertices.max(axis=0) - s.vertices.min(axis=0)
            np.testing.assert_allclose(ext, FOOT, atol=1e-7)
    np.testing.assert_allclose(dae.sole.size, stl.sole.size, atol=1e-7)
    np.testing.assert_allclose(dae.free_sole.corners, stl.free_sole.corners, atol=1e-7)
    assert abs(dae.floor - stl.floor) < 1e-7
    q = np.random.default_rng(0).uniform(-0.4, 0.4, (50, stl.nq))
    rot, org = stl.forward(q)
    from sescid.planning.feasibility.ground import lowest_heights

    np.testing.assert_allclose(
        lowest_heights(dae, rot, org), lowest_heights(stl, rot, org), atol=1e-7
    )


def test_collada_without_pycollada_names_the_extra(tmp_path, monkeypatch):
    """Without pycollada a Collada robot is refused in one line naming the meshes extra, by
    `poses`, and `info` says it where the feet would be (it used to say "no foot found")."""
    path = write_mesh_robot(tmp_path / "bot", up="Y_UP")
    monkeypatch.setitem(sys.modules, "collada", None)  # import collada → ImportError
    robot = sescid.load_robot(path, "r_sole")
    with pytest.raises(MissingExtraError, match=r"pip install 'sescid\[meshes\]'"):
        robot.shapes  # noqa: B018
    res = _info(path)
    assert res.exit_code == 0, res.output
    line = next(x for x in res.output.splitlines() if x.startswith("support candidates"))
    assert "unknown" in line and "pip install 'sescid[meshes]'" in line
    assert "no foot found" not in res.output
    out = tmp_path / "p.csv"
    res = CliRunner().invoke(cli, ["poses", "--robot", str(path), "--support", "r_sole",
                                   "--count", 20, "--out", str(out)])  # fmt: skip
    assert res.exit_code == 2 and not out.exists()
    assert "pip install 'sescid[meshes]'" in res.output and len(res.output.splitlines()) == 1


def test_package_meshes_out_of_their_package(tmp_path, monkeypatch):
    """A URDF copied out of its package: `info` counts its unresolved package:// meshes and says
    how to fix it; ROS_PACKAGE_PATH (a root holding the package by folder name, or by the name
    its package.xml gives) resolves them and the feet are found again."""
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    pkg = tmp_path / "ws" / "src" / "bot_description"
    inside = write_mesh_robot(pkg, package="bot_description")
    assert sorted(f.body for f in support_candidates(inside)) == ["l_foot", "r_foot"]
    away = tmp_path / "elsewhere" / "bot.urdf"
    away.parent.mkdir()
    shutil.copy(inside, away)
    res = _info(away)
    assert res.exit_code == 0, res.output
    assert "no foot found (mesh files not found or unreadable: see the notes)" in res.output
    # 10 links with a collision mesh each: pelvis, torso, two thighs, shanks, feet and arms
    assert "10 mesh file(s) not found" in res.output
    assert "10 of them are package:// meshes of package(s) bot_description" in res.output
    assert "ROS_PACKAGE_PATH" in res.output
    # ROOT/PKG: the workspace's src folder as a root
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{tmp_path / 'nowhere'}:{tmp_path / 'ws' / 'src'}")
    res = _info(away)
    assert "not found" not in res.output and "r_foot: lowest face" in res.output, res.output
    # by package.xml name: a folder named otherwise, deeper under the root
    meshes._ros_packages.cache_clear()
    moved = tmp_path / "ws2" / "a" / "b" / "checkout"
    moved.parent.mkdir(parents=True)
    shutil.move(pkg, moved)
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ws2"))
    assert meshes.ros_package("bot_description") == moved
    got = meshes.resolve_mesh("package://bot_description/meshes/foot.stl", away)
    assert got == moved / "meshes" / "foot.stl"
    assert meshes.resolve_mesh("package://other_pkg/meshes/foot.stl", away) is None


def test_toes_of_the_support_foot_are_held_above_the_floor(tmp_path):
    """Toes on a hinge of the support foot that dip below its sole at the zero pose are not
    exempt from the floor check: a pose is ground-clear only where MuJoCo puts the toes above
    the floor (they used to be skipped: the CMU humanoid's went 9.7 mm under it)."""
    pytest.importorskip("mujoco")
    path = write_humanoid(tmp_path / "h", toes=True)
    robot = sescid.load_robot(path, "r_sole")
    g = ground_checks(robot)
    assert "r_toes" not in g.exempt
    assert any("beyond the support foot held above the floor too: r_toes" in n for n in g.notes)
    q = np.zeros((41, robot.nq))
    toe = robot.joint_names.index("r_toe")
    q[:, toe] = np.linspace(-0.8, 0.8, 41)
    rot, org = robot.forward(q)
    ok = clear_above(g, rot, org, robot.floor)  # every body but the support and the free foot
    low = mj_body_lowest(path, "r_sole", robot.joint_names, q, "r_foot", {"r_toes"})["r_toes"]
    assert abs(low[20] - robot.floor + TOE_DIP) < 1e-9  # the zero pose: 5 mm under the sole
    margin = np.abs(low - robot.floor) > 1e-9
    np.testing.assert_array_equal(ok[margin], (low > robot.floor)[margin])
    assert ok.any() and not ok.all()


def test_bodies_without_geometry_are_checked_by_their_frames_too(tmp_path, monkeypatch):
    """Meshes not found (a URDF copied out of its package): each body is checked by its origin
    and by the frames on it, so the free sole frame keeps the foot clearance (iCub copied out of
    its package planned its free sole origin 7.9 mm under the floor: origins only)."""
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    inside = write_mesh_robot(tmp_path / "pkg", package="bot_description")
    away = tmp_path / "bot.urdf"
    shutil.copy(inside, away)
    robot = sescid.load_robot(away, "r_sole")
    g = ground_checks(robot)
    assert any("by their origin and frames only" in n for n in g.notes)
    q = np.random.default_rng(1).uniform(-0.8, 0.8, (4000, robot.nq))
    rot, org = robot.forward(q)
    ok = ground_clear(robot, None, rot, org, 0.005)
    _, sole = robot.link_poses(q, "l_sole")
    foot = org[:, robot.body_names.index(robot.free_sole.link)]
    assert ok.sum() > 100
    assert np.all(sole[ok, 2] > robot.floor + 0.005) and np.all(foot[ok, 2] > robot.floor + 0.005)
    # the sole frame decides poses the foot body's origin alone would pass
    assert np.any((sole[:, 2] <= robot.floor + 0.005) & (foot[:, 2] > robot.floor + 0.005))


def test_poses_and_session_refuse_a_model_whose_meshes_are_not_found(tmp_path, monkeypatch):
    """`poses` on a URDF copied out of its package: it planned, its floor and self-collision
    checks blind to the 10 missing meshes (a note among others); it now refuses in one line
    naming the files, ROS_PACKAGE_PATH and --allow-missing-meshes, which plans as before."""
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    inside = write_mesh_robot(tmp_path / "ws" / "bot_description", package="bot_description")
    away = tmp_path / "elsewhere" / "bot.urdf"
    away.parent.mkdir()
    shutil.copy(inside, away)
    out = tmp_path / "p.csv"
    args = ["poses", "--robot", str(away), "--support", "r_sole", "--count", 20,
            "--candidates", 300, "--test-poses", 50, "--out", str(out)]  # fmt: skip
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 2 and not out.exists() and len(res.output.splitlines()) == 1
    assert "10 mesh file(s) it names are not found" in res.output, res.output
    assert "ROS_PACKAGE_PATH" in res.output and "--allow-missing-meshes" in res.output
    res = CliRunner().invoke(cli, [*args, "--allow-missing-meshes"])
    assert res.exit_code == 0 and out.exists(), res.output
    assert "10 mesh file(s) not found, their shapes ignored" in res.output
    # a guided session draws its candidates through the same funnel: the same refusal, before
    # its output folder is made
    folder = tmp_path / "session"
    args = ["session", "--adapter", "kinematic", "--robot", str(away), "--support", "r_sole",
            "--torques", "all", "--no-foot-sensors", "--budget", 16, "--candidates", 200,
            "--no-view", "--out-dir", str(folder)]  # fmt: skip
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 2 and not folder.exists(), res.output
    assert "10 mesh file(s) it names are not found" in res.output, res.output
    res = CliRunner().invoke(cli, [*args, "--allow-missing-meshes"])
    assert res.exit_code == 0 and (folder / "fit.json").exists(), res.output
