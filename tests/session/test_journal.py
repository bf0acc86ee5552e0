"""Nothing lost: a session journals each pose, resumes where it stopped, checks its folder
first, and a replay never pairs unrelated poses."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from sescid.bench import ExperimentConfig, run_experiment
from sescid.cli import cli
from sescid.errors import DataError, SescidError
from sescid.planning import candidates
from sescid.sensors import load_sensors, table_from_columns
from sescid.session import (
    JOURNAL_NAME,
    Journal,
    ReplayAdapter,
    SessionOptions,
    load_adapter_class,
    run_session,
)

OPT = SessionOptions(budget=26, samples=6, n_candidates=300, window=3)
HEADER = {"robot": "op2", "adapter": "seeded"}


class Seeded:
    """A robot whose every pose's readings depend on the pose id only (so a resumed session
    sees what an uninterrupted one saw); it can be told to fail after some poses."""

    def __init__(self, robot, crash_after: int | None = None):
        self.robot = robot
        self.crash_after = crash_after
        self.moves: list[str] = []
        self.r_true = robot.sesc_vectors() * 1.01

    def move(self, pose, q):
        if self.crash_after is not None and len(self.moves) >= self.crash_after:
            raise KeyboardInterrupt  # the operator stops the robot
        self.moves.append(pose)
        rng = np.random.default_rng(int(pose))
        self.q = q + rng.uniform(-1, 1, q.shape) * math.radians(0.3)
        self.rng = rng

    def wait_settled(self):
        return "toppled: a test failure" if self.moves[-1] == "3" else ""

    def read(self, n):
        cop = self.robot.cop(self.q[None], self.r_true)[0]
        noisy = cop + self.rng.normal(0.0, 0.001, (n, 2))
        cols = {j: np.full(n, self.q[k]) for k, j in enumerate(self.robot.joint_names)}
        return cols | {"r_cop_x": noisy[:, 0], "r_cop_y": noisy[:, 1], "r_fz": np.full(n, 30.0)}

    def stop(self):
        pass


@pytest.fixture(scope="module")
def sensors(op2):
    return load_sensors(None, op2.profile)


def test_interrupted_session_resumes_to_the_same_result(op2, sensors, tmp_path):
    """Stopped after 7 poses, run again on the same folder: the 7 come from the journal (the
    robot is not asked again) and the result is the uninterrupted session's, bit for bit."""
    whole = run_session(op2, Seeded(op2), sensors, OPT)
    journal = Journal.open(tmp_path / "s", HEADER)
    with pytest.raises(KeyboardInterrupt):
        run_session(op2, Seeded(op2, crash_after=7), sensors, OPT, journal=journal)
    lines = (tmp_path / "s" / JOURNAL_NAME).read_text().splitlines()
    assert len(lines) == 1 + 7  # header + one line per commanded pose, on disk already
    assert json.loads(lines[4])["why"] == "toppled: a test failure"
    again = Journal.open(tmp_path / "s", HEADER)
    assert len(again.entries) == 7 and not again.finished
    bot = Seeded(op2)
    res = run_session(op2, bot, sensors, OPT, journal=again)
    assert bot.moves[0] == "7"  # the robot continues with the first pose not journaled
    assert [s.candidate for s in res.steps] == [s.candidate for s in whole.steps]
    assert np.array_equal(res.fit.r, whole.fit.r) and res.stop_reason == whole.stop_reason
    for k in whole.raw:
        assert np.array_equal(res.raw[k], whole.raw[k]), k
    again.finish(res.stop_reason)
    done = Journal.open(tmp_path / "s", HEADER)  # finished: replays to the end, robot still
    idle = Seeded(op2, crash_after=0)
    replayed = run_session(op2, idle, sensors, OPT, journal=done)
    assert done.finished and not idle.moves and np.array_equal(replayed.fit.r, whole.fit.r)
    with pytest.raises(DataError, match="other settings .*adapter"):
        Journal.open(tmp_path / "s", HEADER | {"adapter": "another"})
    assert Journal.open(tmp_path / "s", HEADER, restart=True).entries == []
    # a journal without a measured pose yet (the session failed before) starts afresh
    assert Journal.open(tmp_path / "s", HEADER | {"adapter": "another"}).entries == []


def test_a_journal_cut_mid_line_loses_only_that_pose(op2, sensors, tmp_path):
    journal = Journal.open(tmp_path / "s", HEADER)
    with pytest.raises(KeyboardInterrupt):
        run_session(op2, Seeded(op2, crash_after=4), sensors, OPT, journal=journal)
    path = tmp_path / "s" / JOURNAL_NAME
    path.write_text(path.read_text()[:-40])  # a crash while writing the last line
    assert len(Journal.open(tmp_path / "s", HEADER).entries) == 3


def test_the_output_folder_is_checked_before_the_first_pose(op2, tmp_path):
    """An output folder that cannot be created fails before the robot moves, in one line."""
    blocker = tmp_path / "file.txt"
    blocker.write_text("not a folder")
    with pytest.raises(DataError, match="cannot create the output folder"):
        Journal.open(blocker / "out", HEADER)
    args = ["session", "--adapter", "kinematic", "--budget", "21", "--no-view"]
    res = CliRunner().invoke(cli, [*args, "--out-dir", str(blocker / "out")])
    assert res.exit_code == 2 and res.output.count("\n") == 1
    assert "[1/" not in res.output


def test_cli_session_resumes_and_force_starts_over(tmp_path):
    """The kinematic bench as the robot: a finished folder replays to the same files; other
    options are refused with a hint; --force runs it anew; the CLI's defaults are
    SessionOptions'."""
    run = CliRunner().invoke
    args = ["session", "--adapter", "kinematic", "--budget", "22", "--samples", "6"]
    args += ["--candidates", "300", "--no-view", "--out-dir", str(tmp_path / "k")]
    res = run(cli, args)
    assert res.exit_code == 0, res.output
    first = (tmp_path / "k" / "session.json").read_text()
    res = run(cli, args)
    assert res.exit_code == 0 and "replaying it" in res.output, res.output
    assert (tmp_path / "k" / "session.json").read_text() == first
    res = run(cli, [*args, "--seed", "3"])
    assert res.exit_code == 2 and "other settings" in res.output and "--force" in res.output
    res = run(cli, [*args, "--seed", "3", "--force"])
    assert res.exit_code == 0, res.output
    params = {p.name: p.default for p in cli.get_command(None, "session").params}
    opt = SessionOptions()
    for name in ("budget", "samples", "seed", "near", "window", "tol", "target_std"):
        assert params[name] == getattr(opt, name), name
    assert params["candidates"] == opt.n_candidates


def test_replaying_an_experiment_log_never_pairs_unrelated_poses(op2, sensors):
    """An experiment's raw log has poses '0', '1', … like a session, but other poses: the
    replay refuses instead of feeding pose 0's samples to the session's pose 0."""
    q = candidates(op2, 30, seed=5).q
    ex = run_experiment(op2, q, sensors, samples=6, seed=0, config=ExperimentConfig())
    bot = ReplayAdapter(table_from_columns(ex.columns), op2.joint_names, servo=op2.profile.servo)
    with pytest.raises(DataError, match="not this session's recording"):
        run_session(op2, bot, sensors, OPT)


def test_replay_matches_a_recorded_pose_by_its_joint_values(op2, sensors):
    """Without the pose list, a command whose id is not in the log takes the recorded pose
    whose read-backs match it; one that matches nothing is a failed pose, not a pairing."""
    q = candidates(op2, 4, seed=6).q
    cfg = ExperimentConfig(backlash_deg=0.5)
    ids = np.array(["a", "b", "c", "d"])
    ex = run_experiment(op2, q, sensors, samples=6, seed=0, config=cfg, pose_ids=ids)
    bot = ReplayAdapter(table_from_columns(ex.columns), op2.joint_names, servo=op2.profile.servo)
    bot.move("7", q[2])
    assert bot.wait_settled() == ""
    assert np.array_equal(bot.read(6)["r_fsr1"], ex.columns["r_fsr1"][ex.columns["pose"] == "c"])
    bot.move("8", q[2] + 0.3)
    assert "not in the recorded log" in bot.wait_settled()


def test_adapter_with_a_syntax_error_is_one_line(tmp_path):
    bad = tmp_path / "robot.py"
    bad.write_text("class Robot:\n    def move(self, pose, q)\n        pass\n")
    with pytest.raises(SescidError, match=r"robot.py, line 2: .*SyntaxError"):
        load_adapter_class(f"{bad}:Robot")
    boom = tmp_path / "boom.py"
    boom.write_text("raise RuntimeError('no robot on the bus')\n")
    with pytest.raises(SescidError, match="RuntimeError: no robot on the bus"):
        load_adapter_class(f"{boom}:Robot")
    res = CliRunner().invoke(
        cli,
        [
            "session",
            "--adapter",
            f"python:{bad}:Robot",
            "--no-view",
            "--out-dir",
            str(tmp_path / "o"),
        ],
    )
    assert res.exit_code == 2 and res.output.count("\n") == 1 and "SyntaxError" in res.output
