"""sescid identify --payload: a payload's mass and CoM from a file, its fit file, predict, and
one-line errors for bad input."""

from __future__ import annotations

import numpy as np
import pytest
from cli_run import invoke as run
from payload_gen import robot_with_payload
from refs import erd

import sescid
from sescid.simulation import TorqueNoise, simulate

HAND = "MP_ARM_LOW_R"


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """8 poses of the OP2 carrying 1.2 kg at 80 mm on its right lower arm: CoP and torques."""
    folder = tmp_path_factory.mktemp("payload_cli")
    op2 = sescid.load_robot("op2")
    truth = robot_with_payload(op2, folder, HAND, 1.2, [0.08, 0.0, 0.0])
    sim = simulate(truth, n=8, noise=1e-3, seed=5, torques=TorqueNoise(noise=0.05))
    cols = {j: sim.q[:, i] for i, j in enumerate(op2.joint_names)}
    cols |= {"cop_x": sim.cop[:, 0], "cop_y": sim.cop[:, 1]}
    cols |= {f"tau_{j}": t for j, t in zip(sim.torques.joints, sim.torques.tau.T, strict=True)}
    sescid.write_table(folder / "carry.csv", cols)
    return folder / "carry.csv", truth


def test_identify_payload_then_predict(data, tmp_path):
    path, truth = data
    res = run("identify", path, "--payload", HAND, "--out", tmp_path / "fit.json")
    assert res.exit_code == 0, res.output
    assert f"payload on {HAND}: 1.2" in res.output
    fit = sescid.load_fit(tmp_path / "fit.json")
    assert fit.payload is not None and fit.payload.body == HAND
    assert abs(fit.payload.mass - 1.2) < 4 * fit.payload.mass_std
    poses = tmp_path / "poses.csv"
    q = sescid.simulation.random_poses(truth, 5, 20.0, 3, clip=True)
    sescid.write_table(poses, {j: q[:, i] for i, j in enumerate(truth.joint_names)})
    res = run("predict", tmp_path / "fit.json", poses, "--out", tmp_path / "pred.csv")
    assert res.exit_code == 0, res.output
    assert f"include the payload on {HAND}" in res.output
    pred = sescid.read_table(tmp_path / "pred.csv")
    cop = np.stack([pred.get("cop_x"), pred.get("cop_y")], axis=1)
    np.testing.assert_allclose(cop, truth.cop(q), atol=3e-3)  # 8 noisy poses: mm-level


def test_weighed_mass_and_a_base_fit(data, tmp_path):
    path, _ = data
    own = tmp_path / "own.csv"
    res = run("simulate", "--robot", "op2", "--count", 200, "--seed", 1, "--out", own)
    assert res.exit_code == 0, res.output
    res = run("identify", own, "--method", "ls", "--out", tmp_path / "base.json")
    assert res.exit_code == 0, res.output
    res = run("identify", path, "--payload", HAND, "--payload-mass", 1.2, "--base",
              tmp_path / "base.json", "--kinds", "cop", "--out", tmp_path / "fit.json")  # fmt: skip
    assert res.exit_code == 0, res.output
    fit = sescid.load_fit(tmp_path / "fit.json")
    assert fit.payload is not None and fit.payload.mass == 1.2 and fit.payload.mass_given
    assert fit.payload.base.startswith("fit") and fit.payload.kinds[0].kind == "cop"


def _bad(tmp_path, *args, match: str):
    out = tmp_path / "out.json"
    res = run(*args, "--out", out)
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("sescid: error: "), res.output
    assert match in lines[0], lines[0]
    assert not out.exists()


def test_bad_payload_input(data, tmp_path):
    path, _ = data
    _bad(tmp_path, "identify", path, "--payload", "hand", match="no link named 'hand'")
    for mass in ("0", "-1", "nan", "inf"):
        _bad(tmp_path, "identify", path, "--payload", HAND, "--payload-mass", mass,
             match="--payload-mass: must be a finite mass > 0")  # fmt: skip
    _bad(tmp_path, "identify", path, "--payload-mass", "1", match="--payload BODY")
    _bad(tmp_path, "identify", path, "--payload", HAND, "--method", "ls", match="--method")
    talos = sescid.load_robot(erd("talos_data/robots/talos_reduced.urdf"), "right_sole_link")
    other = sescid.identify_payload(
        talos, sescid.Measurements(q=np.zeros((3, talos.nq)), cop=np.zeros((3, 2))),
        "gripper_right_base_link", mass=1.0,
    )  # fmt: skip
    sescid.save_fit(other, tmp_path / "talos.json")
    _bad(tmp_path, "identify", path, "--robot", "op2", "--payload", HAND, "--base",
         tmp_path / "talos.json", match="base fit is of the robot")  # fmt: skip


def test_base_model_file(data, tmp_path):
    path, _ = data
    model = sescid.load_robot("op2").model_path
    res = run("identify", path, "--payload", HAND, "--base", model, "--support", "r_sole",
              "--out", tmp_path / "fit.json")  # fmt: skip
    assert res.exit_code == 0, res.output
    fit = sescid.load_fit(tmp_path / "fit.json")
    assert fit.payload is not None and fit.payload.base == "model"
    assert abs(fit.payload.mass - 1.2) < 4 * fit.payload.mass_std
    _bad(tmp_path, "identify", path, "--payload", HAND, "--weighted", match="--weighted: does not")
    _bad(tmp_path, "identify", path, "--payload", HAND, "--total-mass", "4",
         match="--payload-mass")  # fmt: skip
