"""A guided session over stances: it asks for the change when the other stance's best pose is
worth its cost, pools the stances (checked against the bench's true robot), records each pose's
stance in its files, and replays to the same decisions."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from sescid.bench import ExperimentConfig, TorqueConfig
from sescid.bench.real_robot import real_robot
from sescid.cli import cli
from sescid.errors import OptionError
from sescid.sensors import load_sensors
from sescid.session import KinematicAdapter, SessionObserver, SessionOptions, run_session
from sescid.tables import read_table

SMALL = {"samples": 8, "n_candidates": 300, "window": 3}


class _Changes(SessionObserver):
    def __init__(self):
        self.changes: list[tuple[int, str]] = []

    def stance(self, step_no, label, describe):
        self.changes.append((step_no, label))


def test_session_changes_foot_when_worth_it_and_pools(op2):
    """CoP on r_sole, then l_sole: the change is asked once r_sole's directions are determined
    (its best gain fell under 1/6 of l_sole's best); only the pooled poses determine all 44
    directions; the pooled CoM is within 3 predicted standard deviations of the true robot's."""
    sensors = load_sensors(None, op2.profile)
    config = ExperimentConfig()
    bot = KinematicAdapter(op2, sensors, config, seed=0)
    obs = _Changes()
    opt = SessionOptions(budget=45, kinds="cop", stances=("r_sole", "l_sole"), **SMALL)
    res = run_session(op2, bot, sensors, opt, obs)
    assert obs.changes[0] == (0, "r_sole") and obs.changes[1][1] == "l_sole"
    k = obs.changes[1][0]
    before, after = res.steps[k - 1], res.steps[k]
    assert before.rank == 42 and after.rank == 44 and not np.isfinite(before.cop_std)
    assert res.steps[k].gain > (1 + opt.stance_cost) * res.steps[k - 1].gain
    assert {s.stance for s in res.steps} == {"r_sole", "l_sole"}
    theta, sd = res.pooled
    assert np.all(sd > 0)
    r_true, _, _ = real_robot(op2, config)
    q = np.array([s.q for s in res.steps])
    e = op2.sesc_matrix(op2)
    com_est = op2.com(q, (e @ theta / op2.total_mass).reshape(-1, 3))
    err = np.sqrt(np.mean(np.sum((com_est - op2.com(q, r_true))[:, :2] ** 2, axis=1) / 2))
    assert err < 3 * res.cop_std


def test_session_over_stances_cli_and_replay(tmp_path):
    """`sescid session --stances` prints each change it asks for; poses.csv, measured.csv and
    raw.csv carry each pose's stance, session.json the pooled body parameters, fit.json the pooled
    fit `identify measured.csv --weighted` gives; replaying the folder makes the same decisions
    (the same files)."""
    out, rep = tmp_path / "s", tmp_path / "r"
    args = ["session", "--stances", "r_sole,l_sole", "--kinds", "cop", "--budget", "45",
            "--samples", "8", "--candidates", "300", "--window", "3", "--no-view"]  # fmt: skip
    res = CliRunner().invoke(cli, [*args, "--adapter", "kinematic", "--out-dir", str(out)])
    assert res.exit_code == 0, res.output
    assert "stance change before pose 0: put the robot standing on r_sole" in res.output
    assert "put the robot standing on l_sole [l_sole]" in res.output
    poses, meas = read_table(out / "poses.csv"), read_table(out / "measured.csv")
    assert list(dict.fromkeys(poses.text["support"])) == ["r_sole", "l_sole"]
    assert list(meas.text["support"]) == list(poses.text["support"])
    assert set(read_table(out / "raw.csv").text["support"]) == {"r_sole", "l_sole"}
    doc = json.loads((out / "session.json").read_text())
    assert doc["stances"] == ["r_sole", "l_sole"] and len(doc["pooled"]["bodies"]) == 21
    fit = tmp_path / "fit.json"
    res = CliRunner().invoke(cli, ["identify", str(out / "measured.csv"), "--weighted",
                                   "--method", "ls", "--out", str(fit)])  # fmt: skip
    assert res.exit_code == 0, res.output
    a, b = json.loads((out / "fit.json").read_text()), json.loads(fit.read_text())
    ra, rb = (np.array(list(d["r"].values())) for d in (a, b))
    np.testing.assert_allclose(ra, rb, atol=1e-12)  # the pooled fit of its files
    assert a["bodies"] is not None
    res = CliRunner().invoke(cli, [*args, "--adapter", "replay", "--replay", str(out),
                                   "--out-dir", str(rep)])  # fmt: skip
    assert res.exit_code == 0, res.output
    for name in ("poses.csv", "measured.csv"):
        assert (rep / name).read_bytes() == (out / name).read_bytes()


def test_mujoco_session_on_a_foot_and_in_a_gantry(tmp_path):
    """MuJoCo bench, joint torques and the CoP: standing on r_sole, then held by the torso; the
    held poses have torques and no CoP."""
    pytest.importorskip("mujoco")
    out = tmp_path / "m"
    args = ["session", "--adapter", "mujoco", "--stances", "r_sole,gantry:MP_BODY", "--torques",
            "all", "--budget", "30", "--samples", "8", "--candidates", "300", "--window", "3",
            "--no-view", "--out-dir", str(out)]  # fmt: skip
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    assert "held by MP_BODY in a gantry [MP_BODY]" in res.output
    meas = read_table(out / "measured.csv")
    held = np.asarray(meas.text["support"]) == "MP_BODY"
    assert held.any() and (~held).any()
    assert np.all(np.isnan(meas.columns["cop_x"][held]))
    assert np.all(np.isfinite(meas.columns["tau_r_knee"]))


def test_session_over_stances_needs_an_adapter_that_changes_stance(op2):
    """A user's adapter without change_stance, and one stance given as stances, are refused."""
    sensors = load_sensors(None, op2.profile)

    class Plain:
        def move(self, pose, q): ...
        def wait_settled(self):
            return ""  # noqa: E704

        def read(self, n):
            return {}  # noqa: E704

        def stop(self): ...

    opt = SessionOptions(budget=30, stances=("r_sole", "l_sole"), **SMALL)
    with pytest.raises(OptionError, match="change_stance"):
        run_session(op2, Plain(), sensors, opt)
    with pytest.raises(OptionError, match="two or more"):
        run_session(op2, Plain(), sensors, SessionOptions(budget=30, stances=("l_sole",)))
    cfg = ExperimentConfig(torque=TorqueConfig(joints="all"))
    bot = KinematicAdapter(op2, sensors, cfg)
    with pytest.raises(OptionError, match="mount"):
        run_session(op2, bot, sensors, SessionOptions(budget=30, mount="stand",
                                                      stances=("r_sole", "l_sole")))  # fmt: skip


class _Crashing(KinematicAdapter):
    """The kinematic bench, stopped by the operator at its ``crash_after``-th move."""

    def __init__(self, *a, crash_after: int | None = None, **k):
        super().__init__(*a, **k)
        self.crash_after, self.moves, self.stances = crash_after, 0, []

    def change_stance(self, support, mount):
        self.stances.append(support)
        super().change_stance(support, mount)

    def move(self, pose, q):
        if self.crash_after is not None and self.moves >= self.crash_after:
            raise KeyboardInterrupt
        self.moves += 1
        super().move(pose, q)


def test_interrupted_session_over_stances_resumes(op2, tmp_path):
    """Stopped after the stance change, resumed on the same folder: the journaled poses replay,
    the live robot is told the current stance before its first pose, and the result is the
    uninterrupted session's."""
    from sescid.session import Journal

    sensors = load_sensors(None, op2.profile)
    opt = SessionOptions(budget=45, kinds="cop", stances=("r_sole", "l_sole"), **SMALL)
    whole = run_session(op2, _Crashing(op2, sensors, seed=0), sensors, opt)
    k = next(i for i, s in enumerate(whole.steps) if s.stance == "l_sole")
    header = {"robot": "op2", "adapter": "kinematic"}
    journal = Journal.open(tmp_path / "s", header)
    with pytest.raises(KeyboardInterrupt):
        run_session(op2, _Crashing(op2, sensors, seed=0, crash_after=k + 2), sensors, opt,
                    journal=journal)  # fmt: skip
    bot = _Crashing(op2, sensors, seed=0)
    bot.rng = np.random.default_rng(12345)  # its noise differs from here on: not replayed
    res = run_session(op2, bot, sensors, opt, journal=Journal.open(tmp_path / "s", header))
    assert bot.stances == ["l_sole"] and bot.moves == len(res.steps) - (k + 2)
    assert [s.candidate for s in res.steps[: k + 2]] == [s.candidate for s in whole.steps[: k + 2]]
    assert [s.stance for s in res.steps[: k + 2]] == [s.stance for s in whole.steps[: k + 2]]
