"""Sampling limits of candidate poses: the model's joint limits ∩ the paper's Table 2 (robots
whose profile carries the paper's angle convention, the OP2) ∩ an optional ±range.

A joint without limits (URDF ``continuous``, MJCF hinge without ``range``) is sampled within
±``UNLIMITED_RANGE`` (90°): a full turn of a knee or an elbow is no pose a robot takes; the
planner says which joints got it (``unlimited_joints``), and ``--range-deg`` widens it.

The OP2 paper convention: ``paper = sign · servo + offset`` per joint
(``robots/op2/op2_paper_limits.csv``).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from sescid.errors import OptionError, SescidError
from sescid.robot import Robot


@dataclass(frozen=True)
class PaperConvention:
    """The paper's joint-angle convention for the OP2: ``paper = sign · servo + offset``."""

    joint_names: list[str]
    sign: np.ndarray  #: (nq,) ±1
    offset: np.ndarray  #: (nq,) rad
    paper_limits: np.ndarray  #: (nq, 2) the paper's Table 2 limits, rad, paper convention
    servo_limits: np.ndarray  #: (nq, 2) the same in servo angles, rad

    def to_paper(self, q) -> np.ndarray:
        """Servo angles (n, nq) [rad] → paper angles (n, nq) [rad]."""
        return np.asarray(q, dtype=float) * self.sign + self.offset

    def to_servo(self, q_paper) -> np.ndarray:
        """Paper angles (n, nq) [rad] → servo angles (n, nq) [rad]."""
        return (np.asarray(q_paper, dtype=float) - self.offset) * self.sign


def load_paper_convention(path: Path) -> PaperConvention:
    """A paper angle convention and its Table 2 limits from a profile's CSV."""
    with path.open() as fh:
        rows = list(csv.DictReader(fh))
    f = np.array(
        [
            [float(r[k]) for k in ("paper_sign_vs_servo", "paper_offset_deg")]
            + [float(r[k]) for k in ("paper_min_deg", "paper_max_deg")]
            + [float(r[k]) for k in ("servo_min_deg", "servo_max_deg")]
            for r in rows
        ]
    )
    return PaperConvention(
        joint_names=[r["joint"] for r in rows],
        sign=f[:, 0],
        offset=np.radians(f[:, 1]),
        paper_limits=np.radians(f[:, 2:4]),
        servo_limits=np.radians(f[:, 4:6]),
    )


def paper_convention(robot: Robot) -> PaperConvention | None:
    """The paper convention in ``robot.joint_names`` order when the profile has one, else None."""
    path = robot.profile.paper_limits_file
    if path is None:
        return None
    pc = load_paper_convention(path)
    if not set(robot.joint_names) <= set(pc.joint_names):
        return None
    idx = [pc.joint_names.index(j) for j in robot.joint_names]
    fields = ("sign", "offset", "paper_limits", "servo_limits")
    return replace(pc, joint_names=robot.joint_names, **{f: getattr(pc, f)[idx] for f in fields})


#: rad, sampling range ± of a joint the model leaves unlimited
UNLIMITED_RANGE = math.pi / 2


def unlimited_joints(robot: Robot) -> list[str]:
    """Joints the model leaves unlimited (sampled within ±``UNLIMITED_RANGE`` by default)."""
    lim = robot.joint_limits
    return [
        j
        for j, lo, hi in zip(robot.joint_names, lim[:, 0], lim[:, 1], strict=True)
        if not (np.isfinite(lo) and np.isfinite(hi))
    ]


def sampling_limits(robot: Robot, paper: bool = True, range_deg: float | None = None) -> np.ndarray:
    """(nq, 2) sampling limits [rad]: model limits ∩ the paper's Table 2 (OP2, ``paper``) ∩ ±range.

    A joint without limits gets ±``UNLIMITED_RANGE``, or ±``range_deg`` when that is given.
    SescidError for a robot without joints (no pose to choose).
    """
    if robot.nq == 0:
        raise SescidError(f"{robot.name} has no joints: there is no pose to choose")
    lim = robot.joint_limits
    free = ~(np.isfinite(lim[:, 0]) & np.isfinite(lim[:, 1]))
    wide = UNLIMITED_RANGE if range_deg is None else math.pi
    lim[free, 0] = np.maximum(lim[free, 0], -wide)
    lim[free, 1] = np.minimum(lim[free, 1], wide)
    lim = np.clip(lim, -math.pi, math.pi)
    pc = paper_convention(robot) if paper else None
    if pc is not None:
        lim = np.column_stack(
            [
                np.maximum(lim[:, 0], pc.servo_limits[:, 0]),
                np.minimum(lim[:, 1], pc.servo_limits[:, 1]),
            ]
        )
    if range_deg is not None:
        if not 0 < range_deg <= 180:
            raise OptionError("range_deg", f"must be in (0, 180] degrees, got {range_deg}")
        r = math.radians(range_deg)
        lim = np.column_stack([np.maximum(lim[:, 0], -r), np.minimum(lim[:, 1], r)])
    bad = np.flatnonzero(lim[:, 0] > lim[:, 1])
    if bad.size:
        raise OptionError("limits", f"joint '{robot.joint_names[bad[0]]}': empty sampling range")
    return lim
