"""URDF export: round trip through sescid and Pinocchio, untouched elements, merged links, CLI."""

from __future__ import annotations

from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest
from click.testing import CliRunner
from fitting import identify_consistent
from oracle import PinOracle

import sescid
from sescid.cli import cli
from sescid.errors import SescidError
from sescid.io.export.urdf import export_urdf

TOTAL = 2.97  # kg, a "weighed" mass 45 g above the URDF's


@pytest.fixture(scope="module")
def op2():
    return sescid.load_robot("op2")


@pytest.fixture(scope="module")
def data_csv(tmp_path_factory, op2):
    path = tmp_path_factory.mktemp("data") / "sim.csv"
    result = CliRunner().invoke(cli, ["simulate", "--count", "300", "--out", str(path)])
    assert result.exit_code == 0, result.output
    return path


@pytest.fixture(scope="module")
def exported(tmp_path_factory, op2):
    """A consistent OP2 fit (saved and reloaded) and its exported URDF."""
    sim = sescid.simulate(op2, 500, noise=0.00493, seed=3)
    fit = identify_consistent(op2, sim.q, sim.cop, total_mass=TOTAL, symmetric=True)
    folder = tmp_path_factory.mktemp("export")
    sescid.save_fit(fit, folder / "fit.json")
    fit = sescid.load_fit(folder / "fit.json")
    warnings = export_urdf(fit, folder / "op2_identified.urdf")
    # only bodies whose mass moved beyond ±50 % of the CAD's (the OP2's light links do)
    assert all(" % of the CAD's " in w for w in warnings)
    return fit, folder / "op2_identified.urdf"


@pytest.fixture(scope="module")
def poses(op2):
    rng = np.random.default_rng(7)
    return rng.uniform(-np.pi / 2, np.pi / 2, size=(2000, op2.nq))


def test_reloaded_urdf_reproduces_the_fit_cop(exported, poses):
    fit, path = exported
    robot = sescid.load_robot(path, support="r_sole")
    assert np.max(np.abs(robot.cop(poses) - fit.predict_cop(poses))) < 1e-9
    assert robot.total_mass == pytest.approx(TOTAL, abs=1e-12)


def test_pinocchio_loads_the_export_with_the_fit_masses(exported, op2, poses):
    import pinocchio as pin

    fit, path = exported
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    assert pin.computeTotalMass(model) == pytest.approx(TOTAL, abs=1e-12)
    oracle = PinOracle(path, "r_sole", op2.joint_names)
    np.testing.assert_allclose(oracle.com(poses[:20]), fit.predict_com(poses[:20]), atol=1e-9)


def _without_inertials(path: Path) -> str:
    """The file's canonical XML with inertials and sescid's note left out."""
    builder = ET.TreeBuilder(insert_comments=True)
    parser = ET.XMLParser(target=builder)
    parser.feed(Path(path).read_bytes())
    root = parser.close()
    for parent in list(root.iter()):
        for el in list(parent):
            if el.tag == "inertial" or (
                el.tag is ET.Comment and "identified by sescid" in (el.text or "")
            ):
                parent.remove(el)
    return ET.canonicalize(ET.tostring(root, encoding="unicode"), strip_text=True)


def test_only_inertials_change(exported, op2):
    _, path = exported
    assert _without_inertials(path) == _without_inertials(op2.model_path)


def test_inertia_about_the_com_is_cads_and_keeps_its_orientation(exported, op2):
    """The mass changes, the tensor about the CoM stays CAD's (the log-det closest consistent
    one with the mass and first moment fixed), on the same axes."""
    fit, path = exported
    src = ET.parse(op2.model_path).getroot()
    out = ET.parse(path).getroot()
    old = src.find("link[@name='MP_HEAD']/inertial")
    new = out.find("link[@name='MP_HEAD']/inertial")
    ratio = float(new.find("mass").get("value")) / float(old.find("mass").get("value"))
    assert ratio == pytest.approx(
        fit.inertials.masses[fit.robot.body_names.index("MP_HEAD")] / 0.158042, rel=1e-12
    )
    assert abs(ratio - 1) > 1e-3
    for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
        assert float(new.find("inertia").get(key)) == float(old.find("inertia").get(key))
    assert new.find("origin").get("rpy") == old.find("origin").get("rpy")


MERGED_URDF = """<?xml version="1.0"?>
<robot name="merged">
  <link name="base">
    <inertial><origin xyz="0 0 0.1" rpy="0 0 0"/><mass value="2.0"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.03"/></inertial>
  </link>
  <link name="battery">
    <inertial><origin xyz="0.02 0 0" rpy="0 0 0.3"/><mass value="0.5"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
  </link>
  <link name="arm">
    <inertial><origin xyz="0.1 0 -0.05"/><mass value="0.4"/>
      <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.002"/></inertial>
  </link>
  <link name="hand"/>
  <joint name="fix" type="fixed"><parent link="base"/><child link="battery"/>
    <origin xyz="-0.05 0 0.2" rpy="0 0 1.5707963267948966"/></joint>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="wrist" type="revolute"><parent link="arm"/><child link="hand"/>
    <origin xyz="0.2 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
</robot>
"""


@pytest.fixture(scope="module")
def merged(tmp_path_factory):
    """A consistent fit of a robot whose base merges two massive links and whose hand is
    massless in the URDF (the floor gives it mass), and its export."""
    folder = tmp_path_factory.mktemp("merged")
    (folder / "merged.urdf").write_text(MERGED_URDF)
    robot = sescid.load_robot(folder / "merged.urdf", support="base")
    sim = sescid.simulate(robot, 200, noise=1e-4, seed=1)
    fit = identify_consistent(robot, sim.q, sim.cop, mass_floor=0.05)
    export_urdf(fit, folder / "out.urdf")
    return robot, fit, folder / "out.urdf"


def _link(path, name):
    el = ET.parse(path).getroot().find(f"link[@name='{name}']/inertial")
    xyz = np.array([float(v) for v in el.find("origin").get("xyz").split()])
    return float(el.find("mass").get("value")), xyz


def test_merged_links_keep_their_mass_ratio_and_layout(merged):
    robot, fit, path = merged
    (m_base, c_base), (m_bat, c_bat) = _link(path, "base"), _link(path, "battery")
    assert m_bat / m_base == pytest.approx(0.5 / 2.0, rel=1e-12)
    # both CoMs moved by one body-frame offset: the base link is the body frame; the battery's
    # frame is turned 90° about z, so its link-frame shift is that offset turned back
    shift = c_base - [0, 0, 0.1]
    rot = robot.model.link_frames["battery"][1][:3, :3]
    np.testing.assert_allclose(rot @ (c_bat - [0.02, 0, 0]), shift, atol=1e-15)
    assert m_base + m_bat == pytest.approx(
        fit.inertials.masses[fit.robot.body_names.index("base")], rel=1e-12
    )


def test_massless_body_gets_an_inertial_on_its_main_link(merged):
    _, fit, path = merged
    mass, _ = _link(path, "hand")
    assert mass == pytest.approx(
        fit.inertials.masses[fit.robot.body_names.index("hand")], rel=1e-12
    )
    assert mass >= 0.05 - 1e-12


def test_merged_export_round_trip(merged):
    robot, fit, path = merged
    again = sescid.load_robot(path, support="base")
    q = sescid.simulate(robot, 500, range_deg=90, noise=0.0, seed=4).q
    assert np.max(np.abs(again.com(q) - fit.predict_com(q))) < 1e-12


def test_export_of_a_fit_without_masses_is_refused(op2, tmp_path):
    sim = sescid.simulate(op2, 100, noise=0.001, seed=2)
    with pytest.raises(SescidError, match="no body masses"):
        export_urdf(sescid.identify(op2, sim.q, sim.cop), tmp_path / "x.urdf")
    assert not (tmp_path / "x.urdf").exists()


def test_export_detects_a_urdf_changed_since_the_fit(tmp_path):
    (tmp_path / "m.urdf").write_text(MERGED_URDF)
    robot = sescid.load_robot(tmp_path / "m.urdf", support="base")
    sim = sescid.simulate(robot, 100, noise=1e-4, seed=1)
    fit = identify_consistent(robot, sim.q, sim.cop)
    (tmp_path / "m.urdf").write_text(MERGED_URDF.replace('"0.4"', '"0.45"'))
    with pytest.raises(SescidError, match="URDF changed"):
        export_urdf(fit, tmp_path / "out.urdf")
    assert not (tmp_path / "out.urdf").exists()


# --- CLI -----------------------------------------------------------------------------------
def test_cli_identify_consistent_writes_masses(data_csv, tmp_path):
    out = tmp_path / "fit.json"
    args = ["identify", str(data_csv), "--method", "consistent", "--total-mass", "2.97"]
    result = CliRunner().invoke(cli, [*args, "--symmetric", "--out", str(out)])
    assert result.exit_code == 0, result.output
    fit = sescid.load_fit(out)
    assert fit.method == "consistent"
    total = float(fit.inertials.masses.sum())
    assert total == pytest.approx(2.97, abs=1e-9)


@pytest.mark.parametrize(
    "extra",
    [["--total-mass", "-1"], ["--mass-floor", "1"], ["--cad-std", "-0.1"]],
)
def test_cli_identify_consistent_bad_options_exit_2_without_output(data_csv, tmp_path, extra):
    out = tmp_path / "fit.json"
    args = ["identify", str(data_csv), "--method", "consistent", *extra, "--out", str(out)]
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 2
    assert result.output.startswith("sescid: error: ")
    assert not out.exists()


def test_cli_export_of_least_squares_runs_the_consistent_step(data_csv, tmp_path):
    runner = CliRunner()
    fit_json, urdf = tmp_path / "ls.json", tmp_path / "op2.urdf"
    assert runner.invoke(cli, ["identify", str(data_csv), "--out", str(fit_json)]).exit_code == 0
    result = runner.invoke(cli, ["export", str(fit_json), "--out", str(urdf), "--total-mass", "3"])
    assert result.exit_code == 0, result.output
    assert "running the consistent step" in result.output
    assert sescid.load_robot(urdf, support="r_sole").total_mass == pytest.approx(3.0, abs=1e-12)


@pytest.mark.parametrize(
    "case", ["missing fit", "not a fit", "no folder", "mass on consistent", "floor on consistent"]
)
def test_cli_export_errors_exit_2_without_output(exported, tmp_path, case):
    fit_json = tmp_path / "fit.json"
    out = tmp_path / "out.urdf"
    opts = []
    if case == "not a fit":
        fit_json.write_text("{}")
    elif case == "no folder":
        sescid.save_fit(exported[0], fit_json)
        out = tmp_path / "nowhere" / "out.urdf"
    elif case.endswith("on consistent"):  # consistent-step options on a fit that has masses
        sescid.save_fit(exported[0], fit_json)
        opts = ["--total-mass", "3"] if case.startswith("mass") else ["--mass-floor", "0.01"]
    result = CliRunner().invoke(cli, ["export", str(fit_json), "--out", str(out), *opts])
    assert result.exit_code == 2
    assert "sescid: error: " in result.output
    assert not out.exists()
    assert not list(tmp_path.glob(".out*"))  # no temporary file left behind
