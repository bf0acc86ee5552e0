"""Export on bad input: an output that is an input, a destination that cannot be written, a
model file changed since the fit (masses differ, same structure), asset files that do not
exist — one line each, nothing half-written; and the same fit gives the same bytes."""

from __future__ import annotations

import shutil
import tempfile

import numpy as np
import pytest
from click.testing import CliRunner
from humanoid_mjcf_gen import write_humanoid

import sescid
from sescid.cli import cli
from sescid.errors import DataError

pytest.importorskip("mujoco")


@pytest.fixture(scope="module")
def humanoid(tmp_path_factory):
    """An MJCF humanoid (includes, a meshdir) and its default fit, saved."""
    folder = tmp_path_factory.mktemp("hum")
    main = write_humanoid(folder / "src")
    robot = sescid.load_robot(main, support="r_sole")
    sim = sescid.simulate(robot, 300, seed=2, noise=1e-3)
    fit = sescid.identify(robot, sim.q, sim.cop)
    sescid.save_fit(fit, folder / "fit.json")
    return folder, main, fit


def _export(*args):
    return CliRunner().invoke(cli, ["export", *map(str, args)])


def test_output_that_is_an_input_is_refused(humanoid, tmp_path):
    folder, main, _ = humanoid
    before = main.read_bytes()
    for target in (main, folder / "fit.json", main.parent / "parts" / "robot.xml"):
        res = _export(folder / "fit.json", "--out", target, "--force")
        assert res.exit_code == 2 and "this output is also an input" in res.output
        assert len(res.output.strip().splitlines()) == 1
    assert main.read_bytes() == before


def test_unwritable_destination_one_line_nothing_left(humanoid, tmp_path, monkeypatch):
    folder, _, _ = humanoid
    res = _export(folder / "fit.json", "--out", tmp_path / "no_such" / "x.xml")
    assert res.exit_code == 2 and "does not exist" in res.output
    out = tmp_path / "ro"
    out.mkdir()

    def refuse(*a, **k):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    with pytest.raises(DataError, match="cannot write"):
        sescid.export_model(sescid.to_consistent(humanoid[2]), out / "x.xml")
    assert not list(out.iterdir())


def test_model_changed_since_the_fit_is_said(humanoid, tmp_path):
    """The fit's model file with other masses (same bodies): the export says so (a warning
    naming both total masses), then writes."""
    folder, main, fit = humanoid
    copy = tmp_path / "src"
    shutil.copytree(main.parent, copy)
    robot_xml = copy / "parts" / "robot.xml"
    text = robot_xml.read_text()
    import re

    first = re.search(r'mass="([0-9.]+)"', text)
    assert first is not None
    robot_xml.write_text(text.replace(first.group(0), 'mass="9.5"', 1))
    data = (folder / "fit.json").read_text().replace(str(main), str(copy / main.name))
    (tmp_path / "fit.json").write_text(data)
    res = _export(tmp_path / "fit.json", "--out", tmp_path / "out.xml")
    assert res.exit_code == 0, res.output
    assert "the model changed since this fit" in res.output
    assert f"({fit.robot.total_mass:.3g} kg at fit time)" in res.output
    assert (tmp_path / "out.xml").is_file()


SMALL_URDF = """<robot name="small">
  <link name="foot">
    <inertial><origin xyz="0 0 0.02"/><mass value="1.0"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <visual><geometry><mesh filename="meshes/not_there.stl"/></geometry></visual>
  </link>
  <link name="leg">
    <inertial><origin xyz="0.01 0 0.2"/><mass value="2.0"/>
      <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.01"/></inertial>
  </link>
  <link name="arm">
    <inertial><origin xyz="0.1 0 0"/><mass value="0.5"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.002"/></inertial>
  </link>
  <joint name="ankle" type="revolute"><parent link="foot"/><child link="leg"/>
    <origin xyz="0 0 0.05"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="shoulder" type="revolute"><parent link="leg"/><child link="arm"/>
    <origin xyz="0 0 0.4"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""


def test_missing_assets_are_said(tmp_path):
    """Asset files the model names that do not exist: one warning line (the export would not
    load in a simulator either), not silence."""
    (tmp_path / "src").mkdir()
    urdf = tmp_path / "src" / "small.urdf"
    urdf.write_text(SMALL_URDF)
    robot = sescid.load_robot(urdf, support="foot")
    sim = sescid.simulate(robot, 100, seed=2, noise=1e-4)
    fit = sescid.to_consistent(sescid.identify(robot, sim.q, sim.cop))
    warnings = sescid.export_model(fit, tmp_path / "elsewhere.urdf")
    (line,) = [w for w in warnings if "asset file(s)" in w]
    assert line.startswith("1 asset file(s) that small.urdf names do not exist")
    assert "not_there.stl" in line
    (tmp_path / "src" / "meshes").mkdir()
    (tmp_path / "src" / "meshes" / "not_there.stl").write_text("solid x\nendsolid x\n")
    warnings = sescid.export_model(fit, tmp_path / "elsewhere.urdf")
    assert not [w for w in warnings if "asset file(s)" in w]


@pytest.mark.parametrize("name", ["a.xml"])
def test_same_fit_same_bytes(humanoid, tmp_path, name):
    fit = sescid.to_consistent(humanoid[2])
    again = sescid.to_consistent(humanoid[2])
    np.testing.assert_array_equal(fit.inertials.masses, again.inertials.masses)
    sescid.export_model(fit, tmp_path / name)
    sescid.export_model(again, tmp_path / ("b" + name))
    assert (tmp_path / name).read_bytes() == (tmp_path / ("b" + name)).read_bytes()
