"""Guided sessions for robots that report joint torques: planned for the rows the robot gives
(torques, or torques and the CoP), fitted by ``identify`` on the poses so far, stopped on the
predicted CoM error — checked against the benches' truth, the batch command on the session's
own files, a replay, and a robot held in a gantry."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

import sescid
from sescid.bench import ExperimentConfig
from sescid.bench.real_robot import TorqueConfig
from sescid.cli import cli
from sescid.errors import DataError
from sescid.planning import block_rows, candidates, design_kinds, kind_basis
from sescid.planning.design.sequential import SequentialDesign
from sescid.sensors import load_sensors
from sescid.session import (
    KinematicAdapter,
    MujocoAdapter,
    SessionDesign,
    SessionOptions,
    run_session,
)
from sescid.tables import read_table

TORQUES = ExperimentConfig(torque=TorqueConfig("all"))  # 0.05 N·m noise, 0.05 N·m offsets


@pytest.fixture(scope="module")
def sensors(op2):
    return load_sensors(None, op2.profile)


@pytest.fixture(scope="module")
def test_poses(op2):
    return candidates(op2, 400, seed=99).q


def _com_error(com, robot, q, r_true) -> float:
    """RMS per axis [m] of a CoM (n, 3) against the true robot's x, y at poses q."""
    d = com[:, :2] - robot.com(q, r_true)[:, :2]
    return float(np.sqrt(np.mean(np.sum(d**2, axis=1) / 2)))


@pytest.mark.parametrize("bench", ["kinematic", "mujoco"])
def test_torque_only_session_converges_to_the_truth(op2, sensors, test_poses, bench):
    """A robot without foot sensors (its log has joint torques only) on the bench (7 %
    unmodelled mass, ±1° joint play, torque offsets and noise): the session plans for torque
    rows, converges by its stop rule, and its CoM on fresh poses beats the CAD model's and is
    within 2× its own predicted std."""
    if bench == "mujoco":
        pytest.importorskip("mujoco")
        bot = MujocoAdapter(op2, sensors, TORQUES, seed=0, feet=False)
    else:
        bot = KinematicAdapter(op2, sensors, TORQUES, seed=0, feet=False)
    opt = SessionOptions(budget=60, samples=8, n_candidates=600, window=5,
                         total_mass=bot.mass_true)  # fmt: skip
    res = run_session(op2, bot, sensors, opt)
    assert res.stop_reason.startswith("converged: predicted CoM x/y std"), res.stop_reason
    assert res.kinds == ("tau",) and res.quantity == "CoM x/y"
    assert not any(k.startswith("r_fsr") for k in res.raw)  # no foot sensor was logged
    measured = [s for s in res.steps if s.status == "measured"]
    assert all(s.cop is None and s.tau is not None for s in measured)
    err = _com_error(res.fit.predict_com(test_poses), op2, test_poses, bot.r_true)
    cad = _com_error(op2.com(test_poses), op2, test_poses, bot.r_true)
    # measured: kinematic 0.73 mm (predicted 0.65), MuJoCo 0.56 mm (0.48); CAD 1.80 mm
    assert err < 0.6 * cad
    assert err < 2 * res.cop_std
    stds = [s.cop_std for s in measured if math.isfinite(s.cop_std)]
    assert stds[-1] < stds[0]


def test_the_session_fit_is_identify_on_its_files(op2, tmp_path):
    """`sescid session` with torques only: its fit.json equals `sescid identify --method map
    --weighted` on its measured.csv, and replaying the folder makes the same decisions."""
    mass = op2.total_mass * 1.07
    args = ["session", "--adapter", "kinematic", "--torques", "all", "--no-foot-sensors",
            "--budget", "30", "--samples", "6", "--candidates", "400", "--window", "4",
            "--total-mass", f"{mass:.6f}", "--no-view"]  # fmt: skip
    out = tmp_path / "s"
    res = CliRunner().invoke(cli, [*args, "--out-dir", str(out)])
    assert res.exit_code == 0, res.output
    assert "20 joint torques; predicted CoM x/y std" in res.output
    assert "measured (tau)" in res.output
    fit_cli = tmp_path / "fit.json"
    run = CliRunner().invoke(cli, ["identify", str(out / "measured.csv"), "--weighted",
                                   "--method", "map", "--total-mass", f"{mass:.6f}",
                                   "--out", str(fit_cli)])  # fmt: skip
    assert run.exit_code == 0, run.output
    batch, session = sescid.load_fit(fit_cli), sescid.load_fit(out / "fit.json")
    cols = read_table(out / "measured.csv").columns
    q = np.column_stack([cols[j] for j in op2.joint_names])
    assert np.abs(batch.predict_com(q) - session.predict_com(q)).max() < 1e-7
    assert np.abs(batch.predict_torque(q) - session.predict_torque(q)).max() < 1e-6
    again = tmp_path / "r"
    rep = CliRunner().invoke(cli, [*args, "--adapter", "replay", "--replay", str(out),
                                   "--out-dir", str(again)])  # fmt: skip
    assert rep.exit_code == 0, rep.output
    a = json.loads((out / "session.json").read_text())
    b = json.loads((again / "session.json").read_text())
    assert [s["candidate"] for s in a["steps"]] == [s["candidate"] for s in b["steps"]]
    assert a["stop_reason"] == b["stop_reason"]


def test_a_held_robot_session_on_the_kinematic_bench(op2, sensors):
    """The OP2 held by its torso: the candidates are the gantry's, every pose holds, the torques
    alone identify what they can see, and the held CoM beats the CAD model's."""
    robot = sescid.load_robot("op2", support=op2.model.model_root)
    cfg = ExperimentConfig(torque=TorqueConfig("all"), mount="gantry")
    bot = KinematicAdapter(robot, None, cfg, seed=1)
    opt = SessionOptions(budget=40, samples=10, n_candidates=500, window=5,
                         total_mass=bot.mass_true)  # fmt: skip
    res = run_session(robot, bot, None, opt)
    assert res.candidates.mount == "gantry" and res.kinds == ("tau",)
    assert res.stop_reason.startswith("converged")
    # every pose holds; one whose torque samples are too few after outliers is skipped
    skipped = [s.reason for s in res.steps if s.status != "measured"]
    assert len(skipped) <= 2 and all("not determined" in r for r in skipped)
    q = res.candidates.q[:200]
    d = res.fit.predict_torque(q) - robot.torques(q, bot.r_true, total_mass=bot.mass_true)
    cad = robot.torques(q) - robot.torques(q, bot.r_true, total_mass=bot.mass_true)
    assert np.sqrt(np.mean(d**2)) < 0.5 * np.sqrt(np.mean(cad**2))


def test_auto_switches_to_what_the_robot_reports(op2, sensors):
    """ "auto" plans the first pose for the CoP; a robot that reports both kinds gets the rest
    planned for both: the design after the switch is the block design with the first pose."""
    opt = SessionOptions(n_candidates=300, budget=30)
    plan = SessionDesign(op2, opt)
    assert plan.kinds == ("cop",) and plan.mount == "stand"
    first = plan.design.next(plan.cand.q, np.zeros(op2.nq)).index
    plan.design.mark_tried(first)
    plan.switch(("cop", "tau"), [first])
    assert plan.kinds == ("cop", "tau") and plan.design.tried[first]
    spec = design_kinds(op2, "both")
    rows = block_rows(op2, plan.cand.q, spec, kind_basis(op2, plan.cand.q, spec))
    ref = SequentialDesign(rows, opt.near)
    ref.add(first)
    np.testing.assert_allclose(plan.design.gains(), ref.gains(), rtol=1e-9)
    bot = KinematicAdapter(op2, sensors, TORQUES, seed=2)
    res = run_session(op2, bot, sensors, SessionOptions(budget=25, samples=6, n_candidates=300,
                                                        window=4))  # fmt: skip
    assert res.kinds == ("cop", "tau") and res.quantity == "CoM x/y"
    assert all(s.cop is not None and s.tau is not None for s in res.steps if s.status == "measured")


def test_a_kind_the_robot_does_not_report_is_one_line(op2, sensors):
    bot = KinematicAdapter(op2, sensors, TORQUES, seed=0, feet=False)
    with pytest.raises(DataError, match="logs no loaded foot sensor.*--kinds cop"):
        run_session(op2, bot, sensors, SessionOptions(budget=25, n_candidates=100, kinds="cop"))
    bot = KinematicAdapter(op2, sensors, ExperimentConfig(), seed=0)
    with pytest.raises(DataError, match="logs no joint torques"):
        run_session(op2, bot, sensors, SessionOptions(budget=25, n_candidates=100, kinds="tau"))
