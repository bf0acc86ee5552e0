"""Export of a payload fit: the model file with one more body fixed to the payload's link,
read back by sescid (its SESC vectors and mass are the fit's), by Pinocchio (URDF: the holding
torques) and by MuJoCo (MJCF: the payload body's mass, parent and no joint)."""

from __future__ import annotations

import numpy as np
import pytest
from oracle import PinStatics
from payload_gen import robot_with_payload
from refs import write_humanoid

import sescid
from sescid import Measurements, export_model, identify_payload, load_robot
from sescid.base import G0
from sescid.errors import ModelError
from sescid.simulation import simulate

HAND = "MP_ARM_LOW_R"


@pytest.fixture(scope="module")
def op2():
    return load_robot("op2")


def _payload_fit(robot, truth, n=12, seed=0, base=None):
    sim = simulate(truth, n=n, noise=1e-4, seed=seed)
    return identify_payload(robot, Measurements(q=sim.q, cop=sim.cop), HAND, base=base)


def test_urdf_export_on_the_model_adds_the_payload_link(op2, tmp_path):
    truth = robot_with_payload(op2, tmp_path, HAND, 1.2, [0.08, 0.0, 0.0])
    fit = _payload_fit(op2, truth)
    out = tmp_path / "out" / "op2_payload.urdf"
    out.parent.mkdir()
    assert export_model(fit, out) == []
    back = load_robot(out, op2.support)
    assert back.total_mass == pytest.approx(fit.total_mass, rel=1e-12)
    np.testing.assert_allclose(back.sesc_vectors(), fit.r, atol=1e-12)
    assert "HAND_payload".replace("HAND", HAND) in out.read_text()
    q = sescid.simulation.random_poses(op2, 4, 20.0, 1, clip=True)
    pin = PinStatics(out, op2.support, op2.joint_names, G0)
    np.testing.assert_allclose(pin.torques(q), fit.predict_torque(q), atol=1e-9)


def test_urdf_export_on_a_consistent_base(op2, tmp_path):
    own = simulate(op2, n=200, noise=1e-4, seed=3)
    base = sescid.identify(op2, own.q, cop=own.cop, method="consistent")
    truth = robot_with_payload(op2, tmp_path, HAND, 0.5, [0.05, 0.01, 0.0])
    fit = _payload_fit(op2, truth, base=base)
    assert fit.inertials is not None
    export_model(fit, tmp_path / "op2_c.urdf")
    back = load_robot(tmp_path / "op2_c.urdf", op2.support)
    assert back.total_mass == pytest.approx(fit.total_mass, rel=1e-9)
    np.testing.assert_allclose(back.sesc_vectors(), fit.r, atol=1e-9)


def test_mjcf_export_adds_a_fixed_body(tmp_path):
    path = write_humanoid(tmp_path)
    robot = load_robot(path, "legA_sole")
    hand = "armA_forearm"
    q = sescid.simulation.random_poses(robot, 10, 25.0, 0, clip=True)
    # the truth: the same MJCF with a 0.8 kg body inside the forearm at (0.02, 0, -0.1)
    text = path.read_text().replace(
        '<body name="armA_forearm" pos="0 0 -0.25">',
        '<body name="armA_forearm" pos="0 0 -0.25"><body name="box" pos="0.02 0 -0.1">'
        '<inertial pos="0 0 0" mass="0.8" diaginertia="1e-5 1e-5 1e-5"/></body>',
    )
    assert text != path.read_text()
    (tmp_path / "truth.xml").write_text(text)
    truth = load_robot(tmp_path / "truth.xml", "legA_sole")
    cop = truth.cop(q)
    fit = identify_payload(robot, Measurements(q=q, cop=cop), hand)
    assert fit.payload is not None
    np.testing.assert_allclose(fit.payload.com, [0.02, 0.0, -0.1], atol=1e-6)
    export_model(fit, tmp_path / "out.xml")
    back = load_robot(tmp_path / "out.xml", "legA_sole")
    assert back.total_mass == pytest.approx(truth.total_mass, rel=1e-9)
    import mujoco

    compiled = mujoco.MjModel.from_xml_path(str(tmp_path / "out.xml"))
    (bid,) = [i for i in range(compiled.nbody) if compiled.body(i).name == f"{hand}_payload"]
    assert compiled.body_mass[bid] == pytest.approx(fit.payload.mass, rel=1e-12)
    assert compiled.body_parentid[bid] == [i for i in range(compiled.nbody)
                                            if compiled.body(i).name == hand][0]  # fmt: skip
    assert compiled.body_jntnum[bid] == 0  # fixed to the forearm
    np.testing.assert_allclose(back.com(q), truth.com(q), atol=1e-9)


def test_an_undetermined_payload_is_not_exported(op2, tmp_path):
    foot = op2.model.bodies[0].name
    truth = robot_with_payload(op2, tmp_path, foot, 0.3, [0.01, 0.0, 0.02])
    sim = simulate(truth, n=10, noise=1e-4, seed=0)
    fit = identify_payload(op2, Measurements(q=sim.q, cop=sim.cop), foot)
    with pytest.raises(ModelError, match="not determined"):
        export_model(fit, tmp_path / "x.urdf")
    assert not (tmp_path / "x.urdf").exists()
