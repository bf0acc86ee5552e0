"""A standalone 3-D view for the HTML report: the robot at the measured poses, with a slider.

No library, no network: the page carries the scene as JSON (support frame, mm) and a small inline
script (``view3d_script``) draws it on a ``<canvas>``: a floor grid with the robot's shadow, the
support sole filled and labelled, each collision capsule as a thick line with round caps coloured
by limb (support foot, support leg, trunk, other limbs) over a skeleton of the body origins (so a
model whose collision geometry is only its feet still shows its limbs), the identified CoM (the
quartered disc) with its drop line to the floor, and, with CoP data, the measured CoP (blue dot)
and the identified model's (green ring); an inset shows the sole from above at a scale where
millimetres show; a legend, an axis gizmo and the pose label are drawn on the canvas. The camera
frames every pose at once (so a slide does not rescale), from the front-left and above; dragging
turns it, a double click resets it. ``#view3d=K`` in the address opens pose K (scrolled into view).
After every draw the canvas reports its pose and its count of non-background pixels in
``data-pose`` and ``data-ink`` (the page's own check, read by the tests).
"""

from __future__ import annotations

import html
import json

import numpy as np

from sescid.planning import collision_capsules
from sescid.report.view3d_script import SCRIPT
from sescid.robot import Robot

#: limb groups and their colours (support foot, support leg, trunk, then the other limbs)
SUPPORT_FOOT, SUPPORT_LEG, TRUNK = 0, 1, 2
LIMB_COLOURS = ["#e07b00", "#3c8d93", "#8a8f98", "#5b9bd5", "#8e6bbf", "#6aa84f", "#c0587e",
                "#b08a3c", "#4f7fbf"]  # fmt: skip
#: gap [m] between a held robot's lowest point and the reference plane drawn under it
HELD_CLEARANCE = 0.02


def limb_groups(robot: Robot) -> list[int]:
    """A group per body: ``SUPPORT_FOOT`` (the support body), ``SUPPORT_LEG`` (between it and
    the trunk, the model file's root), ``TRUNK``, then one group per other limb (a subtree
    hanging from the trunk or the support leg), numbered from 3."""
    model = robot.model
    bodies = model.bodies
    trunk = model.link_frames[model.model_root][0] if model.model_root in model.link_frames else 0
    group = [-1] * len(bodies)
    b = trunk
    while b > 0:
        group[b] = SUPPORT_LEG
        b = bodies[b].parent
    group[trunk] = TRUNK
    group[0] = SUPPORT_FOOT if trunk != 0 else TRUNK
    limbs: dict[int, int] = {}
    for i in range(len(bodies)):  # parents come before children
        if group[i] >= 0:
            continue
        p = bodies[i].parent
        if group[p] in (SUPPORT_LEG, TRUNK, SUPPORT_FOOT):
            group[i] = limbs.setdefault(i, 3 + len(limbs))
        else:
            group[i] = group[p]
    return group


def _sole_corners(robot: Robot) -> list[list[float]] | None:
    sole = robot.sole
    if sole is None:
        return None
    corners = sole.corners @ robot.model.root_rotation.T + robot.model.root_origin
    mid = corners.mean(axis=0)
    turn = np.arctan2(corners[:, 1] - mid[1], corners[:, 0] - mid[0])
    return np.round(corners[np.argsort(turn)] * 1e3, 1).tolist()  # around the sole, in order


def scene_data(robot: Robot, q, com, cop, cop_fit, labels) -> dict:
    """The view's JSON: per pose capsule segments and body origins, CoM, CoPs (mm, support
    frame; ``cop``/``cop_fit`` (n, 2) m or None without CoP data), limbs and the sole."""
    q = np.asarray(q, dtype=float)
    caps = collision_capsules(robot)
    rot, org = robot.forward(q)
    w0, w1 = caps.world(rot, org)
    mm = 1e3
    groups = limb_groups(robot)
    links = [[b.parent, i] for i, b in enumerate(robot.model.bodies) if b.parent >= 0]
    held = groups[0] == TRUNK  # the trunk itself is held (a gantry): no foot on a floor
    floor = robot.floor
    if held:  # a reference plane under the lowest point of any pose
        floor = float(min(org[..., 2].min(), w0[..., 2].min(), w1[..., 2].min())) - HELD_CLEARANCE

    def pts(a, digits=2):
        return None if a is None else np.round(np.asarray(a) * mm, digits).tolist()

    return {
        "labels": [str(s) for s in labels],
        "body": caps.body.tolist(),
        "group": groups,
        "colours": LIMB_COLOURS,
        "radius": np.round(caps.radius * mm, 1).tolist(),
        "seg": np.round(np.stack([w0, w1], axis=2) * mm, 1).tolist(),  # (n, C, 2, 3)
        "origin": np.round(org * mm, 1).tolist(),  # (n, N, 3)
        "links": links,
        "com": pts(com),
        "cop": pts(cop),
        "cop_fit": pts(cop_fit),
        "sole": None if held else _sole_corners(robot),
        "support": robot.support,
        "held": held,
        "floor": round(floor * mm, 2),
    }


def view3d_html(data: dict, width: int = 900, height: int = 620) -> str:
    """The view's HTML section: canvas, slider, label, the scene JSON and the inline script."""
    n = len(data["labels"])
    name = html.escape(str(data["support"]))
    if data.get("held"):
        support = (
            f"held body ({name}) in grey over a reference plane, the CoM from above in the inset"
        )
    else:
        support = (
            f"support foot ({name}) in orange on the floor grid, the sole from above in the inset"
        )
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    cop = (
        " Blue dot: measured CoP; green ring: the identified model's CoP."
        if data.get("cop") is not None
        else ""
    )
    return f"""<section id="view3d-section">
<h2>3-D view of the measured poses</h2>
<p>The robot's collision capsules at each measured pose (support frame) over its skeleton,
coloured by limb; the {support} (magnified); the identified CoM as the quartered disc with its
drop line.{cop} Slide to change the pose; drag the picture to turn it, double-click to reset.</p>
<input type="range" id="view3d-pose" min="0" max="{n - 1}" value="0" step="1"
 style="width:{width}px" aria-label="pose">
<div id="view3d-label" style="font-size:0.9em">{html.escape(data["labels"][0])}</div>
<canvas id="view3d" width="{width}" height="{height}" style="border:1px solid #ccc;cursor:grab">
</canvas>
<script type="application/json" id="view3d-data">{payload}</script>
<script>{SCRIPT}</script>
</section>"""
