"""Where each body's CoM may lie (a box in its frame), and which bodies mirror each other."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Literal

import numpy as np

from sescid.errors import SescidError
from sescid.model import ShapeRole, body_hulls
from sescid.robot import Robot

#: default growth of the fallback box (joint points + CAD CoM), m
FALLBACK_MARGIN = 0.02


#: where a CoM box came from: the body's collision or visual shapes, the fallback hull of its
#: joint points, or the caller
BoxSource = Literal[ShapeRole, "fallback", "given"]


@dataclass(frozen=True)
class Box:
    """An axis-aligned box in a body's frame (m) and where it came from."""

    lo: np.ndarray  #: (3,) m
    hi: np.ndarray  #: (3,) m
    source: BoxSource
    grown: bool = False  #: grown to contain the body's CAD CoM


def body_boxes(
    robot: Robot,
    boxes: dict[str, tuple] | None = None,
    box_margin: float | None = None,
) -> list[Box]:
    """One box per body (in the body's frame, m) bounding where its CoM may lie.

    ``boxes``: ``{body name: (lo (3,), hi (3,))}`` in the frame of the body's main URDF link
    (its name), m; they take precedence. Otherwise the model's collision shapes, else its visual
    shapes, else the fallback (joint points + CAD CoM). ``box_margin`` (m) grows every box;
    default 0 for given/shape boxes and ``FALLBACK_MARGIN`` for fallback ones. A shape box that
    does not contain the body's CAD CoM is grown to contain it (``Box.grown``): the CAD model
    itself must be feasible.
    """
    model = robot.model
    names = robot.body_names
    if box_margin is not None and not (math.isfinite(box_margin) and box_margin >= 0):
        raise SescidError(f"box margin must be a finite length ≥ 0 m, got {box_margin}")
    given = {}
    for name, box in (boxes or {}).items():
        if name not in names:
            raise SescidError(f"box for unknown body '{name}' (bodies: {', '.join(names)})")
        try:
            lo, hi = (np.asarray(v, dtype=float).reshape(3) for v in box)
        except (TypeError, ValueError):
            raise SescidError(f"box for body '{name}': expected (lo xyz, hi xyz) in m") from None
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(lo <= hi)):
            raise SescidError(f"box for body '{name}': needs finite lo ≤ hi on every axis (m)")
        b = names.index(name)
        x = model.link_frames[model.bodies[b].name][1]  # main link frame in the body frame
        corners = np.array([[(lo, hi)[k >> a & 1][a] for a in range(3)] for k in range(8)])
        pts = corners @ x[:3, :3].T + x[:3, 3]
        given[b] = (pts.min(axis=0), pts.max(axis=0))
    collision = body_hulls(model.shapes, "collision")
    visual = body_hulls(model.shapes, "visual")
    children: list[list[int]] = [[] for _ in names]
    for i, body in enumerate(model.bodies):
        if body.parent >= 0:
            children[body.parent].append(i)
    out = []
    source: BoxSource
    for b, body in enumerate(model.bodies):
        if b in given:
            (lo, hi), source, margin = given[b], "given", box_margin or 0.0
        elif b in collision:
            (lo, hi), source, margin = collision[b], "collision", box_margin or 0.0
        elif b in visual:
            (lo, hi), source, margin = visual[b], "visual", box_margin or 0.0
        else:
            pts = [np.zeros(3), body.com]
            pts += [model.bodies[c].trans_const for c in children[b]]
            pts += [model.link_frames[lk][1][:3, 3] for lk in body.links]
            pts = np.array(pts)
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            source = "fallback"
            margin = FALLBACK_MARGIN if box_margin is None else box_margin
        lo, hi = lo - margin, hi + margin
        grown = False
        if source in ("collision", "visual") and body.mass > 0:
            new_lo, new_hi = np.minimum(lo, body.com), np.maximum(hi, body.com)
            grown = bool(np.any(new_lo < lo) or np.any(new_hi > hi))
            lo, hi = new_lo, new_hi
        out.append(Box(lo, hi, source, grown))
    return out


_SIDES = [
    (r"^(.*)_R$", r"\1_L"),
    (r"^(.*)_r$", r"\1_l"),
    (r"^r_(.*)$", r"l_\1"),
    (r"^R_(.*)$", r"L_\1"),
    (r"^(.*)right(.*)$", r"\1left\2"),
    (r"^(.*)Right(.*)$", r"\1Left\2"),
]


def mirror_pairs(names: list[str]) -> list[tuple[int, int]]:
    """Index pairs (right, left) of bodies whose names differ only by a side marker."""
    index = {n: i for i, n in enumerate(names)}
    pairs = []
    for i, n in enumerate(names):
        for pat, rep in _SIDES:
            if re.match(pat, n):
                other = re.sub(pat, rep, n)
                if other in index and other != n:
                    pairs.append((i, index[other]))
                    break
    return pairs


def mirror_plane(robot: Robot, pairs) -> tuple[np.ndarray, float]:
    """Sagittal plane (unit normal n, offset c: n·p = c) from the mirrored links at q = 0."""
    names = robot.body_names
    q0 = np.zeros((1, robot.nq))
    p = {names[b]: robot.link_poses(q0, names[b])[1][0] for pair in pairs for b in pair}
    diff = sum(p[names[j]] - p[names[i]] for i, j in pairs)
    if np.linalg.norm(diff) < 1e-9:
        raise SescidError("symmetric: the mirrored bodies' frames coincide; no sagittal plane")
    n = diff / np.linalg.norm(diff)
    c = float(np.mean([n @ (p[names[i]] + p[names[j]]) / 2 for i, j in pairs]))
    for i, j in pairs:
        pr, pl = p[names[i]], p[names[j]]
        if np.linalg.norm(pl - 2 * (n @ pl - c) * n - pr) > 1e-3:
            raise SescidError(
                f"symmetric: {names[i]} and {names[j]} are not mirror images at the zero pose "
                "(their frames differ by > 1 mm after reflection)"
            )
    return n, c
