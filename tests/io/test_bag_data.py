"""Bags that would lose or misread data: a clock that steps back, a recording in degrees, joint
states split over publishers or lacking a joint, an output inside the recording."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("rosbags")

from bag_gen import (  # noqa: E402
    LATENCY,
    Builder,
    make_session,
    mapping_dict,
    session_topics,
    write_bag,
)

from sescid.errors import SescidError  # noqa: E402
from sescid.io.bags import parse_mapping, read_bag  # noqa: E402


def _pads_only(**over):
    mp = mapping_dict(**over)
    del mp["feet"]["left"]
    return mp


def stepped_back(s, b, joint_names, shift_s=30.0):
    """The session's topics with every header stamp from the third pose on moved back by
    ``shift_s`` (a restarted sender clock); the bag's receive times run on."""
    topics = session_topics(s, b, joint_names)
    cut = s.pose_times[4][0]  # the third hold starts here
    back = int(shift_s * 1e9)
    out = {}
    for name, (typ, msgs) in topics.items():
        new = []
        for recv, msg in msgs:
            stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            if stamp >= cut:
                t = stamp - back
                msg.header.stamp = type(msg.header.stamp)(sec=t // 10**9, nanosec=t % 10**9)
            new.append((recv, msg))
        out[name] = (typ, new)
    return out


def test_clock_stepping_back_keeps_every_pose(tmp_path, robot):
    """Header stamps that jump back 30 s: every pose is still found (on the receive times), and
    a note says how often the clock stepped back."""
    s = make_session(robot.joint_names, n_poses=4)
    b = Builder(ros1=False)
    path = write_bag(tmp_path / "s", "mcap", stepped_back(s, b, robot.joint_names), b)
    res = read_bag(path, parse_mapping(_pads_only()), robot.joint_names)
    assert [g.pose for g in res.segments] == ["0", "1", "2", "3"]
    note = next(n for n in res.notes if "step back" in n)
    assert "'/joint_states': the header stamps step back 1 time(s) by up to 30 s" in note
    assert "receive times" in note
    # the same bag read with header stamps only lost poses before; now it is refused
    mp = _pads_only()
    mp["joints"]["stamp"] = "header"
    with pytest.raises(SescidError, match="joints: stamp: header, but '/joint_states'") as exc:
        read_bag(path, parse_mapping(mp, "map.yaml"), robot.joint_names)
    assert "\n" not in str(exc.value) and "stamp: receive" in str(exc.value)


def test_messages_slightly_out_of_order_are_sorted(tmp_path, robot):
    """Stamps out of order by less than the tolerance are sorted silently (nothing lost)."""
    s = make_session(robot.joint_names, n_poses=2)
    b = Builder(ros1=False)
    topics = session_topics(s, b, robot.joint_names)
    typ, js = topics["/joint_states"]
    js[10], js[11] = (js[10][0], js[11][1]), (js[11][0], js[10][1])  # swap two stamps
    path = write_bag(tmp_path / "s", "sqlite3", topics, b)
    res = read_bag(path, parse_mapping(_pads_only()), robot.joint_names)
    assert [g.pose for g in res.segments] == ["0", "1"]
    assert not any("step back" in n for n in res.notes)


def test_recording_in_degrees(tmp_path, robot):
    """Angles in degrees under unit: rad: one line naming the bag, the message and the joint
    (was an IndexError with a pose list); unit: deg reads them."""
    s = make_session(robot.joint_names, n_poses=2)
    b = Builder(ros1=False)
    s_deg = make_session(robot.joint_names, n_poses=2)
    s_deg.q = np.degrees(s.q)
    path = write_bag(tmp_path / "s", "mcap", session_topics(s_deg, b, robot.joint_names), b)
    plan = (np.array(["a"]), np.zeros((1, robot.nq)))
    with pytest.raises(SescidError, match="looks like degrees") as exc:
        read_bag(path, parse_mapping(_pads_only(), "map.yaml"), robot.joint_names, poses=plan)
    msg = str(exc.value)
    assert msg.startswith(str(path)) and "/joint_states" in msg and "joints.unit: deg" in msg
    mp = _pads_only()
    mp["joints"]["unit"] = "deg"
    res = read_bag(path, parse_mapping(mp), robot.joint_names)
    assert [g.pose for g in res.segments] == ["0", "1"]
    assert np.abs(res.columns[robot.joint_names[2]]).max() < 0.5


def test_no_segment_with_a_pose_list(tmp_path, robot):
    """No still run long enough and a planned pose list: nothing kept, no IndexError."""
    s = make_session(robot.joint_names, n_poses=2)
    b = Builder(ros1=False)
    path = write_bag(tmp_path / "s", "mcap", session_topics(s, b, robot.joint_names), b)
    plan = (np.array(["a"]), np.zeros((1, robot.nq)))
    res = read_bag(
        path, parse_mapping(_pads_only(stationary={"dwell": 5.0})), robot.joint_names, poses=plan
    )
    assert res.n == 0 and res.dropped["moving"] > 0 and "no sample kept" in res.notes[-1]


def split_publishers(s, b, joint_names):
    """Joint states from two publishers on one topic: the first half of the joints at even
    samples, the second half at odd ones (5 ms apart)."""
    topics = session_topics(s, b, joint_names)
    half = len(joint_names) // 2
    names = ["R_SHO_PITCH", *joint_names[1:]]
    msgs = []
    for k, (t, q) in enumerate(zip(s.t_joint, s.q, strict=True)):
        part = slice(0, half) if k % 2 == 0 else slice(half, None)
        msgs.append((t + LATENCY, b.joint_state(t, names[part], q[part])))
    topics["/joint_states"] = ("sensor_msgs/msg/JointState", msgs)
    return topics


def test_joint_states_from_two_publishers_are_merged(tmp_path, robot):
    """Each row takes every joint's latest value: no NaN, no pose lost to 'moving'."""
    s = make_session(robot.joint_names, n_poses=3)
    b = Builder(ros1=False)
    path = write_bag(tmp_path / "s", "mcap", split_publishers(s, b, robot.joint_names), b)
    res = read_bag(path, parse_mapping(_pads_only()), robot.joint_names)
    q = np.column_stack([res.columns[j] for j in robot.joint_names])
    assert np.isfinite(q).all()
    assert [g.pose for g in res.segments] == ["0", "1", "2"]
    assert res.dropped["missing_joint"] <= 1  # the first message has half the joints


def test_a_joint_that_stops_reporting(tmp_path, robot):
    """A joint absent from the joint states for a stretch: those rows are dropped as
    missing_joint (not counted as moving) and the poses around it are kept."""
    s = make_session(robot.joint_names, n_poses=3)
    b = Builder(ros1=False)
    topics = session_topics(s, b, robot.joint_names)
    typ, js = topics["/joint_states"]
    t_rel = (s.t_joint - s.t_joint[0]) * 1e-9
    gap = (t_rel > 1.9) & (t_rel < 2.2)  # inside the second hold (1.6–2.6 s)
    names = ["R_SHO_PITCH", *robot.joint_names[1:], "extra_joint"]
    for k in np.flatnonzero(gap):
        recv, _ = js[k]
        t = s.t_joint[k]
        js[k] = (recv, b.joint_state(t, names[:-2], s.q[k, :-1]))  # the last joint is missing
    path = write_bag(tmp_path / "s", "mcap", topics, b)
    res = read_bag(path, parse_mapping(_pads_only()), robot.joint_names)
    assert res.dropped["missing_joint"] > 10
    full = read_bag(
        write_bag(tmp_path / "f", "mcap", session_topics(s, b, robot.joint_names), b),
        parse_mapping(_pads_only()),
        robot.joint_names,
    )
    assert res.dropped["moving"] <= full.dropped["moving"]
    assert {g.pose for g in res.segments} >= {"0", "2"}
    assert np.isfinite(res.columns[robot.joint_names[-1]]).all()


def test_cli_bag_refuses_an_output_inside_the_recording(tmp_path, robot):
    """`sescid bag rec --out rec/raw.csv` is refused; the recording folder is left as it was."""
    from click.testing import CliRunner

    from sescid.cli import cli

    s = make_session(robot.joint_names, n_poses=2)
    b = Builder(ros1=False)
    path = write_bag(tmp_path / "rec", "sqlite3", session_topics(s, b, robot.joint_names), b)
    import json

    (tmp_path / "map.json").write_text(json.dumps(_pads_only()))
    before = sorted(p.name for p in path.iterdir())
    for out in (path / "raw.csv", path / "metadata.yaml"):
        res = CliRunner().invoke(
            cli, ["bag", str(path), "--map", str(tmp_path / "map.json"), "--out", str(out)]
        )
        assert res.exit_code == 2 and "inside the input" in res.output, res.output
        assert res.output.count("\n") == 1
    assert sorted(p.name for p in path.iterdir()) == before
