"""Nothing lost: a session journals each pose, resumes where it stopped, checks its folder
first, and a replay never pairs unrelated poses."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

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
HEADER = {"robot": "op2", "adapter": "seeded", "options": {"seed": 0}}


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
    # an option added after the journal was written resumes at its default, not otherwise
    new = HEADER | {"options": HEADER["options"] | {"added_option": 1.5}}
    assert Journal.open(tmp_path / "s", new, defaults={"added_option": 1.5}).entries
    with pytest.raises(DataError, match="other settings .*options"):
        Journal.open(tmp_path / "s", new, defaults={"added_option": 2.0})
    with pytest.raises(DataError, match="other settings .*options"):
        Journal.open(tmp_path / "s", new)
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
    args = ["session", "--adapter", "kinematic", "--budget", "22", "--no-view"]
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


# --- hostile journals and adapters (issue 27): one line, the journal resumable or gone -------


def _journaled(op2, sensors, folder, poses: int) -> list[str]:
    """A journal of ``poses`` commanded poses in ``folder`` (its lines)."""
    journal = Journal.open(folder, HEADER)
    with pytest.raises(KeyboardInterrupt):
        run_session(op2, Seeded(op2, crash_after=poses), sensors, OPT, journal=journal)
    return (folder / JOURNAL_NAME).read_text().splitlines()


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda lines: b"\x89PNG\r\n\x1a\n\xff\xfe" * 40, "not a session journal"),
        (lambda lines: b"", "not a session journal"),
        (lambda lines: b"[1, 2]\n", "not a session journal"),
        (lambda lines: _edit(lines, 2, lambda r: r.pop("q")), "line 3: the pose record has no 'q'"),
        (lambda lines: _edit(lines, 1, lambda r: r.pop("pose")), "line 2: the pose record has no"),
        (lambda lines: _edit(lines, 2, lambda r: r.update(q="abc")), "line 3: 'q' is not a list"),
        (lambda lines: _edit(lines, 2, lambda r: r.update(q=[None])), "line 3: 'q' is not a list"),
        (
            lambda lines: _edit(lines, 2, lambda r: r["columns"].update(r_fz=[[1, 2]])),
            "line 3: column 'r_fz' is not a list of samples",
        ),
        (lambda lines: _edit(lines, 2, lambda r: r.update(columns=[1])), "line 3: 'columns'"),
        (
            lambda lines: "\n".join([*lines[:2], "\x00garbage", *lines[2:]]).encode() + b"\n",
            "line 3 is not a journal record",
        ),
    ],
)
def test_a_damaged_journal_is_one_line_naming_its_line(op2, sensors, tmp_path, damage, message):
    """Binary garbage, a record without q or pose, values of the wrong type: DataError naming
    the journal and its line, never a traceback; the file is left as it was."""
    lines = _journaled(op2, sensors, tmp_path / "s", 3)
    path = tmp_path / "s" / JOURNAL_NAME
    path.write_bytes(damage(lines))
    before = path.read_bytes()
    with pytest.raises(DataError, match=message) as exc:
        Journal.open(tmp_path / "s", HEADER)
    assert str(path) in str(exc.value) and "\n" not in str(exc.value)
    assert path.read_bytes() == before


def _edit(lines: list[str], k: int, change) -> bytes:
    rec = json.loads(lines[k])
    change(rec)
    return "\n".join([*lines[:k], json.dumps(rec), *lines[k + 1 :]]).encode() + b"\n"


def test_a_cut_journal_is_repaired_before_the_session_appends(op2, sensors, tmp_path):
    """A crash cut the last line: resuming cuts it off, so the next pose's record starts on a
    line of its own and the journal reads again afterwards (it used to be glued to the cut
    line, and the next run refused the journal)."""
    lines = _journaled(op2, sensors, tmp_path / "s", 5)
    path = tmp_path / "s" / JOURNAL_NAME
    path.write_text("\n".join(lines[:-1]) + "\n" + lines[-1][: len(lines[-1]) // 2])
    journal = Journal.open(tmp_path / "s", HEADER)
    assert len(journal.entries) == 4
    with pytest.raises(KeyboardInterrupt):
        run_session(op2, Seeded(op2, crash_after=2), sensors, OPT, journal=journal)
    again = Journal.open(tmp_path / "s", HEADER)
    assert [e.pose for e in again.entries] == [str(k) for k in range(6)]
    assert all(json.loads(line) for line in path.read_text().splitlines())


class Overloaded(Seeded):
    """A robot whose servo fails at one pose."""

    def move(self, pose, q):
        if pose == "5":
            raise RuntimeError("servo 12 overload")
        super().move(pose, q)


class Broken(Seeded):
    """A robot whose samples are wrong in one of several ways (``fault``)."""

    fault = ""

    def read(self, n):
        cols = super().read(n)
        if self.fault == "unequal":
            cols["r_cop_x"] = cols["r_cop_x"][:-1]
        elif self.fault == "no sensors":
            cols = {k: v for k, v in cols.items() if k not in ("r_cop_x", "r_cop_y", "r_fz")}
        elif self.fault == "text" and int(self.moves[-1]) >= 4:
            cols["r_cop_x"] = np.array(["0.001"] * (n - 1) + ["abc"])
        elif self.fault == "not columns":
            return [1, 2, 3]
        elif self.fault == "2-D":
            cols["r_fz"] = np.ones((n, 2))
        elif self.fault == "no samples":
            cols = {k: v[:0] for k, v in cols.items()}
        return cols


def test_an_adapter_that_raises_names_the_pose_and_keeps_the_journal(op2, sensors, tmp_path):
    """`RuntimeError: servo 12 overload` at pose 5: one DataError naming the adapter, the pose
    and the error; the journal holds poses 0–4 and a run with a working robot resumes there."""
    journal = Journal.open(tmp_path / "s", HEADER)
    with pytest.raises(DataError) as exc:
        run_session(op2, Overloaded(op2), sensors, OPT, journal=journal)
    text = str(exc.value)
    assert "Overloaded failed at pose 5: RuntimeError: servo 12 overload" in text
    assert "keeps the 5 poses journaled" in text and "\n" not in text
    bot = Seeded(op2)
    res = run_session(op2, bot, sensors, OPT, journal=Journal.open(tmp_path / "s", HEADER))
    assert bot.moves[0] == "5" and res.n_measured > 20


@pytest.mark.parametrize(
    ("fault", "message"),
    [
        ("unequal", r"pose 0: the columns differ in length \('r_cop_x' has 5; the others 6"),
        ("no sensors", "no foot-sensor columns"),
        ("not columns", "returned list, not columns by name"),
        ("2-D", "column 'r_fz' is not one value per sample"),
        ("no samples", "pose 0: read\\(\\) returned no samples"),
        ("text", r"adapter Robot: pose 4, sample 5, column 'r_cop_x': 'abc' is not a number"),
    ],
)
def test_bad_samples_are_one_line_and_never_journaled(tmp_path, fault, message):
    """Samples the session cannot read: one line naming the adapter, pose (and sample and
    column); a session that measured nothing leaves no journal or folder behind, one that
    did keeps the poses before the bad one (resumable), never the bad pose."""
    mod = tmp_path / "broken.py"
    mod.write_text(
        "import sys\n"
        f"sys.path.insert(0, {str(Path(__file__).parent)!r})\n"
        "from test_journal import Broken\n"
        f"class Robot(Broken):\n    fault = {fault!r}\n"
    )
    out = tmp_path / "out"
    args = ["session", "--adapter", f"python:{mod}:Robot", "--budget", "26", "--samples", "6"]
    res = CliRunner().invoke(cli, [*args, "--candidates", "300", "--no-view", "--out-dir", out])
    errors = [line for line in res.output.splitlines() if line.startswith("sescid: error: ")]
    assert res.exit_code == 2 and len(errors) == 1, res.output
    assert re.search(message, errors[0]) and res.output.endswith(errors[0] + "\n"), res.output
    if fault == "text":
        lines = (out / JOURNAL_NAME).read_text().splitlines()
        assert [json.loads(x)["pose"] for x in lines[1:]] == ["0", "1", "2", "3"]
        assert "keeps the 4 poses journaled before it" in res.output
    else:
        assert not out.exists()


def test_failed_replays_leave_no_journal(tmp_path):
    """A replay that diverges (other options) and a replay of an experiment's log (not a
    session's recording) fail before any pose is measured: no folder is left behind."""
    run = CliRunner().invoke
    base = ["session", "--budget", "22", "--samples", "6", "--candidates", "300", "--no-view"]
    res = run(cli, [*base, "--adapter", "kinematic", "--out-dir", str(tmp_path / "k")])
    assert res.exit_code == 0, res.output
    replay = [*base, "--adapter", "replay", "--replay", str(tmp_path / "k")]
    res = run(cli, [*replay, "--seed", "1", "--out-dir", str(tmp_path / "r1")])
    assert res.exit_code == 2 and "replay diverged at pose 0" in res.output, res.output
    raw = tmp_path / "exp.csv"
    poses = tmp_path / "p.csv"
    assert (
        run(cli, ["poses", "--count", "22", "--candidates", "300", "--out", poses]).exit_code == 0
    )
    assert run(cli, ["experiment", "--poses", poses, "--samples", "6", "--out", raw]).exit_code == 0
    replay = [*base, "--adapter", "replay", "--replay", str(raw)]
    res = run(cli, [*replay, "--out-dir", str(tmp_path / "r2")])
    assert res.exit_code == 2 and "not this session's recording" in res.output, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exp.csv", "k", "p.csv"]
