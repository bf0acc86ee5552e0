"""Export of the default (MAP) fit predicts exactly what the fit predicts, checked by
independent tools: Pinocchio (CoM, holding torques from computeGeneralizedGravity) on TALOS
(example-robot-data URDF), MuJoCo (CoM) on an MJCF humanoid; every written inertia is CAD's
about the CoM when CAD's is consistent, repaired (smallest change) only when asked."""

from __future__ import annotations

import math
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest
from mjcf_gen import mujoco_com
from oracle import PinOracle, PinStatics

import sescid
from sescid.errors import ModelError
from sescid.estimation.result.validation import perturbed_sesc
from sescid.model import inertia_problems, repair_inertia
from sescid.model.inertia import physical
from sescid.robots import example_path

pin = pytest.importorskip("pinocchio")
TALOS = (
    Path(pin.__file__).parents[4]
    / "share/example-robot-data/robots/talos_data/robots/talos_reduced.urdf"
)
HUMANOID = example_path("humanoid")


def _fit(robot, seed=1, fraction=0.04, noise=0.00493):
    """The default fit of CoP data from a robot that differs from the model, made consistent."""
    truth = perturbed_sesc(robot, fraction, seed=seed)
    sim = sescid.simulate(robot, 300, r_true=truth, seed=2, stable=True, noise=noise)
    fit = sescid.identify(robot, sim.q, sim.cop)
    assert fit.method == "map"
    return fit, sescid.to_consistent(fit)


def _poses(robot, n=100):
    lo, hi = robot.joint_limits.T
    lo, hi = np.maximum(lo, -1.5), np.minimum(hi, 1.5)
    return np.random.default_rng(7).uniform(lo, hi, (n, robot.nq))


def _tensors(path: Path) -> dict[str, tuple[float, np.ndarray]]:
    out = {}
    for link in ET.parse(path).getroot().findall("link"):
        el, mass = link.find("inertial/inertia"), link.find("inertial/mass")
        if el is None or mass is None:
            continue
        v = {k: float(el.get(k, "0")) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        t = np.array(
            [
                [v["ixx"], v["ixy"], v["ixz"]],
                [v["ixy"], v["iyy"], v["iyz"]],
                [v["ixz"], v["iyz"], v["izz"]],
            ]
        )
        out[link.get("name")] = (float(mass.get("value")), t)
    return out


@pytest.fixture(scope="module")
def talos():
    if not TALOS.is_file():
        pytest.skip("example-robot-data's TALOS not installed")
    robot = sescid.load_robot(TALOS, support="right_sole_link")
    fit, cons = _fit(robot)
    return robot, fit, cons


def test_talos_export_predicts_what_the_map_fit_predicts(talos, tmp_path):
    """CoM at 100 random poses (Pinocchio) = fit.predict_com to 1e-9 m; Pinocchio's holding
    torques (computeGeneralizedGravity) = the fit's torque predictions to 1e-9 relative."""
    robot, fit, cons = talos
    out = tmp_path / "talos_fit.urdf"
    sescid.export_model(cons, out, repair_inertia=True)
    q = _poses(robot)
    com = PinOracle(out, "right_sole_link", robot.joint_names).com(q)
    assert np.abs(com - fit.predict_com(q)).max() < 1e-9
    cad = PinOracle(TALOS, "right_sole_link", robot.joint_names).com(q)
    assert np.abs(cad - fit.predict_com(q)).max() > 1e-4  # the fit is not the CAD model
    tau = PinStatics(out, "right_sole_link", robot.joint_names, fit.gravity_accel).torques(q[:20])
    want = fit.predict_torque(q[:20])
    assert np.abs(tau - want).max() <= 1e-9 * np.abs(want).max()


def test_talos_inertias_are_cads_about_the_com_or_repaired(talos, tmp_path):
    """Each body's inertia about its CoM (Pinocchio's per-joint inertia: the links a fixed
    joint merges, summed) is CAD's though the masses moved; the five massive point masses are
    refused without --repair-inertia and repaired with it (a 1 cm sphere, each reported); a
    body whose tensor could not be kept would be named in a warning."""
    robot, _, cons = talos
    problems = inertia_problems(robot.model)
    assert sorted(p.link for p in problems) == sorted(
        ["rgbd_optical_frame", "wrist_right_ft_link", "wrist_right_ft_tool_link"]
        + ["wrist_left_ft_link", "wrist_left_ft_tool_link"]
    )
    assert all(p.kind == "point mass" for p in problems)
    out = tmp_path / "t.urdf"
    with pytest.raises(ModelError, match="5 link.*--repair-inertia"):
        sescid.export_model(cons, out)
    assert not out.exists()
    warnings = sescid.export_model(cons, out, repair_inertia=True)
    assert sum("inertia repaired" in w for w in warnings) == 5
    named = {w.split(":")[0].removeprefix("link ") for w in warnings if w.startswith("link ")}
    after = _tensors(out)
    for p in problems:  # a 1 cm sphere's, then (merged bodies) its share of the body's
        m1, t1 = after[p.link]
        assert np.linalg.eigvalsh(t1)[0] > 0 and physical(t1)[0]
    a = pin.buildModelFromUrdf(str(TALOS), pin.JointModelFreeFlyer())
    b = pin.buildModelFromUrdf(str(out), pin.JointModelFreeFlyer())
    kept = moved = 0
    for j in range(1, a.njoints):
        links = {f.name for f in a.frames if f.parentJoint == j and f.type == pin.FrameType.BODY}
        i0, i1 = a.inertias[j], b.inertias[j]
        assert np.linalg.eigvalsh(i1.inertia)[0] > 0
        if links & named:
            continue
        np.testing.assert_allclose(i1.inertia, i0.inertia, rtol=1e-9, atol=1e-15)
        kept += 1
        moved += abs(i1.mass / i0.mass - 1) > 1e-3
    assert kept >= a.njoints - 5 and moved > 5  # the masses moved, the tensors stayed


def test_cli_names_the_repaired_tensors_in_one_line(talos, tmp_path):
    """`export --repair-inertia` of TALOS: its five repaired tensors in one warning line (a
    line each before: dozens on a robot with many sensor frames), with the count and the first
    links' moments before → after."""
    from cli_run import outcome

    _, _, cons = talos
    fit = tmp_path / "fit.json"
    sescid.save_fit(cons, fit)
    code, out = outcome("export", fit, "--repair-inertia", "--out", tmp_path / "t.urdf")
    assert code == 0, out
    lines = [x for x in out.splitlines() if "inertia" in x and "repaired" in x]
    assert len(lines) == 1, out
    assert lines[0].startswith("sescid: warning: 5 links' inertia tensors repaired"), lines
    assert "rgbd_optical_frame (0, 0, 0 → 3.8e-07, 3.8e-07, 3.8e-07)" in lines[0]  # 10 mm sphere
    assert "(and 2 more; each in the file written)" in lines[0]


def test_repair_is_the_smallest_change_and_leaves_consistent_tensors_alone():
    """Σ = ½ tr(I)·1 − I clipped at zero: a triangle-breaking tensor becomes the nearest
    consistent one (Σ's negative eigenvalue → 0, the others unchanged); consistent untouched."""
    rng = np.random.default_rng(3)
    rot, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    bad = rot @ np.diag([0.1, 0.2, 0.5]) @ rot.T  # 0.5 > 0.1 + 0.2
    fixed, changed = repair_inertia(bad)
    assert changed and physical(fixed)[0]
    sig_bad = np.linalg.eigvalsh(0.5 * np.trace(bad) * np.eye(3) - bad)
    sig_fix = np.linalg.eigvalsh(0.5 * np.trace(fixed) * np.eye(3) - fixed)
    np.testing.assert_allclose(sig_fix, np.maximum(sig_bad, 0), atol=1e-15)
    good = rot @ np.diag([0.2, 0.3, 0.4]) @ rot.T
    same, changed = repair_inertia(good)
    assert not changed and np.array_equal(same, 0.5 * (good + good.T))
    assert not repair_inertia(np.zeros((3, 3)))[1]  # massless: nothing to repair


def test_mjcf_export_predicts_what_the_map_fit_predicts(tmp_path):
    """MuJoCo's CoM of the exported MJCF at 100 random poses = fit.predict_com to 1e-9 m; the
    explicit inertials' tensors are CAD's."""
    pytest.importorskip("mujoco")
    robot = sescid.load_robot(HUMANOID, support="r_sole")
    fit, cons = _fit(robot, seed=4, fraction=0.15, noise=1e-3)
    out = tmp_path / "humanoid_fit.xml"
    sescid.export_model(cons, out)
    q = _poses(robot)
    com = mujoco_com(out, "r_sole", robot.joint_names, q)
    assert np.abs(com - fit.predict_com(q)).max() < 1e-9
    cad = mujoco_com(HUMANOID, "r_sole", robot.joint_names, q)
    assert np.abs(cad - fit.predict_com(q)).max() > 1e-4
    import mujoco

    m0 = mujoco.MjModel.from_xml_path(str(HUMANOID))
    m1 = mujoco.MjModel.from_xml_path(str(out))
    np.testing.assert_allclose(m1.body_inertia, m0.body_inertia, rtol=1e-12, atol=1e-15)
    assert not np.allclose(m1.body_mass, m0.body_mass)


def test_map_masses_stay_within_the_fits_uncertainty(talos):
    """No body mass beyond 3 prior standard deviations of CAD's; a body held there is named."""
    robot, fit, cons = talos
    tau = fit.map.prior_scale
    m_cad = robot.masses
    big = m_cad.sum()
    m_bar = m_cad + big / (10 * m_cad.size)
    z = (cons.inertials.masses - m_cad) / (tau * m_bar)
    assert np.abs(z).max() <= 3 * (1 + 1e-6)
    held = [robot.body_names[j] for j in np.flatnonzero(np.abs(z) > 3 * (1 - 1e-6))]
    for name in held:
        assert any(n.startswith(name + ":") for n in cons.inertials.notes)
    assert cons.inertials.exact and math.isfinite(cons.rms)


BAD_URDF = """<robot name="bad">
  <link name="foot">
    <inertial><origin xyz="0 0 0.02"/><mass value="1.0"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.005"/></inertial>
  </link>
  <link name="leg">
    <inertial><origin xyz="0.01 0 0.2"/><mass value="2.0"/>
      <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.01"/></inertial>
  </link>
  <link name="hand">
    <inertial><origin xyz="0.1 0 0"/><mass value="0.5"/>
      <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>
  </link>
  <joint name="ankle" type="revolute"><parent link="foot"/><child link="leg"/>
    <origin xyz="0 0 0.05"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="wrist" type="revolute"><parent link="leg"/><child link="hand"/>
    <origin xyz="0 0 0.4"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""


def test_info_names_every_inconsistent_tensor_by_how_much(tmp_path):
    """`sescid info`: a triangle-breaking tensor with its principal moments and Σ's deficit,
    a massive zero tensor as a point mass; a model without any says so."""
    from click.testing import CliRunner

    from sescid.cli import cli

    path = tmp_path / "bad.urdf"
    path.write_text(BAD_URDF)
    res = CliRunner().invoke(cli, ["info", "--robot", str(path), "--support", "foot"])
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    at = next(i for i, x in enumerate(lines) if x.startswith("inertia tensors: 2 link(s)"))
    assert lines[at + 1] == (
        "  foot: 1 kg, triangle inequality broken: 0.005 > 0.001 + 0.001 kg·m² (second moment "
        "-0.0015 kg·m² below zero)"
    )
    assert lines[at + 2] == "  hand: 0.5 kg with a zero inertia tensor (a point mass)"
    res = CliRunner().invoke(cli, ["info", "--robot", "op2"])
    assert "inertia tensors: every link with mass has a physical one" in res.output
