"""Stable single-support test poses for the OP2 (tests only, until pose planning ships).

A base stance leans the robot over its right foot (right ankle and hip roll, right ankle pitch)
with the left leg lifted; random poses are drawn around it and kept when the model's CoP lies
within ±limit of the right sole centre (the paper's ±0.023 m box, tightened).
"""

from __future__ import annotations

import math

import numpy as np

from sescid.simulation import random_poses

#: joint → angle [deg] of the base stance (CoP of the model at (−0.04, −0.0002) mm)
BASE_DEG = {
    "r_ank_roll": -16.51,
    "r_hip_roll": -16.58,
    "r_ank_pitch": 4.38,
    "l_hip_pitch": -20.0,
    "l_knee": -40.0,
    "l_ank_pitch": 20.0,
}


def stable_poses(robot, n, range_deg=10.0, seed=0, limit=0.015) -> np.ndarray:
    """n poses (n, nq) [rad]: base stance + U(±range_deg), within joint limits, CoP in the box."""
    base = np.zeros(robot.nq)
    for j, deg in BASE_DEG.items():
        base[robot.joint_names.index(j)] = math.radians(deg)
    rng = np.random.default_rng(seed)
    lim = robot.joint_limits
    out = []
    while sum(len(o) for o in out) < n:
        q = base + random_poses(robot, 4 * n, range_deg, rng)
        q = np.clip(q, lim[:, 0], lim[:, 1])
        ok = np.all(np.abs(robot.cop(q)) < limit, axis=1)
        out.append(q[ok])
    return np.concatenate(out)[:n]
