"""The stance of each row of a recording (the raw log's ``support`` column): the mapping's
``support`` (one frame for the whole recording, or a String topic naming it as it changes), or
the planned pose each segment matched."""

from __future__ import annotations

import numpy as np

from sescid.io.bags.mapping import BagMapping
from sescid.io.bags.messages import message_pose_ids
from sescid.io.bags.segments import topic_labels
from sescid.robot import Robot
from sescid.stance import data_stance


def row_stances(
    mp: BagMapping, clocks, t_clock, pose, poses, pose_support, masks
) -> np.ndarray | None:
    """The stance of each row: the mapping's, its stance topic's (the latest name at or before
    the row; rows before the first or with an empty name dropped as ``no_support``), or the
    matched planned pose's; None when nothing names one."""
    n = len(t_clock)
    if mp.support is not None:
        return np.full(n, mp.support)
    if mp.support_topic is not None:
        c = clocks["support"]
        said = message_pose_ids(c.topic, mp.support_topic.field, c.where)
        names, labels = topic_labels(c.stamps, said, t_clock)
        masks["no_support"] = labels["no_pose"] | (names == "")
        return names
    if pose_support is None or poses is None:
        return None
    ids = np.asarray(poses[0]).astype(str).tolist()
    by_id = dict(zip(ids, np.asarray(pose_support).astype(str).tolist(), strict=True))
    return np.array([by_id.get(p, "") for p in pose.tolist()], dtype=object).astype(str)


def check_stances(stance: np.ndarray, robot: Robot | None, where: str) -> None:
    """Each stance one ``sescid.stance.parse_stance`` reads: a frame of the model or "double"
    (without a robot: not checked); a DataError starting with ``where``."""
    if robot is None:
        return
    for name in dict.fromkeys(stance.tolist()):
        data_stance(robot, name, (), where)
