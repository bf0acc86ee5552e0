"""Candidate model files with known faults, for the audit and compare tests and studies: a
URDF rewritten with its masses scaled or jittered, a phantom mass on a frame, a mass moved inside
a link (a battery), as the issue's four candidates describe them."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np


def _xyz(el: ET.Element | None) -> np.ndarray:
    if el is None or el.get("xyz") is None:
        return np.zeros(3)
    return np.array([float(v) for v in el.get("xyz", "0 0 0").split()])


def _set_xyz(inertial: ET.Element, xyz: np.ndarray) -> None:
    origin = inertial.find("origin")
    if origin is None:
        origin = ET.SubElement(inertial, "origin")
        origin.set("rpy", "0 0 0")
    origin.set("xyz", " ".join(f"{v:.9g}" for v in xyz))


def variant_urdf(
    src: Path,
    dst: Path,
    *,
    mass_scale: float = 1.0,
    mass_jitter: float = 0.0,
    com_jitter: float = 0.0,
    seed: int = 0,
    phantom: tuple[str, float, tuple[float, float, float]] | None = None,
    moved: tuple[str, float, tuple[float, float, float]] | None = None,
) -> Path:
    """Write ``src`` (a URDF) to ``dst`` changed: every mass × ``mass_scale`` × (1 + N(0,
    ``mass_jitter``²)), every CoM + N(0, ``com_jitter``²) m per axis; ``phantom`` = (link, kg,
    xyz m): a massive link without geometry welded to ``link`` at xyz; ``moved`` = (link, kg,
    displacement m): a mass of kg inside ``link`` moved by the displacement (its first moment
    changes by kg × displacement, its mass not). Meshes keep their (now relative) names."""
    tree = ET.parse(src)
    root = tree.getroot()
    rng = np.random.default_rng(seed)
    for link in root.findall("link"):
        inertial = link.find("inertial")
        if inertial is None or inertial.find("mass") is None:
            continue
        mass_el = inertial.find("mass")
        assert mass_el is not None
        m = float(mass_el.get("value", "0"))
        if m <= 0:
            continue
        jit = 1.0 + (rng.normal(0.0, mass_jitter) if mass_jitter else 0.0)
        mass_el.set("value", f"{m * mass_scale * jit:.9g}")
        com = _xyz(inertial.find("origin"))
        if com_jitter:
            com = com + rng.normal(0.0, com_jitter, 3)
        if moved is not None and link.get("name") == moved[0]:
            com = com + moved[1] * np.asarray(moved[2]) / (m * mass_scale * jit)
        _set_xyz(inertial, com)
    if phantom is not None:
        name, kg, xyz = phantom
        link = ET.SubElement(root, "link", name="audit_phantom")
        inertial = ET.SubElement(link, "inertial")
        ET.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
        ET.SubElement(inertial, "mass", value=f"{kg:.9g}")
        ET.SubElement(inertial, "inertia", ixx="1e-4", ixy="0", ixz="0", iyy="1e-4", iyz="0",
                      izz="1e-4")  # fmt: skip
        joint = ET.SubElement(root, "joint", name="audit_phantom_joint", type="fixed")
        ET.SubElement(joint, "parent", link=name)
        ET.SubElement(joint, "child", link="audit_phantom")
        ET.SubElement(joint, "origin", xyz=" ".join(f"{v:.9g}" for v in xyz), rpy="0 0 0")
    tree.write(dst)
    return dst
