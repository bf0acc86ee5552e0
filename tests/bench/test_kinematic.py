"""The virtual experiment: its log reproduces the truth, and the paper's finding comes out."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from fitting import cop_offset_stats, identify_ls
from op2_stance import stable_poses

import sescid
from sescid.bench import ExperimentConfig, ExtraMass, real_robot, run_experiment
from sescid.cli import cli
from sescid.errors import SescidError
from sescid.robots import MX28, profile_for
from sescid.sensors import load_sensors, measure, read_raw
from sescid.tables import Table, write_table

G = 9.80665


@pytest.fixture(scope="module")
def sensors():
    return load_sensors(profile=profile_for("op2"))


def reduce(robot, sensors, ex, min_samples=5):
    """Raw columns → per-pose CoP via the same path as ``sescid fsr``."""
    cols = {k: np.asarray(v, dtype=float) for k, v in ex.columns.items() if k != "pose"}
    table = Table(Path("raw"), cols, {"pose": [str(p) for p in ex.columns["pose"]]})
    log = read_raw(table, robot.joint_names, sensors, robot.profile.servo)
    return measure(robot, log, sensors, min_samples)


IDEAL = ExperimentConfig(
    extra_mass_fraction=0.0,
    backlash_deg=0.0,
    readback_jitter_ticks=0.0,
    fsr_noise=0.0,
    fsr_bias=0.0,
)


def test_ideal_robot_log_gives_the_model_cop(robot, sensors):
    q = stable_poses(robot, 20, seed=1)
    ex = run_experiment(robot, q, sensors, samples=3, seed=0, config=IDEAL)
    forces = np.column_stack([ex.columns[f"r_fsr{k}"] for k in range(1, 5)])
    np.testing.assert_allclose(forces.sum(1) / 1000, robot.total_mass * G, atol=0.003)
    assert np.all(np.column_stack([ex.columns[f"l_fsr{k}"] for k in range(1, 5)]) == 0)
    res = reduce(robot, sensors, ex, min_samples=2)
    # read-backs are whole ticks (0.088°) and forces whole mN: both bound the error
    q_ticks = MX28.to_rad(np.round(q * 4096 / (2 * math.pi)) + 2048)
    np.testing.assert_allclose(res.data.q, q_ticks, atol=1e-12)
    np.testing.assert_allclose(res.data.cop, robot.cop(q), atol=5e-6)


def test_real_robot_com_matches_added_point_masses(robot):
    cfg = ExperimentConfig()
    r_true, mass, placed = real_robot(robot, cfg)
    assert mass == pytest.approx(robot.total_mass * (1 + cfg.extra_mass_fraction), rel=1e-12)
    q = stable_poses(robot, 5, seed=2)
    rot, org = robot.forward(q)
    # independent CoM: model CoM plus each extra point mass placed with the body's pose
    moment = robot.total_mass * robot.com(q)
    for e in placed:
        b = robot.body_names.index(e["body"])
        pos = org[:, b] + rot[:, b] @ np.array(e["offset_m"])
        moment += e["mass_kg"] * pos
    np.testing.assert_allclose(robot.com(q, r_true), moment / mass, atol=1e-14)


def test_backlash_and_readbacks(robot, sensors):
    q = stable_poses(robot, 200, seed=3)
    cfg = ExperimentConfig(backlash_deg=1.0, readback_seen=0.5)
    tr = run_experiment(robot, q, sensors, samples=1, seed=0, config=cfg).truth
    delta = np.degrees(tr.q_actual - q)
    assert np.abs(delta).max() <= 1.0
    assert delta.std() == pytest.approx(1.0 / math.sqrt(3), rel=0.03)  # U(−1°, 1°)
    np.testing.assert_allclose(np.degrees(tr.q_readback - q), 0.5 * delta, atol=1e-12)


def test_truth_cop_is_the_real_robots_projection(robot, sensors):
    q = stable_poses(robot, 10, seed=4)
    ex = run_experiment(robot, q, sensors, samples=2, seed=5)
    r_true = ex.truth.r_true
    np.testing.assert_allclose(ex.truth.cop_true, robot.cop(ex.truth.q_actual, r_true), atol=1e-15)
    np.testing.assert_allclose(r_true, real_robot(robot, ExperimentConfig())[0], atol=1e-15)


def test_centroid_registers_agree_with_forces(robot, sensors):
    q = stable_poses(robot, 10, seed=6)
    cfg = ExperimentConfig(registers="both")
    ex = run_experiment(robot, q, sensors, samples=100, seed=0, config=cfg)
    by_force = reduce(robot, sensors, ex)
    ex.columns = {k: v for k, v in ex.columns.items() if not k[-1].isdigit()}
    by_reg = reduce(robot, sensors, ex)
    assert by_reg.mode == "centroid"
    # one register count is 0.33 mm along x, 0.21 mm along y; averaged over 100 samples
    np.testing.assert_allclose(by_reg.data.cop, by_force.data.cop, atol=1e-4)


def test_paper_finding_manufacturer_offset_vs_identified(robot, sensors):
    """38 poses × 100 samples (the paper's §4): a clear offset before, none after."""
    q = stable_poses(robot, 38, seed=0)
    ex = run_experiment(robot, q, sensors, samples=100, seed=0)
    res = reduce(robot, sensors, ex)
    fit = identify_ls(robot, res.data.q, res.data.cop, sigma=res.data.cop_se)
    before = cop_offset_stats(res.data.cop, robot.cop(res.data.q))
    after = cop_offset_stats(res.data.cop, fit.predict_cop(res.data.q))
    assert before["mean"] > 1.5e-3  # mm-level offset, several standard errors of a pose mean
    assert before["mean"] > 20 * after["mean"]
    assert before["rms"] > 2 * after["rms"]


def test_identified_fit_recovers_the_true_cop_on_fresh_poses(robot, sensors):
    q = stable_poses(robot, 300, seed=7)
    ex = run_experiment(robot, q, sensors, samples=20, seed=1)
    res = reduce(robot, sensors, ex)
    fit = identify_ls(robot, res.data.q, res.data.cop, sigma=res.data.cop_se)
    r_true = ex.truth.r_true
    fresh = stable_poses(robot, 3000, seed=8)
    truth = robot.cop(fresh, r_true)

    def rms(a):
        return float(np.sqrt(np.mean(a**2)))

    err_fit = rms(fit.predict_cop(fresh) - truth)
    err_model = rms(robot.cop(fresh) - truth)
    assert err_fit < 1.0e-3  # tolerance: 1 mm (backlash ±0.5° unseen, FSR bias)
    assert err_fit < 0.4 * err_model


def test_pose_list_outside_joint_limits_is_an_error(robot, sensors):
    q = stable_poses(robot, 3, seed=9)
    q[1, robot.joint_names.index("r_knee")] = math.radians(-20)  # limit −1.1°
    with pytest.raises(SescidError, match="pose 1, joint 'r_knee': -20.00° is outside"):
        run_experiment(robot, q, sensors, samples=2)


def test_pose_beyond_the_sensors_is_skipped_and_reported(robot, sensors):
    q = stable_poses(robot, 4, seed=12)
    q[2] = 0.0  # on the right foot with the CoM over the left foot: not measurable
    ex = run_experiment(robot, q, sensors, samples=3)
    assert [p for p, _ in ex.skipped] == ["2"]
    assert "outside the sensor rectangle of r_sole" in ex.skipped[0][1]
    assert sorted(set(ex.columns["pose"])) == ["0", "1", "3"]
    assert list(ex.truth.pose) == ["0", "1", "3"] and len(ex.truth.cop_true) == 3
    with pytest.raises(SescidError, match="no pose can be measured"):
        run_experiment(robot, np.zeros((2, robot.nq)), sensors, samples=2)


def test_unknown_extra_mass_body(robot, sensors):
    cfg = ExperimentConfig(extra=(ExtraMass("NO_SUCH_LINK", 1.0, (0, 0, 0)),))
    with pytest.raises(SescidError, match="unknown body 'NO_SUCH_LINK'"):
        real_robot(robot, cfg)


def test_cli_experiment_writes_log_and_truth(robot, tmp_path):
    q = stable_poses(robot, 6, seed=10)
    poses = tmp_path / "poses.csv"
    write_table(
        poses, {"pose": np.arange(10, 16)} | {j: q[:, i] for i, j in enumerate(robot.joint_names)}
    )
    raw, truth = tmp_path / "raw.csv", tmp_path / "truth.json"
    args = ["experiment", "--poses", str(poses), "--samples", "7", "--out", str(raw)]
    res = CliRunner().invoke(cli, [*args, "--truth", str(truth)])
    assert res.exit_code == 0, res.output
    data = json.loads(truth.read_text())
    np.testing.assert_allclose(data["q_commanded"], q, atol=1e-15)
    assert data["pose"] == [str(i) for i in range(10, 16)]
    out = tmp_path / "m.csv"
    res = CliRunner().invoke(cli, ["fsr", str(raw), "--poses", str(poses), "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "6 poses from forces: 42 samples used" in res.output


def test_cli_experiment_bad_pose_list_leaves_no_files(robot, tmp_path):
    q = stable_poses(robot, 3, seed=11)
    q[2, 0] = math.radians(200)  # r_sho_pitch limit ±179.9°
    poses = tmp_path / "poses.csv"
    write_table(poses, {j: q[:, i] for i, j in enumerate(robot.joint_names)})
    raw, truth = tmp_path / "raw.csv", tmp_path / "truth.json"
    args = ["experiment", "--poses", str(poses), "--out", str(raw), "--truth", str(truth)]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 2
    assert res.output.count("\n") == 1 and "outside the joint limits" in res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["poses.csv"]


def test_cli_defaults_are_the_api_defaults():
    opts = {p.name: p.default for p in cli.get_command(None, "experiment").params}
    cfg = ExperimentConfig()
    assert opts["extra_mass"] == cfg.extra_mass_fraction
    assert opts["backlash_deg"] == cfg.backlash_deg
    assert (opts["fsr_noise"], opts["fsr_bias"]) == (cfg.fsr_noise, cfg.fsr_bias)
    assert opts["registers"] == cfg.registers


@pytest.mark.parametrize("robot_key", ["op2", "icub"])
def test_every_stance_stands_the_same_real_robot(op2, icub_path, robot_key):
    """The bench's real robot (the model plus its unmodelled masses, the defaults: the OP2's
    list, a profile-less URDF's generic ones) is one physical robot whatever the stance it is
    rooted at: its CoM at two poses, carried into the right sole's frame, agrees to round-off
    (``experiment --support l_sole`` stood another robot, 2.3 mm off in y on the OP2, so a
    pooled fit of two stances met two robots)."""
    base = op2 if robot_key == "op2" else sescid.load_robot(icub_path, "r_sole")
    others = ("l_sole", "MP_BODY") if robot_key == "op2" else ("l_sole", "root_link")
    rng = np.random.default_rng(3)
    q = np.vstack([np.zeros(base.nq), rng.uniform(-0.3, 0.3, base.nq)])
    r0, m0, _ = real_robot(base, ExperimentConfig())
    c0 = base.com(q, r0)
    for other in others:
        robot = base.at(other)
        r, m, _ = real_robot(robot, ExperimentConfig())
        rot, pos = base.link_poses(q, other)
        c = np.einsum("nij,nj->ni", rot, robot.com(q, r)) + pos
        assert m == pytest.approx(m0, rel=1e-12)
        np.testing.assert_allclose(c, c0, atol=1e-12)
