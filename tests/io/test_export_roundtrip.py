"""Export that round-trips: the written file loads in MuJoCo / Pinocchio with the fit's total
mass and CoMs (compared number by number), on an MJCF humanoid split over included files, the
OP2 URDF and a public URDF humanoid; paths that resolve from the output folder; inertia
tensors that are physically valid for every method; a warning for masses far from the CAD."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest
from fitting import identify_consistent
from humanoid_mjcf_gen import write_humanoid
from mjcf_gen import mujoco_com
from oracle import PinOracle

import sescid
from sescid.io import export_mjcf, export_model, export_urdf
from sescid.io.export.inertia import MASS_WARN, mass_warnings

pytest.importorskip("mujoco")


def _valid(tensor: np.ndarray) -> bool:
    """Positive definite and a + b ≥ c for the principal moments."""
    w = np.linalg.eigvalsh(0.5 * (tensor + tensor.T))
    return bool(w[0] > 0 and w[0] + w[1] >= w[2] * (1 - 1e-12))


def _urdf_tensors(path: Path) -> dict[str, np.ndarray]:
    out = {}
    for link in ET.parse(path).getroot().findall("link"):
        el = link.find("inertial/inertia")
        mass = link.find("inertial/mass")
        if el is None or mass is None or float(mass.get("value")) == 0:
            continue
        v = {k: float(el.get(k, "0")) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        out[link.get("name")] = np.array(
            [
                [v["ixx"], v["ixy"], v["ixz"]],
                [v["ixy"], v["iyy"], v["iyz"]],
                [v["ixz"], v["iyz"], v["izz"]],
            ]
        )
    return out


# --- an MJCF humanoid with <include> and a meshdir ------------------------------------------
@pytest.fixture(scope="module")
def humanoid(tmp_path_factory):
    folder = tmp_path_factory.mktemp("humanoid")
    main = write_humanoid(folder / "src")
    robot = sescid.load_robot(main, support="r_sole")
    sim = sescid.simulate(robot, 300, noise=2e-4, seed=2)
    fit = identify_consistent(robot, sim.q, sim.cop, total_mass=robot.total_mass * 1.04)
    return robot, fit, main


def test_mjcf_with_include_loads_in_mujoco_with_the_fit(humanoid, tmp_path):
    """Written to another folder: includes resolved into one file, the mesh found through the
    rewritten meshdir; MuJoCo's total mass and CoM (support frame) are the fit's."""
    import mujoco

    robot, fit, main = humanoid
    before = {p: p.read_bytes() for p in main.parent.rglob("*") if p.is_file()}
    out = tmp_path / "elsewhere" / "humanoid_fit.xml"
    out.parent.mkdir()
    warnings = export_model(fit, out)
    text = out.read_text()
    assert "<include" not in text
    root = ET.fromstring(text)
    meshdir = root.find("compiler").get("meshdir")
    texture = root.find("asset/texture").get("file")  # no texturedir: the file itself
    assert meshdir.startswith("../") and texture.startswith("../")
    assert (out.parent / meshdir).resolve() == (main.parent / "assets").resolve()
    assert (out.parent / texture).resolve() == (main.parent / "textures" / "skin.png").resolve()
    assert "a generated humanoid: main file" in text  # a comment before the root
    assert "the robot, included by the main file" in text  # a comment of the included file
    assert text.count("<pair ") == 2
    m = mujoco.MjModel.from_xml_path(str(out))
    assert m.body_mass.sum() == pytest.approx(fit.inertials.masses.sum(), rel=1e-12)
    assert m.body_mass.sum() == pytest.approx(robot.total_mass * 1.04, rel=1e-9)
    q = sescid.simulate(robot, 40, noise=0.0, seed=9).q
    np.testing.assert_allclose(
        mujoco_com(out, "r_sole", robot.joint_names, q), fit.predict_com(q), rtol=0, atol=1e-9
    )
    back = sescid.load_robot(out, support="r_sole")
    np.testing.assert_allclose(back.masses, fit.inertials.masses, rtol=1e-12)
    for b in range(1, m.nbody):  # every compiled inertia physically valid
        if m.body_mass[b] > 0:
            i = np.sort(m.body_inertia[b])
            assert i[0] > 0 and i[0] + i[1] >= i[2] * (1 - 1e-12)
    assert all("of the CAD's" in w for w in warnings), warnings
    assert {p: p.read_bytes() for p in main.parent.rglob("*") if p.is_file()} == before


def test_mjcf_export_beside_the_source_keeps_its_paths(humanoid, tmp_path):
    """In the source folder, asset paths are left as written (includes still resolved)."""
    import mujoco

    robot, fit, main = humanoid
    out = main.parent / "humanoid_fit.xml"
    try:
        export_mjcf(fit, out)
        text = out.read_text()
        assert 'meshdir="assets"' in text and "<include" not in text
        assert 'file="textures/skin.png"' in text
        assert mujoco.MjModel.from_xml_path(str(out)).body_mass.sum() == pytest.approx(
            fit.inertials.masses.sum(), rel=1e-12
        )
    finally:
        out.unlink(missing_ok=True)


def test_pair_collisions_are_collision_geometry(humanoid):
    """Feet that collide only through <contact><pair> are the robot's collision geometry."""
    robot, _, _ = humanoid
    roles = {(s.link, s.role) for s in robot.model.shapes}
    collide = sorted(link for link, role in roles if role == "collision")
    assert collide == ["l_foot", "r_foot"]


def test_moving_body_left_massless_is_written_with_a_small_mass(humanoid, tmp_path):
    """MuJoCo refuses a moving body without mass: the export writes 1 mg and says so."""
    import mujoco

    robot, fit, _ = humanoid
    k = robot.body_names.index("l_forearm")
    masses = fit.inertials.masses.copy()
    masses[k] = 0.0
    zero = dataclasses.replace(fit, inertials=dataclasses.replace(fit.inertials, masses=masses))
    out = tmp_path / "zero.xml"
    warnings = export_mjcf(zero, out)
    assert any("l_forearm: the fit leaves it 0 kg; written as 1e-06 kg" in w for w in warnings)
    m = mujoco.MjModel.from_xml_path(str(out))
    assert m.body_mass[m.body("l_forearm").id] == 1e-6


# --- URDF -----------------------------------------------------------------------------------
def test_op2_every_method_exports_valid_inertias_pinocchio_agrees(op2, tmp_path):
    """ls, map and consistent fits (the first two through the consistent step): every written
    tensor is physically valid and Pinocchio's total mass and CoM are the fit's."""
    sim = sescid.simulate(op2, 200, noise=0.00493, seed=4)
    q = sescid.simulate(op2, 15, noise=0.0, seed=8).q
    for method in ("ls", "map", "consistent"):
        fit = sescid.identify(op2, sim.q, sim.cop, method=method)
        if fit.inertials is None:
            fit = sescid.to_consistent(fit)
        out = tmp_path / method / "op2.urdf"
        out.parent.mkdir()
        export_urdf(fit, out)
        tensors = _urdf_tensors(out)
        assert len(tensors) >= len(op2.body_names)
        assert all(_valid(t) for t in tensors.values()), method
        oracle = PinOracle(out, "r_sole", op2.joint_names)
        assert oracle.total_mass() == pytest.approx(fit.inertials.masses.sum(), rel=1e-12)
        np.testing.assert_allclose(oracle.com(q), fit.predict_com(q), rtol=0, atol=1e-9)


def test_icub_exports_to_another_folder_and_loads_in_pinocchio(icub_path, tmp_path):
    """A public URDF humanoid (example-robot-data's iCub): Pinocchio reads the export with the
    fit's total mass and CoMs; package:// meshes are left alone; every tensor is valid."""
    robot = sescid.load_robot(icub_path, support="r_sole")
    sim = sescid.simulate(robot, 300, noise=0.002, seed=1)
    fit = identify_consistent(robot, sim.q, sim.cop, total_mass=robot.total_mass * 0.97)
    out = tmp_path / "icub_fit.urdf"
    warnings = export_urdf(fit, out, repair_inertia=True)
    assert all(_valid(t) for t in _urdf_tensors(out).values())
    src_names = [m.get("filename") for m in ET.parse(icub_path).getroot().iter("mesh")]
    out_names = [m.get("filename") for m in ET.parse(out).getroot().iter("mesh")]
    assert out_names == src_names and src_names[0].startswith("package://")
    oracle = PinOracle(out, "r_sole", robot.joint_names)
    assert oracle.total_mass() == pytest.approx(robot.total_mass * 0.97, rel=1e-9)
    q = sescid.simulate(robot, 15, noise=0.0, seed=3).q
    np.testing.assert_allclose(oracle.com(q), fit.predict_com(q), rtol=0, atol=1e-9)
    assert all("of the CAD's" in w or "inertia" in w for w in warnings)


BAD_INERTIA_URDF = """<?xml version="1.0"?>
<robot name="bad" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <!-- a robot whose CAD inertias are not all physical -->
  <link name="base">
    <inertial><origin xyz="0 0 0.1" rpy="0 0 0"/><mass value="2.0"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.005"/></inertial>
    <visual><geometry><mesh filename="meshes/base.stl" scale="1 1 1"/></geometry></visual>
    <visual><geometry><mesh filename="package://bad_description/meshes/b.stl"/></geometry></visual>
    <visual><geometry><mesh filename="file://meshes/base.stl"/></geometry></visual>
  </link>
  <link name="arm">
    <inertial><origin xyz="0.1 0 -0.05"/><mass value="0.4"/>
      <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>
  </link>
  <link name="hand"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="wrist" type="revolute"><parent link="arm"/><child link="hand"/>
    <origin xyz="0.2 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
</robot>
"""


@pytest.fixture(scope="module")
def bad(tmp_path_factory):
    folder = tmp_path_factory.mktemp("bad")
    (folder / "src" / "meshes").mkdir(parents=True)
    (folder / "src" / "meshes" / "base.stl").write_text("solid x\nendsolid x\n")
    (folder / "src" / "bad.urdf").write_text(BAD_INERTIA_URDF)
    robot = sescid.load_robot(folder / "src" / "bad.urdf", support="base")
    sim = sescid.simulate(robot, 200, noise=1e-4, seed=1)
    fit = identify_consistent(robot, sim.q, sim.cop, mass_floor=0.05)
    return folder, robot, fit


def test_urdf_invalid_cad_inertias_refused_or_repaired_with_a_warning(bad, tmp_path):
    """A triangle-violating tensor and a zero tensor with mass: refused by name (nothing
    written) unless repaired; repaired, all written valid (MuJoCo, which checks, loads the
    export) with a warning naming each; the massless link that gets mass gets a sphere's."""
    import mujoco

    folder, robot, fit = bad
    out = tmp_path / "out.urdf"
    with pytest.raises(sescid.ModelError, match=r"2 link\(s\).*base: 2 kg, triangle.*arm: 0.4 kg"):
        export_urdf(fit, out)
    assert not out.exists()
    warnings = export_urdf(fit, out, repair_inertia=True)
    assert any(w.startswith("link base: inertia repaired") for w in warnings)
    assert any(w.startswith("link arm: inertia repaired") for w in warnings)
    tensors = _urdf_tensors(out)
    assert set(tensors) == {"base", "arm", "hand"} and all(_valid(t) for t in tensors.values())
    shutil.copy(out, folder / "src" / "check.urdf")  # MuJoCo looks for the meshes beside it
    m = mujoco.MjModel.from_xml_path(str(folder / "src" / "check.urdf"))
    for name in ("arm", "hand"):  # MuJoCo welds the root link to the world
        want = fit.inertials.masses[robot.body_names.index(name)]
        assert m.body(name).mass[0] == pytest.approx(want, rel=1e-12)


def test_urdf_relative_meshes_resolve_from_the_output(bad, tmp_path):
    """Another folder: the relative mesh path is rewritten to the same file; package:// stays;
    the xacro namespace prefix and the comments survive."""
    folder, _, fit = bad
    out = tmp_path / "deep" / "out.urdf"
    out.parent.mkdir()
    export_urdf(fit, out, repair_inertia=True)
    names = [m.get("filename") for m in ET.parse(out).getroot().iter("mesh")]
    assert (out.parent / names[0]).resolve() == (folder / "src" / "meshes" / "base.stl").resolve()
    assert names[1] == "package://bad_description/meshes/b.stl"
    assert names[2] == "file://" + names[0]
    text = out.read_text()
    assert 'xmlns:xacro="http://www.ros.org/wiki/xacro"' in text
    assert "<!-- a robot whose CAD inertias are not all physical -->" in text
    same = folder / "src" / "same.urdf"
    export_urdf(fit, same, repair_inertia=True)
    assert [m.get("filename") for m in ET.parse(same).getroot().iter("mesh")][
        0
    ] == "meshes/base.stl"


def test_mass_far_from_the_cad_is_reported(op2):
    """Beyond ±50 % of a body's CAD mass: one line naming the body and the change."""
    masses = np.array([b.mass for b in op2.model.bodies])
    assert mass_warnings(op2.model, masses) == []
    k = op2.body_names.index("MP_HEAD")
    masses[k] *= 3.34
    masses[k + 1 if k + 1 < len(masses) else 0] *= 1 + MASS_WARN * 0.99
    (line,) = mass_warnings(op2.model, masses)
    assert line.startswith("body MP_HEAD: exported mass") and "+234 %" in line


def test_cli_export_prints_the_warnings(op2, tmp_path, write_dataset):
    from click.testing import CliRunner

    from sescid.cli import cli

    sim = sescid.simulate(op2, 120, noise=0.00493, seed=6)
    data = write_dataset(tmp_path / "d.csv", sim.q, sim.cop)
    runner = CliRunner()
    args = ["identify", str(data), "--method", "consistent", "--allow-outside-limits"]
    res = runner.invoke(cli, [*args, "--out", str(tmp_path / "fit.json")])
    assert res.exit_code == 0, res.output
    out = tmp_path / "x" / "op2.urdf"
    out.parent.mkdir()
    res = runner.invoke(cli, ["export", str(tmp_path / "fit.json"), "--out", str(out)])
    assert res.exit_code == 0, res.output
    fit = sescid.load_fit(tmp_path / "fit.json")
    n = len(mass_warnings(op2.model, fit.inertials.masses))
    assert res.output.count("sescid: warning: body ") == n


def test_export_never_overwrites_a_file_the_model_reads(humanoid, tmp_path):
    """`export --out` naming the model, a file it <include>s or a mesh/texture it reads is
    refused in one line, every input untouched (it used to overwrite parts/robot.xml)."""
    from click.testing import CliRunner

    from sescid.cli import cli
    from sescid.io import model_files

    robot, fit, main = humanoid
    names = {p.relative_to(main.parent).as_posix() for p in model_files(main)}
    assert {"humanoid.xml", "parts/assets.xml", "parts/robot.xml", "assets/tetra.obj",
            "textures/skin.png"} <= names  # fmt: skip
    fit_file = tmp_path / "fit.json"
    sescid.save_fit(fit, fit_file)
    before = {p: p.read_bytes() for p in main.parent.rglob("*") if p.is_file()}
    for name in ("parts/robot.xml", "parts/assets.xml", "assets/tetra.obj", "humanoid.xml"):
        res = CliRunner().invoke(cli, ["export", str(fit_file), "--out", str(main.parent / name)])
        assert res.exit_code == 2 and res.output.count("\n") == 1, res.output
        assert "also an input" in res.output, res.output
    assert {p: p.read_bytes() for p in main.parent.rglob("*") if p.is_file()} == before
