"""A robot carrying a known payload, for payload tests and studies: the model file with one
more link (a point mass) fixed to a body, written beside a copy of the model (tests only)."""

from __future__ import annotations

from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from sescid import load_robot
from sescid.robot import Robot

PAYLOAD_LINK = "payload_truth"


def urdf_with_payload(src: Path, out: Path, body: str, mass: float, com) -> Path:
    """``src`` URDF with a link of mass ``mass`` [kg] fixed to ``body`` at ``com`` (3,) [m, its
    frame] (a tiny inertia: a point mass); written to ``out`` (the same folder keeps meshes)."""
    tree = ET.parse(src)
    root = tree.getroot()
    link = ET.SubElement(root, "link", name=PAYLOAD_LINK)
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=repr(float(mass)))
    ET.SubElement(inertial, "inertia", ixx="1e-6", iyy="1e-6", izz="1e-6", ixy="0", ixz="0",
                  iyz="0")  # fmt: skip
    joint = ET.SubElement(root, "joint", name=PAYLOAD_LINK + "_joint", type="fixed")
    ET.SubElement(joint, "parent", link=body)
    ET.SubElement(joint, "child", link=PAYLOAD_LINK)
    c = np.asarray(com, dtype=float)
    ET.SubElement(joint, "origin", xyz=" ".join(repr(float(v)) for v in c), rpy="0 0 0")
    tree.write(out)
    return out


def robot_with_payload(robot: Robot, folder: Path, body: str, mass: float, com) -> Robot:
    """The same robot (model, support) with the payload added, loaded from a URDF written in
    ``folder``; for a model file, beside it (its meshes resolve) when ``folder`` is None."""
    src = Path(robot.model_path)
    out = Path(folder) / f"{src.stem}_payload.urdf"
    urdf_with_payload(src, out, body, mass, com)
    return load_robot(out, robot.support, robot.line)
