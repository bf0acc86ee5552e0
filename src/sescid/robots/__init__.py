"""Robots sescid ships, each a small data package: model file plus a ``RobotProfile``.

``profile_for(name)`` gives an embedded robot's profile (``EMBEDDED`` lists the names);
``generic_profile`` stands for any other model file. ``body_table`` reads a profile's paper
Table 1 (index → body) when it has one.
"""

import csv
from pathlib import Path

from sescid.errors import ModelError
from sescid.robots.op2 import PROFILE as _OP2
from sescid.robots.profile import (
    MX28,
    PoseSampler,
    RobotProfile,
    ServoEncoding,
    ServoGains,
    generic_profile,
)

#: embedded robot name → its profile
EMBEDDED: dict[str, RobotProfile] = {"op2": _OP2}


def profile_for(name: str) -> RobotProfile:
    """The profile of an embedded robot (ModelError for an unknown name)."""
    try:
        return EMBEDDED[name]
    except KeyError:
        raise ModelError(
            f"unknown robot '{name}': give an embedded name ({', '.join(EMBEDDED)}) or a model file"
        ) from None


def embedded_path(name: str) -> Path:
    """Path of an embedded robot's model file."""
    path = profile_for(name).model_file
    assert path is not None
    return path


def body_table(profile: RobotProfile) -> list[dict[str, str]] | None:
    """The paper's Table 1 rows (index, body, link, …) for a profile that has one."""
    if profile.body_table_file is None:
        return None
    with profile.body_table_file.open() as fh:
        return list(csv.DictReader(fh))


__all__ = [
    "EMBEDDED",
    "MX28",
    "PoseSampler",
    "RobotProfile",
    "ServoEncoding",
    "ServoGains",
    "body_table",
    "embedded_path",
    "generic_profile",
    "profile_for",
]
