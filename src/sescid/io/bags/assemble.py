"""A recording → the raw log: one row per sample of the clock topic (the first foot's, else the
torques'), with its pose id, time, joint angles (rad), joint torques (``tau_<joint>``, N·m) and
each foot's force columns.

Each row takes the nearest joint state by stamp within ``tolerance`` seconds (else it is dropped
as ``no_joint_state``); other feet and the torques contribute their nearest sample within the
tolerance (else NaN, with a note). Joint states that lack some joints (several publishers on one
topic) take those joints' latest value within the tolerance; rows still missing a joint are
dropped as ``missing_joint``. Angles beyond ±2π rad in a ``unit: rad`` mapping are an error
(a recording in degrees needs ``unit: deg``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from sescid.errors import DataError, SescidError
from sescid.io.bags.feet import FootSource
from sescid.io.bags.fields import Stamp
from sescid.io.bags.joints import check_joint_values, joint_angles, joint_torques
from sescid.io.bags.mapping import BagMapping, load_mapping
from sescid.io.bags.messages import foot_values, message_pose_ids
from sescid.io.bags.recording import bag_paths, check_type, read_topics
from sescid.io.bags.segments import segment_labels, topic_labels
from sescid.io.bags.stamps import Clocked, fill_recent, nearest, one_clock, topic_stamps
from sescid.io.bags.stances import check_stances, row_stances
from sescid.robot import Robot
from sescid.sensors.raw import reversed_force
from sescid.sensors.wrench import cop_from_plate, cop_from_wrench
from sescid.tables import SUPPORT_COLUMN

#: reasons a clock sample is left out, in the order they are counted
DROP_REASONS = (
    "no_joint_state", "missing_joint", "no_pose", "moving", "unmatched_pose", "no_support",
)  # fmt: skip
_JOINT_STATE = ("sensor_msgs/msg/JointState",)
_FOOT_TYPES = {
    "wrench": ("geometry_msgs/msg/WrenchStamped", "geometry_msgs/msg/Wrench"),
    "cop": ("geometry_msgs/msg/PointStamped", "geometry_msgs/msg/Point"),
}


@dataclass(frozen=True)
class Segment:
    """One pose in the bag: its id, first and last kept sample (s since the bag's first stamp)."""

    pose: str
    start: float
    end: float
    samples: int
    stance: str = ""  #: the support it was measured in ("" when the log names none)


@dataclass
class RawLogTable:
    """The raw log table (``write_table`` writes ``columns``) and how it was cut."""

    columns: dict[str, np.ndarray]  #: pose (text), t (s), joints (rad), tau_<joint>, forces
    segments: list[Segment]
    dropped: dict[str, int]  #: reason → clock samples left out (see DROP_REASONS)
    notes: list[str] = dataclasses.field(default_factory=list)

    @property
    def n(self) -> int:
        """Number of rows (samples)."""
        return len(self.columns["pose"])


def _sorted(c: Clocked, values):
    """Stamps and values (array or dict of arrays) in time order."""
    o = np.argsort(c.stamps, kind="stable")
    if isinstance(values, dict):
        return c.stamps[o], {k: v[o] for k, v in values.items()}
    return c.stamps[o], values[o]


def _aligned(t_ref, values: dict, t_clock, tol: int, what: str, mp, notes) -> dict:
    """``values`` (sorted at ``t_ref``) at each clock stamp: nearest within ``tol`` ns, else NaN."""
    i = nearest(t_ref, t_clock, tol)
    if (i < 0).any():
        topic = (
            mp.torques.topic
            if what == "torques"
            else next(f.topic for f in mp.feet if f"feet.{f.name}" == what)
        )
        notes.append(
            f"{what}: {(i < 0).sum()} of {len(t_clock)} samples have no message within "
            f"{mp.tolerance:g} s on {topic} (NaN there)"
        )
    out = {}
    for k, v in values.items():
        ok = (i >= 0).reshape((-1,) + (1,) * (v.ndim - 1))
        out[k] = np.where(ok, v[np.maximum(i, 0)], np.nan)
    return out


def _joint_names(mp: BagMapping, joint_names, robot: Robot | None) -> list[str]:
    if joint_names is None:
        if robot is None:
            raise DataError("read_bag needs joint_names or a robot")
        joint_names = robot.joint_names
    joint_names = list(joint_names)
    if robot is not None and joint_names != list(robot.joint_names):
        raise DataError("read_bag: joint_names differ from the robot's joints")
    if robot is None and any(f.sensor_link for f in mp.feet):
        foot = next(f for f in mp.feet if f.sensor_link)
        raise DataError(
            f"{mp.source}: feet.{foot.name}.sensor_link needs the robot model to place the sensor"
        )
    return joint_names


def _clocks(mp: BagMapping, topics: dict, tol: int, notes: list[str]) -> dict[str, Clocked]:
    """Mapping section → its topic's stamps (types checked; one time line for all)."""
    src = mp.source
    sections: list[tuple[str, str, Stamp, str | None, tuple[str, ...]]] = [
        (
            "joints",
            mp.joints.topic,
            mp.joints.stamp,
            mp.joints.type,
            _JOINT_STATE if mp.joints.kind == "joint_state" else (),
        ),
    ]
    if mp.torques is not None:
        ts = mp.torques
        default = _JOINT_STATE if ts.kind == "joint_state" else ()
        sections.append(("torques", ts.topic, ts.stamp, ts.type, default))
    for f in mp.feet:
        sections.append((f"feet.{f.name}", f.topic, f.stamp, f.type, _FOOT_TYPES.get(f.source, ())))
    if mp.pose is not None:
        sections.append(
            (
                "pose",
                mp.pose.topic,
                mp.pose.stamp,
                None,
                ("std_msgs/msg/Int32", "std_msgs/msg/String"),
            )
        )
    if mp.support_topic is not None:
        s = mp.support_topic
        sections.append(("support", s.topic, s.stamp, None, ("std_msgs/msg/String",)))
    clocks = {}
    for name, topic, stamp, want, default in sections:
        where = f"{src}: {name}"
        check_type(topics[topic], want, where, default)
        clocks[name] = topic_stamps(topics[topic], stamp, where, notes)
    return dict(zip(clocks, one_clock(list(clocks.values()), tol, notes), strict=True))


def _streams(mp: BagMapping, clocks: dict, joint_names: list[str], notes) -> dict[str, tuple]:
    """Section → (sorted stamps, values by column): the torques, then each foot ("v": (m, k))."""
    out = {}
    if mp.torques is not None:
        c = clocks["torques"]
        out["torques"] = _sorted(c, joint_torques(c, mp, joint_names, notes))
    for f in mp.feet:
        c = clocks[f"feet.{f.name}"]
        out[f"feet.{f.name}"] = _sorted(c, {"v": foot_values(c.topic, f, c.where)})
    return out


def _count(masks: dict[str, np.ndarray], n: int) -> tuple[dict[str, int], np.ndarray]:
    """Rows dropped per reason (each row under its first reason of DROP_REASONS) and the kept
    rows."""
    keep = np.ones(n, dtype=bool)
    dropped = {}
    for reason in DROP_REASONS:
        if reason in masks:
            hit = keep & masks[reason]
            dropped[reason] = int(hit.sum())
            keep &= ~hit
    return dropped, keep


def read_bag(
    bag_path, mapping, joint_names=None, robot: Robot | None = None, poses=None, pose_support=None
) -> RawLogTable:
    """Read a ROS bag into the raw log of the ``fsr`` step (see ``sescid.io.bags``).

    ``bag_path``: a rosbag2 directory (sqlite3 or MCAP), a ROS 1 ``.bag`` file, or a list of
    ROS 1 files. ``mapping``: a ``BagMapping`` or a mapping file path. ``joint_names``: the
    model's joints (default ``robot.joint_names``). ``robot`` is needed for a wrench source whose
    sensor frame is a URDF link. ``poses = (ids, q)``: the planned pose list (ids (k,) text,
    angles (k, nq) rad) whose ids the stationary segments take (without a pose topic);
    ``pose_support`` (k,): their stances (the list's ``support`` column), which the rows of a
    matched segment take when the mapping names no ``support``. With a stance the log has a
    ``support`` column (a frame of the model, or "double"; checked against ``robot``).
    """
    mp = mapping if isinstance(mapping, BagMapping) else load_mapping(mapping)
    joint_names = _joint_names(mp, joint_names, robot)
    topics = read_topics(bag_paths(bag_path), mp)
    notes: list[str] = []
    tol = int(round(mp.tolerance * 1e9))
    clocks = _clocks(mp, topics, tol, notes)
    tj, q = _sorted(clocks["joints"], joint_angles(clocks["joints"], mp, joint_names, notes))
    q = fill_recent(tj, q, tol)
    check_joint_values(clocks["joints"], tj, q, joint_names, notes)
    streams = _streams(mp, clocks, joint_names, notes)
    clock = f"feet.{mp.feet[0].name}" if mp.feet else "torques"
    t_clock = streams[clock][0]
    ij = nearest(tj, t_clock, tol)
    masks = {"no_joint_state": ij < 0}
    masks["missing_joint"] = (ij >= 0) & np.isnan(q[np.maximum(ij, 0)]).any(axis=1)
    if mp.pose is not None:
        cp = clocks["pose"]
        pose, more = topic_labels(
            cp.stamps, message_pose_ids(cp.topic, mp.pose.field, cp.where), t_clock
        )
    else:
        pose, more = segment_labels(ij, tj, q, mp, poses, notes)
    stance = row_stances(mp, clocks, t_clock, pose, poses, pose_support, more)
    dropped, keep = _count(masks | more, len(t_clock))
    t0 = min(int(tj[0]), int(t_clock[0]))
    qk = q[ij[keep]]
    cols = {"pose": pose[keep], "t": (t_clock[keep] - t0) * 1e-9}
    if stance is not None:
        where = f"{mp.source}: support" if mp.support or mp.support_topic else "the pose list"
        check_stances(stance[keep], robot, where)
        cols[SUPPORT_COLUMN] = stance[keep]
    cols |= {j: qk[:, c] for c, j in enumerate(joint_names)}
    for name, (t, values) in streams.items():
        if name != clock:
            values = _aligned(t, values, t_clock, tol, name, mp, notes)
        values = {k: v[keep] for k, v in values.items()}
        foot = next((f for f in mp.feet if f"feet.{f.name}" == name), None)
        cols |= values if foot is None else _foot_columns(foot, values["v"], qk, robot, mp.source)
    return _result(cols, dropped, notes)


def _result(cols: dict[str, np.ndarray], dropped: dict[str, int], notes: list[str]):
    """The raw log with its pose segments (runs of one pose id in time order)."""
    segments = []
    pk, tk = cols["pose"], cols["t"]
    sk = cols.get(SUPPORT_COLUMN, np.full(len(pk), ""))
    if len(pk):
        change = np.flatnonzero((pk[1:] != pk[:-1]) | (sk[1:] != sk[:-1])) + 1
        for a, b in zip(np.r_[0, change], np.r_[change, len(pk)], strict=True):
            seg = Segment(str(pk[a]), float(tk[a]), float(tk[b - 1]), int(b - a), str(sk[a]))
            segments.append(seg)
    else:
        why = ", ".join(f"{k}={v}" for k, v in dropped.items() if v) or "none"
        notes.append(f"no sample kept: {why}")
    return RawLogTable(cols, segments, dropped, notes)


def _foot_columns(
    foot: FootSource, v: np.ndarray, q: np.ndarray, robot: Robot | None, source: str
) -> dict:
    """Output columns of one foot from its values (n, ·) and the joint angles (n, nq)."""
    if foot.source == "pads":  # the fsr step's force counts, mN (exact for unit mN, scale 1)
        mn = 1000.0 * foot.si_per_unit  # FORCE_UNITS in mN: 1000, 1, 9806.65 (the same bits)
        return {c: v[:, k] * mn for k, c in enumerate(foot.columns)}
    v = v * foot.si_per_unit
    if foot.source == "cop":
        return {f"{foot.prefix}_cop_x": v[:, 0], f"{foot.prefix}_cop_y": v[:, 1]}
    if foot.source == "plate":
        cop, fz = cop_from_plate(v, foot.cells, foot.foot_pose, foot.min_force)
    else:
        rot, pos = _sensor_in_sole(foot, q, robot, source)
        cop, fz = cop_from_wrench(
            v[:, :3],
            v[:, 3:],
            rot,
            pos,
            foot_mass=foot.foot_mass,
            foot_com=foot.foot_com,
            min_force=foot.min_force,
        )
    why = reversed_force(fz, max(foot.min_force, 1e-9))
    if why is not None:
        raise DataError(f"{source}: feet.{foot.name} ({foot.topic}): {why}")
    p = foot.prefix
    return {f"{p}_cop_x": cop[:, 0], f"{p}_cop_y": cop[:, 1], f"{p}_fz": fz}


def _sensor_in_sole(foot: FootSource, q: np.ndarray, robot: Robot | None, source: str):
    """The F/T sensor frame in the sole frame: fixed, or per sample from the model's links."""
    if foot.sensor_link is None:
        return foot.sensor_rot, foot.sensor_pos
    if not len(q):
        return np.zeros((0, 3, 3)), np.zeros((0, 3))
    assert foot.sole_frame is not None  # the mapping requires it with sensor_link
    assert robot is not None  # _joint_names: a sensor_link needs the robot
    try:
        r_sole, p_sole = robot.link_poses(q, foot.sole_frame)
        r_s, p_s = robot.link_poses(q, foot.sensor_link)
    except SescidError as exc:
        raise DataError(f"{source}: feet.{foot.name}: {exc}") from None
    rot = np.swapaxes(r_sole, -1, -2) @ r_s
    pos = np.einsum("nji,nj->ni", r_sole, p_s - p_sole)
    return rot, pos
