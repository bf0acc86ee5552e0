"""Joint angles (rad) and joint torques (``tau_<joint>``, N·m) out of their topics: a
``JointState`` matched by name (``rename``), or an array by position (``index``/``names``).

Angles beyond ±2π rad in a ``unit: rad`` mapping are an error naming the message and the joint
(a recording in degrees needs ``joints.unit: deg``). Torques may cover any subset of the joints.
"""

from __future__ import annotations

import math

import numpy as np

from sescid.base.text import listed
from sescid.errors import DataError
from sescid.io.bags.mapping import TORQUE_NM, BagMapping
from sescid.io.bags.messages import bag_names, by_index, by_name
from sescid.io.bags.stamps import Clocked

_JOINT_STATE = ("sensor_msgs/msg/JointState",)


def joint_angles(c: Clocked, mp: BagMapping, joint_names: list[str], notes) -> np.ndarray:
    """Joint angles (m, nq) rad of the joint topic, in its message order."""
    js, where = mp.joints, c.where
    if js.kind == "array":
        unknown = [j for j in js.index if j not in joint_names]
        if unknown:
            raise DataError(f"{where}: index: '{unknown[0]}' is not a joint of the robot")
        missing = [j for j in joint_names if j not in js.index]
        if missing:
            raise DataError(f"{where}: index: no array index for joint '{missing[0]}'")
        q = by_index(c.topic, js.field, {j: js.index[j] for j in joint_names}, where)
    else:
        q, seen, empty = by_name(c.topic, js.field, js.rename, joint_names, where)
        missing = [j for j in joint_names if j not in seen]
        if missing:
            have = bag_names(c.topic)
            raise DataError(
                f"{where}: joint {listed([repr(m) for m in missing], first=1)} is not in "
                f"{c.topic.name} (its names: {listed(have, first=8)}); "
                "add joints.rename: {bag_name: model_name}"
            )
        if empty:
            notes.append(f"{c.topic.name}: {empty} joint states have no {js.field} values")
    if js.unit == "deg":
        return np.radians(q)
    big = np.argwhere(np.abs(q) > 2 * math.pi)
    if len(big):
        i, k = big[0]
        raise DataError(
            f"{c.topic.bag}: message {i} on {c.topic.name}, joint '{joint_names[k]}': "
            f"{q[i, k]:g} rad looks like degrees (set joints.unit: deg in {mp.source})"
        )
    return q


def joint_torques(
    c: Clocked, mp: BagMapping, joint_names: list[str], notes
) -> dict[str, np.ndarray]:
    """``tau_<joint>`` (m,) N·m per mapped joint, in the torque topic's message order."""
    ts, where = mp.torques, c.where
    assert ts is not None
    if ts.kind == "array":
        unknown = [j for j in ts.index if j not in joint_names]
        if unknown:
            raise DataError(f"{where}: '{unknown[0]}' is not a joint of the robot")
        names = [j for j in joint_names if j in ts.index]
        tau = by_index(c.topic, ts.field, {j: ts.index[j] for j in names}, where)
    else:
        full, seen, empty = by_name(c.topic, ts.field, ts.rename, joint_names, where)
        names = [j for j in joint_names if j in seen]
        if not names:
            raise DataError(
                f"{where}: no joint of the robot in {c.topic.name} (its names: "
                f"{', '.join(bag_names(c.topic)[:8])}); add torques.rename"
            )
        tau = full[:, [joint_names.index(j) for j in names]]
        if empty == len(c.topic.msgs):
            raise DataError(
                f"{c.topic.bag}: no message on {c.topic.name} has {ts.field} values "
                f"({where}.field; the recording holds no joint torques there)"
            )
        if empty:
            notes.append(f"{c.topic.name}: {empty} messages have no {ts.field} values (NaN)")
    tau = tau * (ts.scale * TORQUE_NM[ts.unit])
    return {f"tau_{j}": tau[:, k] for k, j in enumerate(names)}


#: rad: consecutive joint states further apart than this, while the states two apart agree,
#: alternate between two time lines
ALTERNATION_RAD = 0.01
#: alternating joint states that make a recording two interleaved time lines
ALTERNATIONS = 10


def check_joint_values(c: Clocked, tj: np.ndarray, q: np.ndarray, joint_names, notes) -> None:
    """Name the joints whose angles are NaN (a note; an error when one never has a value), and
    refuse joint states that alternate between two time lines (a clock that stepped back
    while recording: the bag's order interleaves two stretches of the session)."""
    where = f"{c.topic.bag}: {c.topic.name}"
    nan = np.isnan(q)
    if nan.any():
        counts = nan.sum(axis=0)
        dead = [j for j, n in zip(joint_names, counts, strict=True) if n == len(q)]
        if dead:
            raise DataError(
                f"{where}: joint '{dead[0]}' has no value (NaN) in any of the {len(q)} joint "
                "states: no sample can be placed (a dead encoder?)"
            )
        shown = ", ".join(f"'{j}' {int(n)}" for j, n in zip(joint_names, counts, strict=True)
                          if n)  # fmt: skip
        notes.append(
            f"{c.topic.name}: NaN joint angles ({shown} of {len(q)} joint states): the samples "
            "they would place are dropped (missing_joint)"
        )
    if len(q) < 3:
        return
    with np.errstate(invalid="ignore"):
        d1 = np.nanmax(np.abs(q[1:-1] - q[:-2]), axis=1)
        d2 = np.nanmax(np.abs(q[2:] - q[:-2]), axis=1)
    alt = np.flatnonzero((d1 > ALTERNATION_RAD) & (d2 < 0.25 * d1))
    if alt.size >= ALTERNATIONS:
        t = (tj[alt[0] + 1] - tj[0]) * 1e-9
        raise DataError(
            f"{where}: from {t:.3f} s on, {alt.size} joint states alternate between two sets of "
            "angles: two time lines interleaved in one recording (a clock that stepped back?); "
            "split the bag where the clock stepped back"
        )
