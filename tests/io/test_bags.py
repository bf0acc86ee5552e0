"""ROS bags → the fsr step's raw table (sescid.io.bags), on bags written with rosbags itself."""

from __future__ import annotations

import sys

import numpy as np
import pytest

pytest.importorskip("rosbags")

from bag_gen import (  # noqa: E402
    EXAMPLE,
    FOOT_TYPE,
    T0,
    Builder,
    Session,
    make_session,
    mapping_dict,
    sensor_wrench,
    session_topics,
    write_bag,
)

from sescid.errors import SescidError  # noqa: E402
from sescid.io.bags import BagMapping, load_mapping, parse_mapping, read_bag  # noqa: E402


def check_session(res, s: Session, joint_names, pose_names=None):
    """Segmentation and per-sample values as written."""
    n_poses = s.hold.max() + 1
    t_rel = (s.t_force - s.t_joint[0]) * 1e-9
    kept = np.isin(np.round(t_rel, 6), np.round(res.columns["t"], 6))
    # inner hold samples all kept, inner transition samples all dropped
    assert kept[s.inner & (s.hold >= 0)].all()
    assert not kept[s.inner & (s.hold < 0)].any()
    assert res.dropped["moving"] == (~kept).sum() and res.dropped["no_joint_state"] == 0
    names = pose_names or [str(k) for k in range(n_poses)]
    assert [g.pose for g in res.segments] == names
    expect = np.array(names)[s.hold[kept]]
    assert (res.columns["pose"] == expect).all()
    # joints: the nearest joint state, exactly; pads exactly as written (float32 mN)
    ij = np.abs(s.t_joint[None, :] - s.t_force[kept][:, None]).argmin(axis=1)
    for c, j in enumerate(joint_names):
        assert np.array_equal(res.columns[j], s.q[ij, c])
    for k in range(4):
        assert np.array_equal(res.columns[f"r_fsr{k + 1}"], s.pads[kept, k].astype(float))
    assert np.abs(res.columns["l_cop_x"] - s.cop[kept, 0]).max() < 1e-12
    assert np.abs(res.columns["l_cop_y"] - s.cop[kept, 1]).max() < 1e-12
    assert res.columns["l_fz"].min() > 25


@pytest.mark.parametrize("storage", ["sqlite3", "mcap", "ros1"])
def test_session_segmented_by_stationarity(tmp_path, robot, storage):
    """sqlite3, MCAP and ROS 1 bags give the held poses and the exact per-sample values."""
    s = make_session(robot.joint_names)
    b = Builder(ros1=storage == "ros1")
    path = tmp_path / ("s.bag" if storage == "ros1" else "s")
    write_bag(path, storage, session_topics(s, b, robot.joint_names), b)
    res = read_bag(path, parse_mapping(mapping_dict()), robot.joint_names)
    check_session(res, s, robot.joint_names)
    assert list(res.columns)[:3] == ["pose", "t", robot.joint_names[0]]
    for g in res.segments:
        assert g.end - g.start > 0.5 and g.samples > 25


def test_segments_take_the_planned_pose_ids(tmp_path, robot):
    """Given the pose list, each hold gets its planned pose's id; an unplanned hold is dropped."""
    s = make_session(robot.joint_names)  # holds start every 1.6 s
    b = Builder(ros1=False)
    path = write_bag(tmp_path / "s", "mcap", session_topics(s, b, robot.joint_names), b)
    mid = [np.abs(s.t_joint - T0 - int((0.5 + 1.6 * k) * 1e9)).argmin() for k in range(4)]
    q_held = s.q[mid]
    # planned: poses 3, 0, 1 under other ids, in another order, 0.5° off; one never run
    plan_q = np.array([q_held[3], q_held[0], q_held[1], q_held[0] + 0.5]) + np.radians(0.5)
    plan_ids = np.array(["p3", "p0", "p1", "never"])
    mp = parse_mapping(mapping_dict())
    res = read_bag(path, mp, robot.joint_names, poses=(plan_ids, plan_q))
    assert [g.pose for g in res.segments] == ["p0", "p1", "p3"]
    unplanned = read_bag(path, mp, robot.joint_names).columns["pose"] == "2"
    assert res.dropped["unmatched_pose"] == unplanned.sum() > 0
    assert any("segment 2 matches no planned pose within 3°" in n for n in res.notes)


@pytest.mark.parametrize("kind", ["int", "string"])
def test_pose_topic(tmp_path, robot, kind):
    """A pose-id topic (Int32 with −1, or String with '') names the poses instead."""
    s = make_session(robot.joint_names, n_poses=3)
    b = Builder(ros1=False)
    path = write_bag(
        tmp_path / "s", "mcap", session_topics(s, b, robot.joint_names, pose_topic=kind), b
    )
    res = read_bag(path, parse_mapping(mapping_dict(pose={"topic": "/pose_id"})), robot=robot)
    names = [str(k) for k in range(3)] if kind == "int" else [f"p{k}" for k in range(3)]
    expect = np.array(names)[s.hold[s.hold >= 0]]
    assert (res.columns["pose"] == expect).all()
    assert res.dropped["moving"] == (s.hold < 0).sum()
    assert [g.pose for g in res.segments] == names


def test_bag_without_definitions_needs_the_mapping_types(tmp_path, robot):
    """An old rosbag2 (no stored definitions) decodes the custom type from the mapping's .msg."""
    s = make_session(robot.joint_names, n_poses=2)
    b = Builder(ros1=False)
    path = write_bag(tmp_path / "s", "sqlite3", session_topics(s, b, robot.joint_names), b, False)
    res = read_bag(path, parse_mapping(mapping_dict()), robot.joint_names)
    check_session(res, s, robot.joint_names)
    with pytest.raises(SescidError, match="op2_msgs/msg/FootFsr.*types:"):
        read_bag(path, parse_mapping(mapping_dict(types={})), robot.joint_names)


def test_end_to_end_through_the_fsr_step(tmp_path, robot):
    """The pads table, written as CSV, gives the fsr step the session's CoP per pose."""
    from sescid.sensors import fsr, load_sensors
    from sescid.tables import read_table, write_table

    s = make_session(robot.joint_names)
    b = Builder(ros1=False)
    path = write_bag(tmp_path / "s", "sqlite3", session_topics(s, b, robot.joint_names), b)
    mp = mapping_dict()
    del mp["feet"]["left"]
    res = read_bag(path, parse_mapping(mp), robot.joint_names)
    write_table(tmp_path / "raw.csv", res.columns)
    measured, _ = fsr(robot, read_table(tmp_path / "raw.csv"), load_sensors(profile=robot.profile))
    want = np.array([s.cop[s.hold == k][0] for k in range(4)])
    assert measured.pose.tolist() == ["0", "1", "2", "3"]
    assert np.abs(measured.data.cop - want).max() < 2e-4  # pad noise 5 mN on 30 N


def test_array_joints_in_degrees_and_multiarray_pads(tmp_path, robot):
    """Float64MultiArray joints (deg, by index), both feet's pads in one Float32MultiArray."""
    s = make_session(robot.joint_names, n_poses=2)
    b = Builder(ros1=False)
    nq = len(robot.joint_names)
    perm = np.random.default_rng(5).permutation(nq)  # array position of each model joint
    js = []
    for t, q in zip(s.t_joint, s.q, strict=True):
        arr = np.zeros(nq)
        arr[perm] = np.degrees(q)
        js.append((t, b.array("Float64", arr)))
    both = [
        (t, b.array("Float32", np.r_[np.zeros(4), f]))
        for t, f in zip(s.t_force, s.pads, strict=True)
    ]
    path = write_bag(
        tmp_path / "s",
        "mcap",
        {
            "/dxl/positions": ("std_msgs/msg/Float64MultiArray", js),
            "/fsr/all": ("std_msgs/msg/Float32MultiArray", both),
        },
        b,
    )
    mp = mapping_dict(
        joints={
            "topic": "/dxl/positions",
            "kind": "array",
            "unit": "deg",
            "index": {j: int(perm[c]) for c, j in enumerate(robot.joint_names)},
        },
        feet={
            "right": {
                "source": "pads",
                "topic": "/fsr/all",
                "index": [4, 5, 6, 7],
                "unit": "N",
                "scale": 0.001,
            },
            "left": {"source": "pads", "topic": "/fsr/all"},  # same message, values 0..3
        },
    )
    res = read_bag(path, parse_mapping(mp), robot.joint_names)
    kept = np.isin(s.t_force - s.t_joint[0], np.round(res.columns["t"] * 1e9).astype(int))
    ij = np.abs(s.t_joint[None, :] - s.t_force[kept][:, None]).argmin(axis=1)
    q = np.column_stack([res.columns[j] for j in robot.joint_names])
    assert np.abs(q - s.q[ij]).max() < 1e-15
    assert np.abs(res.columns["r_fsr2"] - s.pads[kept, 1]).max() < 1e-9 * 3e4
    assert [g.pose for g in res.segments] == ["0", "1"]
    assert not res.columns["l_fsr4"].any()


def test_ready_cop_and_plate_sources(tmp_path, robot):
    """A PointStamped CoP (mm) and a four-cell plate (left foot) come out in the sole frame."""
    s = make_session(robot.joint_names, n_poses=2)
    b = Builder(ros1=False)
    topics = session_topics(s, b, robot.joint_names)
    del topics["/r_foot/fsr"], topics["/l_ankle/ft"]
    topics["/r_foot/cop"] = (
        "geometry_msgs/msg/PointStamped",
        [(t, b.point(t, xy * 1000)) for t, xy in zip(s.t_force, s.cop, strict=True)],
    )
    cells = np.array([[0.0, 0.0], [0.4, 0.0], [0.0, 0.3], [0.4, 0.3]])
    pose = (0.2, 0.15, 0.3)
    c, sn = np.cos(pose[2]), np.sin(pose[2])
    p_plate = np.array(pose[:2]) + s.cop @ np.array([[c, sn], [-sn, c]])
    u, v = p_plate[:, 0] / 0.4, p_plate[:, 1] / 0.3
    loads = 30 * np.stack([(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v], 1)
    topics["/plate"] = (
        "std_msgs/msg/Float64MultiArray",
        [(t, b.array("Float64", f)) for t, f in zip(s.t_force, loads, strict=True)],
    )
    path = write_bag(tmp_path / "s", "sqlite3", topics, b)
    mp = mapping_dict(
        feet={
            "right": {"source": "cop", "topic": "/r_foot/cop", "unit": "mm"},
            "left": {
                "source": "plate",
                "topic": "/plate",
                "cells_m": cells.tolist(),
                "foot_pose": list(pose),
                "stamp": "receive",
            },
        }
    )
    res = read_bag(path, parse_mapping(mp), robot.joint_names)
    kept = np.isin(s.t_force - s.t_joint[0], np.round(res.columns["t"] * 1e9).astype(int))
    assert "r_fz" not in res.columns
    assert np.abs(res.columns["r_cop_x"] - s.cop[kept, 0]).max() < 1e-15
    assert np.abs(res.columns["l_cop_y"] - s.cop[kept, 1]).max() < 1e-14
    assert np.allclose(res.columns["l_fz"], 30)


def test_wrench_sensor_frame_from_the_model(tmp_path, robot):
    """A sensor_link frame follows the model's kinematics at each sample's joint angles."""
    s = make_session(robot.joint_names, n_poses=2)
    b = Builder(ros1=False)
    # the left ankle roll link as sensor frame: its pose in l_sole is fixed by the URDF
    q0 = np.zeros((1, len(robot.joint_names)))
    r_sole, p_sole = robot.link_poses(q0, "l_sole")
    r_s, p_s = robot.link_poses(q0, "MP_ANKLE2_L")
    rot = (r_sole[0].T @ r_s[0])[None]
    pos = (r_sole[0].T @ (p_s[0] - p_sole[0]))[None]
    n = len(s.t_force)
    f_ground = np.column_stack([np.zeros((n, 2)), np.full(n, 20.0)])
    f, tq = sensor_wrench(s.cop, f_ground, np.zeros(n), np.repeat(rot, n, 0), pos)
    topics = session_topics(s, b, robot.joint_names)
    topics["/l_ankle/ft"] = (
        "geometry_msgs/msg/WrenchStamped",
        [(t, b.wrench(t, w)) for t, w in zip(s.t_force, np.hstack([f, tq]), strict=True)],
    )
    mp = mapping_dict()
    left = mp["feet"]["left"]
    del left["sensor_in_sole"], left["foot_mass"], left["foot_com"]
    left |= {"sensor_link": "MP_ANKLE2_L", "sole_frame": "l_sole"}
    path = write_bag(tmp_path / "s", "mcap", topics, b)
    res = read_bag(path, parse_mapping(mp), robot=robot)
    kept = np.isin(s.t_force - s.t_joint[0], np.round(res.columns["t"] * 1e9).astype(int))
    assert np.abs(res.columns["l_cop_x"] - s.cop[kept, 0]).max() < 1e-12
    with pytest.raises(SescidError, match="sensor_link needs the robot"):
        read_bag(path, parse_mapping(mp), robot.joint_names)


def test_empty_bag_and_missing_topic(tmp_path, robot):
    """A bag without messages or without a mapped topic is a one-line error naming the topic."""
    b = Builder(ros1=False)
    empty = write_bag(
        tmp_path / "e",
        "sqlite3",
        {
            "/joint_states": ("sensor_msgs/msg/JointState", []),
            "/r_foot/fsr": (FOOT_TYPE, []),
            "/l_ankle/ft": ("geometry_msgs/msg/WrenchStamped", []),
        },
        b,
    )
    with pytest.raises(SescidError, match="topic '/joint_states' has no messages"):
        read_bag(empty, parse_mapping(mapping_dict()), robot.joint_names)
    nothing = write_bag(tmp_path / "n", "mcap", {}, b)
    with pytest.raises(SescidError, match="no topic '/joint_states'.*no topics"):
        read_bag(nothing, parse_mapping(mapping_dict()), robot.joint_names)
    s = make_session(robot.joint_names, n_poses=2)
    topics = session_topics(s, b, robot.joint_names)
    del topics["/l_ankle/ft"]
    path = write_bag(tmp_path / "m", "sqlite3", topics, b)
    with pytest.raises(SescidError) as exc:
        read_bag(path, parse_mapping(mapping_dict()), robot.joint_names)
    msg = str(exc.value)
    assert "no topic '/l_ankle/ft'" in msg and "feet.left.topic" in msg and "/r_foot/fsr" in msg
    with pytest.raises(SescidError, match="bag not found"):
        read_bag(tmp_path / "absent", parse_mapping(mapping_dict()), robot.joint_names)


def test_bag_content_errors(tmp_path, robot):
    """Unknown joints, wrong types and short arrays are one-line errors naming the mapping field."""
    s = make_session(robot.joint_names, n_poses=2)
    b = Builder(ros1=False)
    path = write_bag(tmp_path / "s", "mcap", session_topics(s, b, robot.joint_names), b)
    cases = [
        (mapping_dict(joints={"topic": "/joint_states"}), "joint 'r_sho_pitch' is not in"),
        (
            mapping_dict(
                joints={"topic": "/r_foot/fsr", "kind": "array", "field": "force", "index": {}}
            ),
            "joints.index",
        ),
        (mapping_dict(joints={"topic": "/l_ankle/ft"}), "expected sensor_msgs/msg/JointState"),
    ]
    bad_field = mapping_dict()
    bad_field["feet"]["right"]["field"] = "forces"
    cases.append((bad_field, "has no field 'forces'.*force"))
    short = mapping_dict()
    short["feet"]["right"]["index"] = [0, 1, 2, 9]
    cases.append((short, "has 4 values in 'force', the index needs 10"))
    wrong_type = mapping_dict()
    wrong_type["feet"]["right"]["type"] = "std_msgs/Float32MultiArray"
    cases.append((wrong_type, "feet.right.type"))
    for mp, match in cases:
        with pytest.raises(SescidError, match=match) as exc:
            read_bag(path, parse_mapping(mp, "map.yaml"), robot.joint_names)
        assert "\n" not in str(exc.value)


def test_no_pose_held_long_enough(tmp_path, robot):
    """A dwell longer than every hold keeps nothing and says why."""
    s = make_session(robot.joint_names, n_poses=2)
    b = Builder(ros1=False)
    path = write_bag(tmp_path / "s", "mcap", session_topics(s, b, robot.joint_names), b)
    mp = mapping_dict(stationary={"dwell": 5.0})
    res = read_bag(path, parse_mapping(mp), robot.joint_names)
    assert res.n == 0 and res.segments == [] and "no sample kept" in res.notes[-1]


BAD_MAPPINGS = [
    ("format: other\n", "format: expected 'sescid-bag-mapping/1'"),
    ("format: sescid-bag-mapping/1\nfeet: {}\n", "joints: missing"),
    ("format: sescid-bag-mapping/1\njoints: {topic: /j}\nfeet: {}\n", "feet: expected"),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j, unit: grad}\n"
        "feet: {right: {source: pads, topic: /f}}\n",
        "joints.unit: expected one of rad, deg",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j}\nfeet: {right: {source: pads}}\n",
        "feet.right.topic: missing",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j}\n"
        "feet: {right: {source: magic, topic: /f}}\n",
        "feet.right.source: expected one of pads, wrench, plate, cop",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j}\n"
        "feet: {right: {source: pads, topic: /f, unit: lb}}\n",
        "feet.right.unit: expected one of N, mN, kgf",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j}\n"
        "feet: {right: {source: pads, topic: /f, scale: -2}}\n",
        "feet.right.scale: must be > 0",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j}\n"
        "feet: {right: {source: pads, topic: /f, index: [0, 1]}}\n",
        "feet.right.index: expected 4 array indices",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j}\n"
        "feet: {right: {source: wrench, topic: /f}}\n",
        "feet.right.sensor_link: give exactly one",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j}\n"
        "feet: {right: {source: wrench, topic: /f, sensor_link: a}}\n",
        "feet.right.sole_frame: missing",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j}\n"
        "feet: {right: {source: wrench, topic: /f, sensor_in_sole: {xyz: [1, 2]}}}\n",
        "feet.right.sensor_in_sole.xyz: expected 3 numbers",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j}\n"
        "feet: {right: {source: wrench, topic: /f, sensor_in_sole: {}, foot_mass: 0.1}}\n",
        "feet.right.foot_com: missing",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j}\n"
        "feet: {right: {source: cop, topic: /f, index: [1]}}\n",
        "feet.right.index: unknown field",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j}\n"
        "feet: {right: {source: pads, topic: /f}}\nstationary: {dwel: 1}\n",
        "stationary.dwel: unknown field",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j}\n"
        "feet: {right: {source: pads, topic: /f}}\ntolerance: zero\n",
        "tolerance: expected a number",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j}\n"
        "feet: {right: {source: pads, topic: /f}, r2: {source: pads, topic: /g, prefix: r}}\n",
        "feet: two feet write the column 'r_fsr1'",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j, kind: array}\n"
        "feet: {right: {source: pads, topic: /f}}\n",
        "joints.index: kind array needs",
    ),
    (
        "format: sescid-bag-mapping/1\njoints: {topic: /j}\n"
        "feet: {right: {source: pads, topic: /f}}\ntypes: {a/msg/B: 3}\n",
        "types: expected a table",
    ),
    ("format: [unclosed\n", "not a YAML file"),
]


@pytest.mark.parametrize(("text", "match"), BAD_MAPPINGS)
def test_mapping_errors(tmp_path, text, match):
    """Each bad mapping field gives one line naming the file and the field."""
    p = tmp_path / "mapping.yaml"
    p.write_text(text)
    with pytest.raises(SescidError, match=match) as exc:
        load_mapping(p)
    assert str(exc.value).startswith(str(p)) and "\n" not in str(exc.value)


def test_bad_msg_text_and_typestore(tmp_path, robot):
    """Unparsable .msg text and an unknown typestore name are reported at read time."""
    b = Builder(ros1=False)
    path = write_bag(tmp_path / "n", "mcap", {}, b)
    with pytest.raises(SescidError, match=r"types\.op2_msgs/msg/FootFsr: bad \.msg text"):
        read_bag(path, parse_mapping(mapping_dict(types={FOOT_TYPE: "float32[ x"})), ["a"])
    with pytest.raises(SescidError, match="typestore: unknown 'ros3'"):
        read_bag(path, parse_mapping(mapping_dict(typestore="ros3")), ["a"])


def test_example_mapping_loads():
    """examples/bag_mapping.yaml is a valid mapping."""
    mp = load_mapping(EXAMPLE)
    assert isinstance(mp, BagMapping) and [f.source for f in mp.feet] == ["pads", "wrench"]


def test_missing_rosbags_names_the_extra(monkeypatch, tmp_path):
    """Without rosbags installed, read_bag says which extra to install."""
    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)
    with pytest.raises(SescidError, match=r"pip install 'sescid\[bags\]'"):
        read_bag(tmp_path, parse_mapping(mapping_dict()), ["a"])


def test_cli_bag_then_fsr(tmp_path, robot):
    """`sescid bag` with a pose list, then `sescid fsr`: an ankle F/T foot's CoP per pose."""
    import json

    from click.testing import CliRunner

    from sescid.cli import cli
    from sescid.tables import read_table, write_table

    s = make_session(robot.joint_names)
    b = Builder(ros1=False)
    path = write_bag(tmp_path / "s", "mcap", session_topics(s, b, robot.joint_names), b)
    mp = mapping_dict()
    mp["feet"] = {"right": mp["feet"]["left"] | {"prefix": "r"}}  # the F/T sensor as right foot
    (tmp_path / "map.json").write_text(json.dumps(mp))
    mid = [np.abs(s.t_joint - T0 - int((0.5 + 1.6 * k) * 1e9)).argmin() for k in range(4)]
    plan_q = s.q[mid][[3, 0, 1]] + np.radians(0.5)
    cols = {"pose": np.array(["p3", "p0", "p1"])}
    write_table(tmp_path / "poses.csv", cols | dict(zip(robot.joint_names, plan_q.T, strict=True)))
    raw, out = tmp_path / "raw.parquet", tmp_path / "cop.csv"
    args = ["bag", path, "--map", tmp_path / "map.json", "--poses", tmp_path / "poses.csv"]
    res = CliRunner().invoke(cli, [str(a) for a in [*args, "--out", raw]])
    assert res.exit_code == 0, res.output
    assert "3 pose segments" in res.output and "  pose p3: " in res.output
    assert (
        "unmatched_pose" in res.output and "moving" in res.output and f"wrote {raw}" in res.output
    )
    assert "segment 2 matches no planned pose" in res.output
    assert {"r_cop_x", "r_cop_y", "r_fz"} <= set(read_table(raw).names())
    fsr_args = ["fsr", raw, "--poses", tmp_path / "poses.csv", "--out", out]
    res = CliRunner().invoke(cli, [str(a) for a in fsr_args])
    assert res.exit_code == 0, res.output
    assert "3 poses from forces" in res.output
    tab = read_table(out)
    assert tab.text["pose"] == ["p0", "p1", "p3"]
    want = np.array([s.cop[s.hold == k][0] for k in (0, 1, 3)])
    got = np.column_stack([tab.get("cop_x"), tab.get("cop_y")])
    assert np.abs(got - want).max() < 1e-9
    assert np.abs(tab.get("force_n") - 30).max() < 0.1  # the ground's force, weight 30 N


def test_cli_bag_errors_are_one_line(tmp_path, robot):
    """A missing bag or a bad mapping field is one `sescid: error:` line and no output file."""
    from click.testing import CliRunner

    from sescid.cli import cli

    (tmp_path / "map.yaml").write_text("format: sescid-bag-mapping/1\nfeet: {}\n")
    out = tmp_path / "raw.csv"
    cases = [(tmp_path / "map.yaml", "map.yaml: joints: missing"), (EXAMPLE, "bag not found")]
    for mapping, match in cases:
        res = CliRunner().invoke(
            cli, ["bag", str(tmp_path / "absent"), "--map", str(mapping), "--out", str(out)]
        )
        lines = res.output.strip().splitlines()
        assert res.exit_code == 2 and len(lines) == 1 and match in lines[0], res.output
    assert not out.exists()


def test_plate_file_force_unit(tmp_path):
    """A plate file's force_unit scales the loads unless the mapping gives its own unit."""
    (tmp_path / "plate.yaml").write_text(
        "format: sescid-plate/1\nforce_unit: kgf\ncells_m: [[0, 0], [0.4, 0], [0, 0.3]]\n"
    )
    foot = {"source": "plate", "topic": "/plate", "plate": "plate.yaml", "scale": 2.0}
    mp = parse_mapping(mapping_dict(feet={"left": foot}), "m.yaml", tmp_path)
    assert mp.feet[0].scale == pytest.approx(2 * 9.80665) and mp.feet[0].unit == "N"
    mp = parse_mapping(mapping_dict(feet={"left": foot | {"unit": "mN"}}), "m.yaml", tmp_path)
    assert mp.feet[0].scale == 2.0 and mp.feet[0].unit == "mN"


def _write_shifted(path, s: Session, b: Builder, joint_names, shift_ns: int):
    """An MCAP bag recorded by a clock that stepped back ``shift_ns`` half-way (receive
    times and header stamps alike): the reader's time order interleaves two stretches."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    topics = session_topics(s, b, joint_names)
    items = sorted(((r, t, typ, m) for t, (typ, msgs) in topics.items() for r, m in msgs),
                   key=lambda x: x[0])  # fmt: skip
    mid = items[len(items) // 2][0]
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {t: w.add_connection(t, typ, typestore=b.ts) for t, (typ, _) in topics.items()}
        for r, t, typ, m in items:
            if r >= mid:
                r -= shift_ns
                st = m.header.stamp
                ns = st.sec * 10**9 + st.nanosec - shift_ns
                m.header.stamp = b.T["builtin_interfaces/msg/Time"](sec=ns // 10**9,
                                                                    nanosec=ns % 10**9)  # fmt: skip
            w.write(conns[t], int(r), b.ts.serialize_cdr(m, typ))
    return path


def test_hostile_recordings_are_one_line(tmp_path, robot):
    """A recording whose clock stepped back 5 s (two stretches interleaved: poses were lost
    silently), a joint without any value, an F/T sensor of reversed sign and a rosbag2 folder
    without its metadata.yaml: one line naming the bag, topic, joint or file; NaN angles in
    part of the recording are named in a note."""
    import shutil

    b = Builder(ros1=False)
    mp = parse_mapping(mapping_dict(), "map.yaml")
    back = _write_shifted(tmp_path / "back", make_session(robot.joint_names), b,
                          robot.joint_names, 5 * 10**9)  # fmt: skip
    with pytest.raises(SescidError, match="/joint_states: from .* joint states alternate between"):
        read_bag(back, mp, robot.joint_names)
    s = make_session(robot.joint_names)
    s.q[:, 3] = np.nan
    dead = write_bag(tmp_path / "dead", "mcap", session_topics(s, b, robot.joint_names), b)
    with pytest.raises(SescidError, match="joint 'l_sho_roll' has no value \\(NaN\\) in any"):
        read_bag(dead, mp, robot.joint_names)
    s = make_session(robot.joint_names)
    s.q[150:, 5] = np.nan
    part = write_bag(tmp_path / "part", "mcap", session_topics(s, b, robot.joint_names), b)
    res = read_bag(part, mp, robot.joint_names)
    assert any("NaN joint angles ('l_el' 428 of" in n for n in res.notes), res.notes
    s = make_session(robot.joint_names)
    s.wrench *= -1
    neg = write_bag(tmp_path / "neg", "mcap", session_topics(s, b, robot.joint_names), b)
    with pytest.raises(SescidError, match="feet.left .*the force/torque sensor's sign is rev"):
        read_bag(neg, mp, robot.joint_names)
    shutil.copytree(part, tmp_path / "nometa")
    (tmp_path / "nometa" / "metadata.yaml").unlink()
    with pytest.raises(SescidError, match="nometa: no metadata.yaml, the index of a rosbag2"):
        read_bag(tmp_path / "nometa", mp, robot.joint_names)
