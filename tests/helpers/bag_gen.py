"""Synthetic bench sessions written as ROS bags (rosbags imported only when writing), and the
wrench a foot F/T sensor reads under a known ground load: helpers shared by the bag, wrench and
CLI tests.
"""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sescid.base import G0
from sescid.sensors.wrench import rpy_matrix

FOOT_MSG = "std_msgs/Header header\nfloat32[4] force\nuint8 board_id\n"
FOOT_TYPE = "op2_msgs/msg/FootFsr"
T0 = 1_700_000_000 * 10**9  # ns, the session's first stamp
EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "bag_mapping.yaml"
SENSOR_XYZ, SENSOR_RPY = [0.004, -0.002, 0.031], [0.02, -0.03, 0.4]


@dataclass
class Session:
    """A synthetic bench session: holds at poses with moving transitions between them."""

    t_joint: np.ndarray  #: (nj,) ns
    q: np.ndarray  #: (nj, nq) rad
    t_force: np.ndarray  #: (nf,) ns
    pads: np.ndarray  #: (nf, 4) float32 mN
    wrench: np.ndarray  #: (nf, 6) N, N·m (left foot sensor frame)
    cop: np.ndarray  #: (nf, 2) m, the true CoP of each force sample
    hold: np.ndarray  #: (nf,) pose index of each force sample, −1 in transitions
    inner: np.ndarray  #: (nf,) bool: more than 0.15 s from a hold's or transition's edge
    pose_times: list  #: (t_ns, id) pose-id messages


def make_session(joint_names, n_poses=4, hold=1.0, move=0.6, seed=0) -> Session:
    """Poses held ``hold`` s with linear ``move`` s transitions; joints 100 Hz, forces 50 Hz."""
    rng = np.random.default_rng(seed)
    nq = len(joint_names)
    poses = rng.uniform(-0.3, 0.3, size=(n_poses, nq))
    poses[1:, 0] = poses[:-1, 0] + 0.3  # every transition moves at least one joint 0.3 rad
    cops = rng.uniform(-0.015, 0.015, size=(n_poses, 2))
    edges = []  # (start, end, pose or −1) in s
    t = 0.0
    for k in range(n_poses):
        edges.append((t, t + hold, k))
        t += hold
        if k < n_poses - 1:
            edges.append((t, t + move, -1))
            t += move
    total = t
    tj = np.arange(0.0, total, 0.01)
    q = np.empty((len(tj), nq))
    for a, b, k in edges:
        sel = (tj >= a) & (tj < b)
        if k >= 0:
            q[sel] = poses[k]
        else:
            prev = next(kk for aa, bb, kk in edges if bb == a)
            s = (tj[sel] - a) / (b - a)
            q[sel] = poses[prev] + s[:, None] * (poses[prev + 1] - poses[prev])
    q += rng.normal(0, 2e-4, size=q.shape)
    tf = np.arange(0.0, total, 0.02) + 0.003  # 3 ms after a joint sample
    hold_of = np.full(len(tf), -1)
    inner = np.zeros(len(tf), dtype=bool)
    cop = np.empty((len(tf), 2))
    for a, b, k in edges:
        sel = (tf >= a) & (tf < b)
        hold_of[sel] = k
        inner |= sel & (tf > a + 0.15) & (tf < b - 0.15)
    for i in range(len(tf)):
        k = hold_of[i]
        if k >= 0:
            cop[i] = cops[k]
        else:  # moving: the CoP slides between the poses'
            prev = max(kk for aa, bb, kk in edges if bb <= tf[i] and kk >= 0)
            cop[i] = cops[prev] + (cops[prev + 1] - cops[prev]) * rng.uniform()
    # right foot: four pads (OP2 board layout of op2_fsr.json), mN, float32
    from sescid.robots import profile_for
    from sescid.sensors.pads import load_sensors

    sensors = load_sensors(profile=profile_for("op2")).foot("right").sensors
    ex, ey = sensors[1] - sensors[0], sensors[2] - sensors[0]
    d = cop - sensors[0]
    u, v = d @ ex / (ex @ ex), d @ ey / (ey @ ey)
    weight = 30.0 + rng.normal(0, 0.3, len(tf))
    pads = weight[:, None] * np.stack([(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v], 1)
    pads = (pads * 1000 + rng.normal(0, 5, pads.shape)).astype(np.float32)
    # left foot: an ankle F/T sensor reading a point load at the CoP (heavy foot below it)
    rot = np.broadcast_to(rpy_matrix(SENSOR_RPY), (len(tf), 3, 3))
    f_ground = np.column_stack([rng.normal(0, 1, (len(tf), 2)), weight])
    f, tq = sensor_wrench(
        cop, f_ground, np.zeros(len(tf)), rot, np.array(SENSOR_XYZ), 0.2, [0.01, 0.0, 0.01]
    )
    pose_times = []
    for a, _b, k in edges:
        pose_times.append((T0 + int(round(a * 1e9)), k))
    return Session(
        t_joint=T0 + np.round(tj * 1e9).astype(np.int64),
        q=q,
        t_force=T0 + np.round(tf * 1e9).astype(np.int64),
        pads=pads,
        wrench=np.hstack([f, tq]),
        cop=cop,
        hold=hold_of,
        inner=inner,
        pose_times=pose_times,
    )


class Builder:
    """Builds messages for one typestore (ROS 2 Humble or ROS 1 Noetic) with the custom type."""

    def __init__(self, ros1: bool):
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore

        self.ros1 = ros1
        self.ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
        self.ts.register(get_types_from_msg(FOOT_MSG, FOOT_TYPE))
        self.T = self.ts.types

    def header(self, ns: int, frame: str = ""):
        stamp = self.T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
        kw = {"seq": 0} if self.ros1 else {}
        return self.T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame, **kw)

    def joint_state(self, ns, names, pos):
        return self.T["sensor_msgs/msg/JointState"](
            header=self.header(ns),
            name=list(names),
            position=np.asarray(pos, dtype=float),
            velocity=np.zeros(0),
            effort=np.zeros(0),
        )

    def foot(self, ns, force):
        return self.T[FOOT_TYPE](header=self.header(ns, "r_sole"), force=force, board_id=111)

    def wrench(self, ns, w):
        v3 = self.T["geometry_msgs/msg/Vector3"]
        return self.T["geometry_msgs/msg/WrenchStamped"](
            header=self.header(ns, "l_ft"),
            wrench=self.T["geometry_msgs/msg/Wrench"](force=v3(*w[:3]), torque=v3(*w[3:])),
        )

    def point(self, ns, xy):
        return self.T["geometry_msgs/msg/PointStamped"](
            header=self.header(ns, "r_sole"),
            point=self.T["geometry_msgs/msg/Point"](x=xy[0], y=xy[1], z=0.0),
        )

    def int32(self, v):
        return self.T["std_msgs/msg/Int32"](data=int(v))

    def string(self, v):
        return self.T["std_msgs/msg/String"](data=str(v))

    def array(self, kind, values):
        t = self.T
        dim = t["std_msgs/msg/MultiArrayDimension"](label="", size=len(values), stride=1)
        layout = t["std_msgs/msg/MultiArrayLayout"](dim=[dim], data_offset=0)
        dtype = np.float32 if kind == "Float32" else np.float64
        return t[f"std_msgs/msg/{kind}MultiArray"](layout=layout, data=np.asarray(values, dtype))


def write_bag(path: Path, storage: str, topics: dict, builder: Builder, defs: bool = True):
    """Write ``{topic: (msgtype, [(receive_ns, msg), ...])}`` as sqlite3, mcap or ros1."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin, Writer

    ts = builder.ts
    if storage == "ros1":
        with Writer1(path) as w:
            conns = {t: w.add_connection(t, typ, typestore=ts) for t, (typ, _) in topics.items()}
            items = [(r, t, typ, m) for t, (typ, msgs) in topics.items() for r, m in msgs]
            for r, t, typ, m in sorted(items, key=lambda x: x[0]):
                w.write(conns[t], int(r), ts.serialize_ros1(m, typ))
        return path
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=8, storage_plugin=plugin) as w:
        conns = {t: w.add_connection(t, typ, typestore=ts) for t, (typ, _) in topics.items()}
        items = [(r, t, typ, m) for t, (typ, msgs) in topics.items() for r, m in msgs]
        for r, t, typ, m in sorted(items, key=lambda x: x[0]):
            w.write(conns[t], int(r), ts.serialize_cdr(m, typ))
    if not defs:  # an older rosbag2 recording: no message definitions stored
        db = next(path.glob("*.db3"))
        with sqlite3.connect(db) as con:
            con.execute("DELETE FROM message_definitions")
    return path


LATENCY = 1_000_000  # ns between a header stamp and the bag's receive time


def session_topics(s: Session, b: Builder, joint_names, pose_topic=None):
    """Joint states (one renamed joint, one extra), right pads, left wrench, optional pose ids."""
    names = ["R_SHO_PITCH", *joint_names[1:], "extra_joint"]
    js = [
        (t + LATENCY, b.joint_state(t, names, [*q, 9.0]))
        for t, q in zip(s.t_joint, s.q, strict=True)
    ]
    pads = [(t + LATENCY, b.foot(t, f)) for t, f in zip(s.t_force, s.pads, strict=True)]
    wr = [
        (t + 2 * LATENCY, b.wrench(t + 4_000_000, w))
        for t, w in zip(s.t_force, s.wrench, strict=True)
    ]
    topics = {
        "/joint_states": ("sensor_msgs/msg/JointState", js),
        "/r_foot/fsr": (FOOT_TYPE, pads),
        "/l_ankle/ft": ("geometry_msgs/msg/WrenchStamped", wr),
    }
    if pose_topic == "int":
        topics["/pose_id"] = ("std_msgs/msg/Int32", [(t, b.int32(k)) for t, k in s.pose_times])
    elif pose_topic == "string":
        msgs = [(t, b.string("" if k < 0 else f"p{k}")) for t, k in s.pose_times]
        topics["/pose_id"] = ("std_msgs/msg/String", msgs)
    return topics


def mapping_dict(**over) -> dict:
    """The test session's mapping (pads right, wrench left), with top-level overrides."""
    m = {
        "format": "sescid-bag-mapping/1",
        "joints": {"topic": "/joint_states", "rename": {"R_SHO_PITCH": "r_sho_pitch"}},
        "feet": {
            "right": {
                "source": "pads",
                "topic": "/r_foot/fsr",
                "type": FOOT_TYPE,
                "field": "force",
                "unit": "mN",
            },
            "left": {
                "source": "wrench",
                "topic": "/l_ankle/ft",
                "sensor_in_sole": {"xyz": SENSOR_XYZ, "rpy": SENSOR_RPY},
                "foot_mass": 0.2,
                "foot_com": [0.01, 0.0, 0.01],
            },
        },
        "stationary": {"max_speed": 0.05, "dwell": 0.5, "window": 0.1},
        "tolerance": 0.02,
        "types": {FOOT_TYPE: FOOT_MSG},
    }
    m.update(over)
    return m


def sensor_wrench(p, f_ground, tau_n, rot, s, foot_mass=0.0, foot_com=(0, 0, 0)):
    """What the sensor reads (sensor frame) when the ground pushes ``f_ground`` at ``p``.

    Independent of the module's derivation: equilibrium of the foot below the sensor, with
    moments taken about the sensor origin instead of the sole origin.
    """
    p = np.column_stack([p, np.zeros(len(p))])
    g_vec = np.array([0.0, 0.0, -G0]) * foot_mass
    big_f = f_ground + g_vec
    big_t = (
        np.cross(p - s, f_ground)
        + tau_n[:, None] * np.array([0.0, 0.0, 1.0])
        + np.cross(np.asarray(foot_com) - s, g_vec)
    )
    rt = np.swapaxes(rot, -1, -2)
    return np.einsum("nij,nj->ni", rt, big_f), np.einsum("nij,nj->ni", rt, big_t)
