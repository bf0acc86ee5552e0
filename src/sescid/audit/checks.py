"""Model checks on a candidate file, each named by body (or link, or joint): what a model file
can get wrong by itself, before any measurement.

- an inertia tensor that is not physical (``sescid.model.inertia.inertia_issue``, the one rule);
- a moving body with zero or negligible mass (below ``NEGLIGIBLE_SHARE`` of the total);
- a welded link with mass and no geometry (``PHANTOM_SHARE`` of the total or more): mass put on a
  frame that moves nothing and that nothing can be seen on, a "phantom";
- an unlimited (continuous) joint;
- a name the file gives twice (links/bodies, joints).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections import Counter
from dataclasses import dataclass

import numpy as np

from sescid.model.inertia import inertia_issue
from sescid.robot import Robot

#: a moving body lighter than this share of the total mass counts as massless
NEGLIGIBLE_SHARE = 1e-4
#: a welded link without geometry carrying at least this share of the total mass is flagged
PHANTOM_SHARE = 0.01


@dataclass(frozen=True)
class Check:
    """One problem of a model file: where (a body, link or joint) and what."""

    body: str
    problem: str

    def to_json(self) -> dict:
        """``{body, problem}``."""
        return {"body": self.body, "problem": self.problem}


def _duplicates(robot: Robot) -> list[Check]:
    """Names the file gives twice (links or MJCF bodies, joints)."""
    try:
        root = ET.parse(robot.model_path).getroot()
    except (ET.ParseError, OSError):  # the loader read it; nothing more to say here
        return []
    tags = ("link", "joint") if robot.model.format == "urdf" else ("body", "joint")
    out = []
    for tag in tags:
        found = [
            e.get("name")
            for e in root.iter(tag)
            if e.get("name") and (robot.model.format != "urdf" or e in list(root))
        ]
        for name, k in Counter(found).items():
            if k > 1:
                out.append(Check(str(name), f"the {tag} name '{name}' is given {k} times"))
    return out


def model_checks(robot: Robot) -> list[Check]:
    """Every problem of the robot's model file, named by body (module docstring)."""
    model = robot.model
    total = robot.total_mass
    out: list[Check] = []
    for link, inertial in model.inertials.items():
        if inertial.inertia is None or not inertial.mass > 0:
            continue
        issue = inertia_issue(inertial.inertia)
        if issue is not None:
            out.append(Check(link, f"inertia tensor {issue}"))
    for b in model.bodies[1:]:
        if not b.frame_only and b.mass < NEGLIGIBLE_SHARE * total:
            out.append(
                Check(b.name, f"moves (joint {b.joint_name}) but has {b.mass:.3g} kg: massless")
            )
    with_shapes = {s.link for s in model.shapes}
    mains = {b.name for b in model.bodies}
    for link, inertial in model.inertials.items():
        if link in mains or link in with_shapes or link not in model.link_frames:
            continue
        if inertial.mass >= PHANTOM_SHARE * total:
            body = robot.body_names[model.link_frames[link][0]]
            out.append(
                Check(
                    link,
                    f"carries {inertial.mass:.3g} kg on a welded frame of {body} without any "
                    "geometry (a phantom mass?)",
                )
            )
    lo, hi = model.joint_limits[:, 0], model.joint_limits[:, 1]
    by_joint = {b.joint_name: b.name for b in model.bodies if b.parent >= 0}
    for j in np.flatnonzero(~(np.isfinite(lo) & np.isfinite(hi))):
        name = model.joint_names[j]
        out.append(Check(by_joint.get(name, name), f"joint {name} has no limits"))
    return out + _duplicates(robot)
