"""The guided session: next-best pose, adapters (MuJoCo, replay, a user class), stop rule, files."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import sescid
from sescid.cli import cli
from sescid.errors import DataError
from sescid.planning import candidates, identifiable_basis, projected_regressor
from sescid.planning.design.doptimal import information
from sescid.planning.design.sequential import SequentialDesign
from sescid.sensors import load_sensors
from sescid.session.adapters import ReplayAdapter, RobotAdapter, load_adapter_class
from sescid.session.loop import SessionOptions, run_session
from sescid.tables import read_table

EXAMPLES = Path(__file__).parents[2] / "examples"
DUMMY = f"{EXAMPLES / 'op2_dummy_robot_session.py'}:DummyRobot"
#: the small session the MuJoCo tests share (CLI options and the same as SessionOptions)
SMALL = ["--budget", "28", "--samples", "8", "--candidates", "300", "--window", "3"]
SMALL_OPT = SessionOptions(budget=28, samples=8, n_candidates=300, window=3)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """`sescid session --adapter mujoco` end to end, small budget (the recorded session)."""
    pytest.importorskip("mujoco")
    out = tmp_path_factory.mktemp("session") / "s"
    res = CliRunner().invoke(cli, ["session", *SMALL, "--no-view", "--out-dir", str(out)])
    assert res.exit_code == 0, res.output
    return out, res.output


def test_mujoco_session_writes_the_step_by_step_files(recorded, op2, tmp_path):
    """The session's files feed fsr/identify, which reproduce its measured CoPs and its fit."""
    out, output = recorded
    assert "stopped:" in output and "[1/28] pose 0" in output
    doc = json.loads((out / "session.json").read_text())
    assert doc["n_commanded"] == len(read_table(out / "poses.csv").columns["pose"]) <= 28
    run = CliRunner().invoke
    meas = tmp_path / "m.csv"
    args = ["fsr", str(out / "raw.csv"), "--poses", str(out / "poses.csv"), "--out", str(meas)]
    res = run(cli, args)
    assert res.exit_code == 0, res.output
    a, b = read_table(meas), read_table(out / "measured.csv")
    for c in ("cop_x", "cop_y", "cop_se_x", "cop_se_y"):
        assert np.array_equal(a.columns[c], b.columns[c])
    # the session's fit is `sescid identify --weighted` of its measured.csv: the same weighted
    # least squares with the logged gravity columns (tilted statics)
    cols = read_table(out / "measured.csv").columns
    assert "grav_z" in cols
    fit_cli = tmp_path / "fit.json"
    res = run(
        cli,
        [
            "identify",
            str(out / "measured.csv"),
            "--method",
            "ls",
            "--weighted",
            "--out",
            str(fit_cli),
        ],
    )
    assert res.exit_code == 0, res.output
    batch, online = sescid.load_fit(fit_cli), sescid.load_fit(out / "fit.json")
    assert batch.rank == online.rank
    qq = np.column_stack([cols[j] for j in op2.joint_names])
    g = np.column_stack([cols["grav_x"], cols["grav_y"], cols["grav_z"]])
    d = batch.predict_cop(qq, g) - online.predict_cop(qq, g)
    assert np.abs(d).max() < 1e-7  # measured.csv rounds to ~1e-12; the fit amplifies it
    dz = batch.predict_com(qq)[:, 2] - online.predict_com(qq)[:, 2]
    assert np.abs(dz).max() < 1e-5  # measured 2e-7 m; 39 mm when the session fit flat
    skipped = [s for s in doc["steps"] if s["status"] == "skipped"]
    assert all(s["reason"] for s in skipped)  # a failed pose is logged with its reason
    assert doc["n_measured"] + len(skipped) == doc["n_commanded"]


def test_replay_reproduces_the_decisions_exactly(recorded, op2):
    """Replaying the raw log makes the same choices, skips and fit (bit for bit)."""
    out, _ = recorded
    sensors = load_sensors(None, op2.profile)
    doc = json.loads((out / "session.json").read_text())
    reasons = {s["pose"]: s["reason"] for s in doc["steps"] if s["reason"]}
    bot = ReplayAdapter(
        read_table(out / "raw.csv"),
        op2.joint_names,
        read_table(out / "poses.csv"),
        op2.profile.servo,
        reasons,
    )
    assert isinstance(bot, RobotAdapter)
    res = run_session(op2, bot, sensors, SMALL_OPT)
    assert [s.candidate for s in res.steps] == [s["candidate"] for s in doc["steps"]]
    assert [s.status for s in res.steps] == [s["status"] for s in doc["steps"]]
    assert [s.reason for s in res.steps] == [s["reason"] for s in doc["steps"]]
    assert np.array_equal(res.fit.r, sescid.load_fit(out / "fit.json").r)
    assert res.stop_reason == doc["stop_reason"]
    # other options → other decisions: the replay refuses to serve them
    bot2 = ReplayAdapter(
        read_table(out / "raw.csv"),
        op2.joint_names,
        read_table(out / "poses.csv"),
        op2.profile.servo,
    )
    opt = SessionOptions(budget=28, samples=8, n_candidates=300, window=3, seed=1)
    with pytest.raises(DataError, match="replay diverged"):
        run_session(op2, bot2, sensors, opt)


def test_cli_replay_folder(recorded, tmp_path):
    """`sescid session --adapter replay --replay FOLDER` writes the same session record."""
    out, _ = recorded
    args = ["session", *SMALL, "--no-view", "--adapter", "replay", "--replay", str(out)]
    res = CliRunner().invoke(cli, [*args, "--out-dir", str(tmp_path / "r")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "r" / "session.json").read_text() == (out / "session.json").read_text()


def test_next_pose_gain_is_the_logdet_rise(op2):
    """A candidate's gain equals log det M(after) − log det M(before), computed directly."""
    cand = candidates(op2, 200, seed=5)
    basis = identifiable_basis(op2, cand.q)
    a = projected_regressor(op2, cand.q, basis)
    des = SequentialDesign(a, near=1.0)
    for i in range(25):  # beyond the rank: M non-singular from here on
        des.add(int(np.argsort(-des.gains())[0]))
        assert des.tried.sum() == i + 1
    chosen = np.flatnonzero(des.tried)
    m = information(a[chosen])
    g = des.gains()
    for j in np.flatnonzero(~des.tried)[:5]:
        direct = np.linalg.slogdet(m + information(a[j : j + 1]))[1] - np.linalg.slogdet(m)[1]
        assert g[j] == pytest.approx(direct, rel=1e-6)
    nxt = des.next(cand.q, np.zeros(op2.nq))  # near = 1: the best gain
    assert nxt.gain == pytest.approx(np.nanmax(g)) and not des.tried[nxt.index]


def test_near_rule_takes_the_closest_good_pose(op2):
    """With near < 1 the chosen pose is the closest of those within near × the best gain."""
    cand = candidates(op2, 200, seed=5)
    a = projected_regressor(op2, cand.q, identifiable_basis(op2, cand.q))
    des = SequentialDesign(a, near=0.9)
    q0 = cand.q[17]
    nxt = des.next(cand.q, q0)
    g = des.gains()
    ok = g >= 0.9 * g.max()
    dist = np.linalg.norm(cand.q - q0, axis=1)
    assert nxt.distance == pytest.approx(dist[ok].min()) and nxt.gain >= 0.9 * g.max()


def test_user_class_session_converges_to_the_truth(op2, tmp_path):
    """A user's Python class (the dummy robot): safe commands only; the fit finds its truth."""
    cls = load_adapter_class(DUMMY)
    bot = cls(op2)
    opt = SessionOptions(budget=45, samples=10, n_candidates=400, window=5, tol=0.1)
    res = run_session(op2, bot, load_sensors(None, op2.profile), opt)
    q = np.array(bot.commands)
    lim = op2.joint_limits
    assert np.all((q >= lim[:, 0]) & (q <= lim[:, 1]))
    assert np.all(np.abs(op2.cop(q)) < op2.profile.cop_box)
    assert res.n_measured >= 21 and math.isfinite(res.cop_std)
    q_test = candidates(op2, 300, seed=9).q
    err = res.fit.predict_cop(q_test) - op2.cop(q_test, bot.r_true)
    rms = float(np.sqrt(np.mean(err**2)))
    # 1 mm CoP noise and ±0.5° joint play: within 3× the session's own predicted CoP std
    assert rms < 3 * res.cop_std and rms < 1e-3
    steps = [s.cop_std for s in res.steps if math.isfinite(s.cop_std)]
    assert steps[-1] < steps[0]  # the predicted error falls as poses come in


def test_cli_python_adapter_and_bad_adapter(tmp_path):
    """`--adapter python:FILE.py:Class` runs; an unknown class is one error line, exit 2."""
    run = CliRunner().invoke
    args = ["session", "--budget", "22", "--samples", "5", "--candidates", "300", "--no-view"]
    res = run(cli, [*args, "--adapter", f"python:{DUMMY}", "--out-dir", str(tmp_path / "d")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "d" / "fit.json").is_file()
    bad = f"python:{EXAMPLES / 'op2_dummy_robot_session.py'}:Nope"
    res = run(cli, [*args, "--adapter", bad, "--out-dir", str(tmp_path / "e")])
    assert res.exit_code == 2 and "has no class 'Nope'" in res.output
    assert not (tmp_path / "e").exists()
    res = run(cli, [*args, "--adapter", "replay", "--out-dir", str(tmp_path / "f")])
    assert res.exit_code == 2 and "--replay" in res.output


def test_example_runs():
    """The dummy-robot example prints its session summary and error vs truth."""
    import subprocess

    res = subprocess.run(
        [
            sys.executable,
            str(EXAMPLES / "op2_dummy_robot_session.py"),
            "--budget",
            "24",
            "--candidates",
            "300",
            "--samples",
            "5",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert res.returncode == 0, res.stderr[-2000:]
    assert "RMS CoP error vs truth" in res.stdout
