"""Joint torques from bags (``tau_<joint>`` columns, N·m): a JointState's effort by name, and a
vendor low-level state by motor index, with or without foot sensors."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("rosbags")

from bag_gen import FOOT_TYPE, LATENCY, make_session, mapping_dict, write_bag  # noqa: E402
from bag_torque_gen import (  # noqa: E402
    LOW_MSG,
    LOW_TYPE,
    MOTOR_MSG,
    MOTOR_TYPE,
    TorqueBuilder,
    motor_layout,
)

from sescid.errors import SescidError  # noqa: E402
from sescid.io.bags import parse_mapping, read_bag  # noqa: E402


def effort_topics(s, b, joint_names, rng):
    """Joint states with efforts (first joint renamed in the bag, one extra joint) and right
    pads; returns the topics and the efforts (nj, nq) N·m as written."""
    names = ["R_SHO_PITCH", *joint_names[1:], "extra_joint"]
    effort = 2.0 * s.q + rng.normal(0, 0.05, s.q.shape)
    js = [
        (t + LATENCY, b.joint_state_effort(t, names, [*q, 9.0], [*e, -7.0]))
        for t, q, e in zip(s.t_joint, s.q, effort, strict=True)
    ]
    pads = [(t + LATENCY, b.foot(t, f)) for t, f in zip(s.t_force, s.pads, strict=True)]
    topics = {
        "/joint_states": ("sensor_msgs/msg/JointState", js),
        "/r_foot/fsr": (FOOT_TYPE, pads),
    }
    return topics, effort


def test_joint_state_effort_beside_the_pads(tmp_path, robot):
    """Each row's torques are the efforts of the joint state its angles come from, by name."""
    s = make_session(robot.joint_names, n_poses=3)
    b = TorqueBuilder()
    topics, effort = effort_topics(s, b, robot.joint_names, np.random.default_rng(1))
    path = write_bag(tmp_path / "s", "mcap", topics, b)
    mp = mapping_dict(torques={"topic": "/joint_states"})
    del mp["feet"]["left"]
    res = read_bag(path, parse_mapping(mp), robot.joint_names)
    taus = [f"tau_{j}" for j in robot.joint_names]
    names = list(res.columns)
    assert names[2 : 2 + robot.nq] == robot.joint_names
    assert names[2 + robot.nq : 2 + 2 * robot.nq] == taus  # beside the joint angles
    assert "tau_extra_joint" not in res.columns
    kept = np.isin(s.t_force - s.t_joint[0], np.round(res.columns["t"] * 1e9).astype(int))
    ij = np.abs(s.t_joint[None, :] - s.t_force[kept][:, None]).argmin(axis=1)
    tau = np.column_stack([res.columns[c] for c in taus])
    assert np.array_equal(tau, effort[ij])  # renamed joint included (tau_r_sho_pitch)
    assert [g.pose for g in res.segments] == ["0", "1", "2"]


def test_joint_state_effort_without_foot_sensors(tmp_path, robot):
    """No feet: the joint states are the rows; torques in mN·m are scaled to N·m."""
    s = make_session(robot.joint_names, n_poses=2)
    b = TorqueBuilder()
    topics, effort = effort_topics(s, b, robot.joint_names, np.random.default_rng(2))
    del topics["/r_foot/fsr"]
    path = write_bag(tmp_path / "s", "sqlite3", topics, b)
    mp = mapping_dict(torques={"topic": "/joint_states", "unit": "mN.m", "scale": 2.0})
    del mp["feet"]
    res = read_bag(path, parse_mapping(mp), robot.joint_names)
    kept = np.isin(s.t_joint - s.t_joint[0], np.round(res.columns["t"] * 1e9).astype(int))
    assert res.n == kept.sum() > 100
    assert np.array_equal(res.columns[robot.joint_names[3]], s.q[kept, 3])
    assert np.allclose(res.columns[f"tau_{robot.joint_names[3]}"], 2e-3 * effort[kept, 3], 0, 1e-15)
    assert not any(c.endswith("_fsr1") for c in res.columns)


def low_state_bag(path, s, b, names):
    """A bag holding only low states (no header: receive times), one per joint sample, whose
    motors carry the session's angles and torques 3·q − 0.2 (float32)."""
    slot = {j: i for i, j in enumerate(names) if j}
    msgs = []
    for k, (t, q) in enumerate(zip(s.t_joint, s.q, strict=True)):
        qm, tm = np.zeros(len(names)), np.zeros(len(names))
        for c, j in enumerate(s.joint_names):
            qm[slot[j]], tm[slot[j]] = q[c], 3 * q[c] - 0.2
        msgs.append((t, b.low_state(k, qm, tm)))
    return write_bag(path, "mcap", {"/lowstate": (LOW_TYPE, msgs)}, b)


def low_state_mapping(names, **over) -> dict:
    m = {
        "format": "sescid-bag-mapping/1",
        "joints": {"topic": "/lowstate", "kind": "array", "field": "motor_state.q", "names": names},
        "torques": {
            "topic": "/lowstate",
            "kind": "array",
            "field": "motor_state.tau_est",
            "names": names,
        },
        "types": {MOTOR_TYPE: MOTOR_MSG, LOW_TYPE: LOW_MSG},
    }
    return m | over


def test_low_state_by_motor_index(tmp_path, robot):
    """A Unitree-style LowState: angles and tau_est of motor i go to the joint named at i."""
    s = make_session(robot.joint_names, n_poses=3)
    s.joint_names = robot.joint_names
    b = TorqueBuilder()
    names = motor_layout(robot.joint_names)
    path = low_state_bag(tmp_path / "s", s, b, names)
    res = read_bag(path, parse_mapping(low_state_mapping(names)), robot.joint_names)
    kept = np.isin(s.t_joint - s.t_joint[0], np.round(res.columns["t"] * 1e9).astype(int))
    q32 = s.q.astype(np.float32).astype(float)
    tau32 = (3 * s.q - 0.2).astype(np.float32).astype(float)
    for c, j in enumerate(robot.joint_names):
        assert np.array_equal(res.columns[j], q32[kept, c])
        assert np.array_equal(res.columns[f"tau_{j}"], tau32[kept, c])
    assert [g.pose for g in res.segments] == ["0", "1", "2"]
    assert res.dropped["moving"] == (~kept).sum()


def test_torques_of_some_joints_only(tmp_path, robot):
    """A names list that maps a subset of the joints gives only their tau columns."""
    s = make_session(robot.joint_names, n_poses=2)
    s.joint_names = robot.joint_names
    b = TorqueBuilder()
    names = motor_layout(robot.joint_names)
    path = low_state_bag(tmp_path / "s", s, b, names)
    legs = [j if j and j.endswith(("knee", "ank_pitch")) else None for j in names]
    mp = low_state_mapping(names)
    mp["torques"]["names"] = legs
    res = read_bag(path, parse_mapping(mp), robot.joint_names)
    taus = sorted(c for c in res.columns if c.startswith("tau_"))
    assert taus == sorted(f"tau_{j}" for j in legs if j) and len(taus) == 4


BAD = [
    ({"names": ["a", "a"]}, "torques.names: joint 'a' appears twice"),
    ({"names": ["a"], "index": {"a": 0}}, "torques.names: give one of names"),
    ({"unit": "Nm"}, "torques.unit: expected one of N.m, mN.m"),
    ({"scale": 0}, "torques.scale: must be > 0"),
    ({"kind": "joint_state"}, "torques.names: only for kind: array"),
    ({"names": "a b"}, "torques.names: expected a list of joint names"),
]


@pytest.mark.parametrize(("over", "match"), BAD)
def test_torque_mapping_errors(over, match):
    mp = low_state_mapping(["a"])
    mp["torques"] = mp["torques"] | over
    with pytest.raises(SescidError, match=match) as exc:
        parse_mapping(mp, "map.yaml")
    assert str(exc.value).startswith("map.yaml: ") and "\n" not in str(exc.value)


def test_no_feet_and_no_torques_is_refused():
    mp = mapping_dict()
    del mp["feet"]
    with pytest.raises(SescidError, match="feet: expected .* at least one foot .*torques"):
        parse_mapping(mp, "map.yaml")


def test_torque_joint_errors_name_the_field(tmp_path, robot):
    """A motor named after no joint of the robot, or a JointState with none of its joints."""
    s = make_session(robot.joint_names, n_poses=2)
    s.joint_names = robot.joint_names
    b = TorqueBuilder()
    names = motor_layout(robot.joint_names)
    path = low_state_bag(tmp_path / "s", s, b, names)
    mp = low_state_mapping(names)
    mp["torques"]["names"] = ["elbow_joint"]
    with pytest.raises(SescidError, match=r"map.yaml: torques: 'elbow_joint' is not a joint"):
        read_bag(path, parse_mapping(mp, "map.yaml"), robot.joint_names)
    mp = low_state_mapping(names)
    mp["torques"]["field"] = "motor_state.tau"
    with pytest.raises(SescidError, match=r"has no field 'motor_state.tau' \(fields: mode, q"):
        read_bag(path, parse_mapping(mp, "map.yaml"), robot.joint_names)


def test_cli_bag_writes_torque_columns(tmp_path, robot):
    """`sescid bag` on a low-state bag with no foot sensor writes joints and tau columns."""
    from click.testing import CliRunner

    from sescid.cli import cli
    from sescid.tables import read_table

    s = make_session(robot.joint_names, n_poses=2)
    s.joint_names = robot.joint_names
    b = TorqueBuilder()
    names = motor_layout(robot.joint_names)
    path = low_state_bag(tmp_path / "s", s, b, names)
    (tmp_path / "map.json").write_text(json.dumps(low_state_mapping(names)))
    out = tmp_path / "raw.csv"
    res = CliRunner().invoke(
        cli, ["bag", str(path), "--map", str(tmp_path / "map.json"), "--out", str(out)]
    )
    assert res.exit_code == 0, res.output
    assert "2 pose segments" in res.output
    tab = read_table(out)
    assert {f"tau_{j}" for j in robot.joint_names} <= set(tab.names())
    assert tab.n > 100


def test_joint_states_without_efforts_are_refused(tmp_path, robot):
    """torques: on a JointState whose effort arrays are all empty: one line, not NaN columns."""
    from bag_gen import session_topics

    s = make_session(robot.joint_names, n_poses=2)
    b = TorqueBuilder()
    path = write_bag(tmp_path / "s", "mcap", session_topics(s, b, robot.joint_names), b)
    mp = mapping_dict(torques={"topic": "/joint_states"})
    with pytest.raises(SescidError, match=r"no message on /joint_states has effort values") as e:
        read_bag(path, parse_mapping(mp, "map.yaml"), robot.joint_names)
    assert "map.yaml: torques.field" in str(e.value) and "\n" not in str(e.value)
