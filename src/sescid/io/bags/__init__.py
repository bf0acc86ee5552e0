"""ROS bags → the raw log the ``fsr`` step (and the joint-torque reduction) reads, without a ROS
installation.

``read_bag`` reads a rosbag2 recording (sqlite3 or MCAP directory) or ROS 1 ``.bag`` files with
the ``rosbags`` library (the ``bags`` extra) and a **mapping file** (``load_mapping``) that names
the topics: the joint read-backs, optionally the joint torques (``tau_<joint>`` columns, N·m:
a ``JointState.effort`` by name, or a vendor state such as Unitree's
``LowState.motor_state[i].tau_est`` by motor index), each foot's force source, optionally a
pose-id topic. A recording may have torques and no foot sensor at all.

Modules: ``fields`` (a mapping section read with one-line errors), ``mapping`` (the file and its
joint, torque and pose sources), ``feet`` (force sources), ``recording`` (topics out of the bag),
``messages`` (values out of messages), ``stamps`` (one clock), ``segments`` (pose ids),
``assemble`` (the raw log).
"""

from sescid.io.bags.assemble import DROP_REASONS, RawLogTable, Segment, read_bag
from sescid.io.bags.feet import FootSource
from sescid.io.bags.mapping import (
    MAPPING_FORMAT,
    BagMapping,
    JointSource,
    PoseSource,
    TorqueSource,
    load_mapping,
    parse_mapping,
)

__all__ = [
    "DROP_REASONS",
    "MAPPING_FORMAT",
    "BagMapping",
    "FootSource",
    "JointSource",
    "PoseSource",
    "RawLogTable",
    "Segment",
    "TorqueSource",
    "load_mapping",
    "parse_mapping",
    "read_bag",
]
