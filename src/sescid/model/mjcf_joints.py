"""The joints of an MJCF robot: which are its coordinates, which follow others, their limits.

From MuJoCo's compiled model: the robot is the subtree of one top-level body; that body's own
joints (a free joint, say) are dropped with a note; below it only hinges are supported. An active
``<equality><joint>`` makes joint1 follow joint2 linearly (``qpos1 − ref1 = c0 + c1 (qpos2 −
ref2)``) or, without joint2, locks joint1 at ``ref1 + c0``. Every hinge's angle is then
``k q[col] + o`` for an independent joint ``col`` (``o = −ref`` for an ordinary hinge: MuJoCo
rotates by ``qpos − ref``), or the constant ``o`` (``col = −1``) for a locked one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sescid.errors import ModelError
from sescid.model.mjcf_compile import mujoco_module


@dataclass
class MjcfJoints:
    """The robot's joints, read from a compiled MjModel (ids are MuJoCo joint ids)."""

    robot: list[int]  #: hinge ids below the top-level body, document order
    names: list[str]  #: independent joints (columns of q), document order
    limits: np.ndarray  #: (nq, 2) rad, ±inf when not limited
    drive: dict[int, tuple[int, float, float]]  #: hinge id → (column or −1, k, o)
    notes: list[str] = field(default_factory=list)


def _robot_hinges(path: Path, m: Any, in_robot: list[int], names: list[str]) -> MjcfJoints:
    """The hinges below the top-level body ``in_robot[0]`` (other joint types: ModelError)."""
    mujoco = mujoco_module()
    root, dropped, robot = in_robot[0], [], []
    for b in in_robot:
        for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]):
            jt = m.jnt_type[j]
            if b == root:
                dropped.append(names[j])
            elif jt == mujoco.mjtJoint.mjJNT_FREE:
                raise ModelError(
                    f"{path}: joint '{names[j]}' is a free joint below the top-level "
                    "body; only a free root joint is supported"
                )
            elif jt != mujoco.mjtJoint.mjJNT_HINGE:
                kind = mujoco.mjtJoint(jt).name.removeprefix("mjJNT_").lower()
                raise ModelError(
                    f"{path}: joint '{names[j]}' is a {kind} joint; only hinge joints "
                    "are supported (the SESC form needs rotations only)"
                )
            else:
                robot.append(j)
    notes = []
    if dropped:
        notes.append(
            f"{path}: joints of the top-level body '{m.body(root).name or f'body{root}'}' "
            f"dropped ({', '.join(dropped)}): the support frame does not see them"
        )
    return MjcfJoints(robot, [], np.empty((0, 2)), {}, notes)


def _couplings(path: Path, m: Any, robot: set[int], names: list[str]) -> dict:
    """Active joint equalities on the robot: joint1 → (joint2 or −1, c1, c0)."""
    mujoco = mujoco_module()
    follows: dict[int, tuple[int, float, float]] = {}
    for e in range(m.neq):
        if m.eq_type[e] != mujoco.mjtEq.mjEQ_JOINT or not m.eq_active0[e]:
            continue
        j1, j2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        if j1 not in robot:
            continue
        ename = m.equality(e).name or f"equality {e}"
        coef = np.asarray(m.eq_data[e, :5], dtype=float)
        if not np.all(np.isfinite(coef)):
            raise ModelError(f"{path}: joint equality '{ename}' has a non-finite polycoef")
        if np.any(coef[2:] != 0):
            raise ModelError(
                f"{path}: joint equality '{ename}' ({names[j1]} from "
                f"{names[j2] if j2 >= 0 else 'a constant'}) has nonzero polycoef "
                f"{coef[2:].tolist()} beyond the linear term; only linear couplings are supported"
            )
        if j2 >= 0 and j2 not in robot:
            raise ModelError(
                f"{path}: joint equality '{ename}' couples '{names[j1]}' to "
                f"'{names[j2]}', which is not a hinge of the robot below its root"
            )
        if j1 in follows:
            raise ModelError(f"{path}: joint '{names[j1]}' is coupled twice")
        follows[j1] = (j2, float(coef[1]), float(coef[0]))
    return follows


def _drives(path: Path, joints: MjcfJoints, follows: dict, ref: np.ndarray, names: list[str]):
    """Each hinge's (column or −1, k, o), following chains of couplings without recursion."""
    col = {j: i for i, j in enumerate(j for j in joints.robot if j not in follows)}
    drive = joints.drive
    for start in joints.robot:
        chain: list[int] = []
        j = start
        while j not in drive:  # walk to a resolved, independent or locked joint
            if j in chain:
                raise ModelError(f"{path}: joint equalities form a loop through '{names[j]}'")
            chain.append(j)
            if j not in follows:
                drive[j] = (col[j], 1.0, -float(ref[j]))
                chain.pop()
                break
            j2, _, c0 = follows[j]
            if j2 < 0:
                drive[j] = (-1, 0.0, c0)
                chain.pop()
                break
            j = j2
        for j in reversed(chain):  # then each follower from the joint it follows
            j2, c1, c0 = follows[j]
            c2, k2, o2 = drive[j2]
            drive[j] = (c2, c1 * k2, c0 + c1 * o2)


def robot_joints(path: Path, m: Any, in_robot: list[int], names: list[str]) -> MjcfJoints:
    """The joints of the robot whose bodies are ``in_robot`` (top-level body first); ``names``:
    every joint's name by MuJoCo id."""
    joints = _robot_hinges(path, m, in_robot, names)
    follows = _couplings(path, m, set(joints.robot), names)
    _drives(path, joints, follows, m.qpos0[m.jnt_qposadr], names)
    independent = [j for j in joints.robot if j not in follows]
    joints.names = [names[j] for j in independent]
    joints.limits = np.empty((len(independent), 2))
    for i, j in enumerate(independent):
        joints.limits[i] = m.jnt_range[j] if m.jnt_limited[j] else (-np.inf, np.inf)
    return joints
