"""A recording's stance carried through: the bag mapping's ``support`` (a frame, or a String
topic naming it as it changes) or the planned poses' ``support`` column → the raw log's
``support`` column → ``measure`` reducing each stance's samples in its own frame → a pooled
``identify``."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("rosbags")

from bag_gen import (  # noqa: E402
    T0,
    Builder,
    make_session,
    mapping_dict,
    session_topics,
    write_bag,
)
from click.testing import CliRunner  # noqa: E402

from sescid.cli import cli  # noqa: E402
from sescid.errors import SescidError  # noqa: E402
from sescid.io.bags import parse_mapping, read_bag  # noqa: E402
from sescid.sensors import fsr, load_sensors  # noqa: E402
from sescid.sensors.raw import table_from_columns  # noqa: E402
from sescid.tables import (  # noqa: E402
    pose_ids,  # noqa: E402
    read_table,
    write_table,
)

STANCES = ["r_sole", "r_sole", "l_sole", "l_sole"]  # the session's four poses


def stance_bag(tmp_path, robot, names=STANCES):
    """The test session with a /stance String topic: each pose's stance, said as it starts."""
    s = make_session(robot.joint_names)
    b = Builder(ros1=False)
    topics = session_topics(s, b, robot.joint_names)
    said = [(t - 100_000_000, b.string(names[k])) for t, k in s.pose_times if k >= 0]
    topics["/stance"] = ("std_msgs/msg/String", said)
    return s, write_bag(tmp_path / "s", "mcap", topics, b)


def test_a_stance_topic_names_each_pose_and_measure_reduces_each_in_its_frame(tmp_path, robot):
    """The /stance topic's names become the log's support column (segments split where the
    stance changes); ``measure`` gives each pose's CoP in its own stance's frame — the numbers
    of reducing that stance's samples alone with the robot rooted there."""
    _, path = stance_bag(tmp_path, robot)
    mp = parse_mapping(mapping_dict(support={"topic": "/stance"}))
    res = read_bag(path, mp, robot=robot)
    assert [(g.pose, g.stance) for g in res.segments] == [
        (str(k), s) for k, s in enumerate(STANCES)
    ]
    assert res.dropped["no_support"] == 0
    # on one foot only that foot carries the weight (the synthetic session loads both)
    cols = dict(res.columns)
    left = cols["support"] == "l_sole"
    for k in range(1, 5):
        cols[f"r_fsr{k}"] = np.where(left, 0.0, cols[f"r_fsr{k}"])
    cols["l_fz"] = np.where(left, cols["l_fz"], 0.0)
    write_table(tmp_path / "raw.csv", cols)
    out = CliRunner().invoke(
        cli, ["measure", str(tmp_path / "raw.csv"), "--out", str(tmp_path / "m.csv")]
    )
    assert out.exit_code == 0, out.output
    table = read_table(tmp_path / "m.csv")
    assert [v.strip() for v in table.text["support"]] == STANCES
    ids = pose_ids(table)
    cop = np.column_stack([table.columns["cop_x"], table.columns["cop_y"]])
    sensors = load_sensors(profile=robot.profile)
    for stance in ("r_sole", "l_sole"):
        rows = res.columns["support"] == stance
        alone = table_from_columns({k: v[rows] for k, v in cols.items()})
        want, _ = fsr(robot.at(stance), alone, sensors)
        np.testing.assert_array_equal(cop[np.isin(ids, want.pose)], want.data.cop)
    # the frames differ: the left-sole poses are not the right sole's numbers
    left_rows = table_from_columns({k: v[left] for k, v in cols.items()})
    with pytest.raises(SescidError, match="off_floor"):
        fsr(robot, left_rows, sensors)  # on the right sole's plane the left foot is off it

    # and identify pools them: the left sole's poses fitted in its frame
    out = CliRunner().invoke(
        cli,
        [
            "identify",
            str(tmp_path / "m.csv"),
            "--allow-exact",
            "--allow-outside-limits",
            "--out",
            str(tmp_path / "f.json"),
        ],
    )
    assert out.exit_code == 0, out.output
    assert "l_sole" in out.output


def test_a_recording_in_one_stance_and_the_planned_stances(tmp_path, robot):
    """``support: l_sole`` names the whole recording's stance; without it, the planned pose
    list's ``support`` column gives each matched segment its pose's stance."""
    s, path = stance_bag(tmp_path, robot)
    res = read_bag(path, parse_mapping(mapping_dict(support="l_sole")), robot=robot)
    assert set(res.columns["support"]) == {"l_sole"}
    assert {g.stance for g in res.segments} == {"l_sole"}
    mid = [np.abs(s.t_joint - T0 - int((0.5 + 1.6 * k) * 1e9)).argmin() for k in range(4)]
    plan_ids = np.array(["a", "b", "c", "d"])
    plan_support = np.array(["double", "r_sole", "l_sole", "r_sole"])
    res = read_bag(
        path, parse_mapping(mapping_dict()), robot=robot, poses=(plan_ids, s.q[mid]),
        pose_support=plan_support,
    )  # fmt: skip
    assert [(g.pose, g.stance) for g in res.segments] == list(
        zip(plan_ids, plan_support, strict=True)
    )
    without = read_bag(path, parse_mapping(mapping_dict()), robot=robot)
    assert "support" not in without.columns and {g.stance for g in without.segments} == {""}


def test_stance_errors(tmp_path, robot):
    """An unknown stance is one line naming the mapping; samples before the stance topic's
    first name, or under an empty one, are left out as ``no_support``; a bad field is named."""
    _, path = stance_bag(tmp_path, robot, ["r_sole", "", "l_sole", "l_sole"])
    res = read_bag(path, parse_mapping(mapping_dict(support={"topic": "/stance"})), robot=robot)
    assert [g.pose for g in res.segments] == ["0", "2", "3"] and res.dropped["no_support"] > 0
    with pytest.raises(SescidError, match=r"map.yaml: support: .*unknown support 'l_foot'"):
        read_bag(path, parse_mapping(mapping_dict(support="l_foot"), "map.yaml"), robot=robot)
    with pytest.raises(SescidError, match=r"map.yaml: support: expected a name, got 3"):
        parse_mapping(mapping_dict(support=3), "map.yaml")
    with pytest.raises(SescidError, match=r"map.yaml: support.topic: missing"):
        parse_mapping(mapping_dict(support={"field": "data"}), "map.yaml")
