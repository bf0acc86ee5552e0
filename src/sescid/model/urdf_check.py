"""What of a parsed URDF statics can use: one tree, supported joints, finite numbers.

Real-world quirks are accepted with a note (``RobotModel.notes``): a ``<mimic>`` left on a fixed
joint is ignored; a ``floating`` joint that hangs the whole robot from a massless world link is
dropped with that link (the robot is re-rooted at its support anyway); an inertia tensor that is
not physical (negative principal moment, triangle inequality broken) is named, since statics
does not use it. Everything else is a one-line ``ModelError`` naming the file and the element:
links that form two trees or a loop, prismatic and planar joints, a mimic of a missing or
dependent joint, lower > upper limits, non-finite numbers, a zero axis, a negative mass.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sescid.errors import ModelError
from sescid.model.inertia import inertia_issue, physical
from sescid.model.urdf_records import Joint, Link, Urdf

_SUPPORTED = {"revolute", "continuous", "fixed"}


@dataclass
class UrdfTree:
    """A URDF that passed the checks: its links and joints (file order) and their numbers."""

    name: str
    links: dict[str, Link]
    joints: list[Joint]  #: the kept joints (a dropped floating root joint is not here)
    root: str  #: the file's own root link
    joint_names: list[str]  #: independent joints (columns of q), file order
    drive: dict[str, tuple[int, float, float]]  #: movable joint → (column, multiplier, offset)
    limits: np.ndarray  #: (nq, 2) rad
    origins: dict[str, np.ndarray]  #: joint → (4, 4) origin
    axes: dict[str, np.ndarray]  #: movable joint → (3,) unit axis
    notes: list[str] = field(default_factory=list)


def finite_array(path: Path, what: str, values: Any) -> np.ndarray:
    """``values`` as a float array; ModelError naming ``what`` if a number is not finite."""
    arr = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{path}: {what} has a non-finite number")
    return arr


def _axis(path: Path, j: Joint) -> np.ndarray:
    try:
        a = np.array([1.0, 0.0, 0.0]) if j.axis is None else np.asarray(j.axis, dtype=float)
    except (TypeError, ValueError):
        a = np.zeros(0)
    norm = float(np.linalg.norm(a)) if a.shape == (3,) else math.nan
    if not math.isfinite(norm) or norm < 1e-12:
        raise ModelError(
            f"{path}: joint '{j.name}' has a zero or invalid axis (expected 3 numbers)"
        )
    return a / norm


def _drop_floating_root(links: dict, joints: list, notes: list[str]) -> tuple[list, set[str]]:
    """Joints without a floating joint that hangs the robot from a massless world link; the
    world links so dropped."""
    out, world = [], set()
    for j in joints:
        if j.type == "floating":
            parent = links.get(j.parent)
            has_parent = any(k.child == j.parent for k in joints)
            massless = parent is None or parent.inertial is None or not parent.inertial.mass
            if not has_parent and massless:
                notes.append(
                    f"floating root joint '{j.name}' dropped (world link '{j.parent}' "
                    "removed): the robot is rooted at its support instead"
                )
                world.add(j.parent)
                continue
        out.append(j)
    return out, world


def _one_tree(path: Path, links: dict[str, Link], joints: list[Joint]) -> str:
    """The root link of the one tree the joints make of the links (ModelError otherwise)."""
    child_joint: dict[str, Joint] = {}
    children: dict[str, list[str]] = {name: [] for name in links}
    for j in joints:
        if j.parent not in links or j.child not in links:
            raise ModelError(f"{path}: joint '{j.name}' names a link that does not exist")
        if j.child in child_joint:
            raise ModelError(f"{path}: link '{j.child}' has two parent joints")
        child_joint[j.child] = j
        children[j.parent].append(j.child)
    roots = [name for name in links if name not in child_joint]
    if len(roots) > 1:
        listed = ", ".join(f"'{r}'" for r in roots[:6]) + (", …" if len(roots) > 6 else "")
        raise ModelError(
            f"{path}: the links form {len(roots)} separate trees (roots {listed}); a URDF robot "
            "is one tree: attach each root by a joint or remove it"
        )
    seen, todo = set(roots), list(roots)
    while todo:
        for c in children[todo.pop()]:
            seen.add(c)
            todo.append(c)
    if len(seen) < len(links):
        loop = next(name for name in links if name not in seen)
        raise ModelError(f"{path}: the joints form a loop through link '{loop}'")
    return roots[0]


def _drives(path: Path, joints: list[Joint]) -> tuple[list[str], dict[str, tuple]]:
    """Independent joint names (file order) and each movable joint's (column, k, offset)."""
    by_name = {j.name: j for j in joints}
    movable = [j for j in joints if j.type != "fixed"]
    joint_names = [j.name for j in movable if j.mimic is None]
    col = {name: i for i, name in enumerate(joint_names)}
    drive: dict[str, tuple[int, float, float]] = {}
    for j in movable:
        if j.mimic is None:
            drive[j.name] = (col[j.name], 1.0, 0.0)
            continue
        master = by_name.get(j.mimic.joint or "")
        if master is None:
            raise ModelError(
                f"{path}: joint '{j.name}' mimics '{j.mimic.joint}', which does not exist"
            )
        if master.type == "fixed" or master.mimic is not None:
            raise ModelError(
                f"{path}: joint '{j.name}' mimics '{j.mimic.joint}', which is not an "
                "independent revolute/continuous joint"
            )
        mult = 1.0 if j.mimic.multiplier is None else float(j.mimic.multiplier)
        off = 0.0 if j.mimic.offset is None else float(j.mimic.offset)
        finite_array(path, f"joint '{j.name}' mimic", [mult, off])
        drive[j.name] = (col[master.name], mult, off)
    return joint_names, drive


def _limits(path: Path, joints: list[Joint], joint_names: list[str]) -> np.ndarray:
    """(nq, 2) lower/upper [rad]; ±inf for continuous joints and absent limits."""
    by_name = {j.name: j for j in joints}
    limits = np.empty((len(joint_names), 2))
    for i, name in enumerate(joint_names):
        j = by_name[name]
        lim = j.limit
        if j.type == "continuous" or lim is None or lim.lower is None or lim.upper is None:
            limits[i] = (-np.inf, np.inf)
            continue
        lo, hi = float(lim.lower), float(lim.upper)
        if math.isnan(lo) or math.isnan(hi):
            raise ModelError(f"{path}: joint '{name}' has a non-finite limit")
        if lo > hi:
            raise ModelError(f"{path}: joint '{name}' has lower limit {lo:g} > upper {hi:g} rad")
        limits[i] = (lo, hi)
    return limits


def _inertials(path: Path, links: dict[str, Link], notes: list[str]) -> None:
    """Masses finite and ≥ 0, inertial origins and tensors finite; unphysical tensors noted."""
    tensors = {}
    for name, link in links.items():
        inertial = link.inertial
        if inertial is None:
            continue
        m = inertial.mass
        if m is not None and not (math.isfinite(m) and m >= 0):
            raise ModelError(
                f"{path}: link '{name}' has an invalid mass {m} (a mass is a finite number ≥ 0 kg)"
            )
        if inertial.origin is not None:
            finite_array(path, f"link '{name}' inertial origin", inertial.origin)
        if inertial.inertia is not None:
            tensors[name] = finite_array(path, f"link '{name}' inertia", inertial.inertia)
            if not m:
                del tensors[name]  # a massless link's tensor means nothing
    ok = physical(np.array(list(tensors.values()))) if tensors else np.zeros(0, bool)
    bad = [n for n, good in zip(tensors, ok, strict=True) if not good]
    odd = [f"link '{n}' inertia {inertia_issue(tensors[n])}" for n in bad]
    if odd:
        notes.append(
            f"{len(odd)} unphysical inertia tensor(s), e.g. {odd[0]}: statics does not use "
            "inertia tensors, the physics bench and simulators do"
        )


def check_urdf(path: Path, urdf: Urdf, support: str) -> UrdfTree:
    """The parsed ``urdf`` checked for statics rooted at the link ``support`` (see the module
    doc); ModelError naming the file and the element otherwise."""
    robot = urdf.robot
    links = {lk.name: lk for lk in robot.links}
    notes: list[str] = []
    joints, world = _drop_floating_root(links, list(robot.joints), notes)
    used = {j.parent for j in joints} | {j.child for j in joints}
    links = {n: lk for n, lk in links.items() if n not in world or n in used}
    if support not in links:
        raise ModelError(
            f"{path}: unknown support link '{support}' (links: {', '.join(sorted(links)[:12])}"
            + (", …)" if len(links) > 12 else ")")
        )
    root = _one_tree(path, links, joints)
    for j in joints:
        if j.type not in _SUPPORTED:
            raise ModelError(
                f"{path}: joint '{j.name}' has type '{j.type}'; only revolute, continuous and "
                "fixed joints are supported (the SESC form needs rotations only)"
            )
        if j.mimic is not None and j.type == "fixed":
            notes.append(f"fixed joint '{j.name}': its <mimic> is ignored (a fixed joint is rigid)")
    joint_names, drive = _drives(path, joints)
    limits = _limits(path, joints, joint_names)
    given = [j for j in joints if j.origin is not None]
    if given and not np.all(np.isfinite(np.array([j.origin for j in given]))):
        for j in given:  # name the first culprit
            finite_array(path, f"joint '{j.name}' origin", j.origin)
    origins = {j.name: np.eye(4) if j.origin is None else j.origin for j in joints}
    axes = {j.name: _axis(path, j) for j in joints if j.type != "fixed"}
    _inertials(path, links, notes)
    return UrdfTree(
        robot.name, links, joints, root, joint_names, drive, limits, origins, axes, notes
    )
