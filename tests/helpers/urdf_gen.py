"""Random kinematic trees as URDF text, for oracle tests."""

from __future__ import annotations

import numpy as np


def _vec(v) -> str:
    return " ".join(f"{x:.17g}" for x in v)


def random_urdf(
    rng: np.random.Generator,
    n_links: int = 10,
    p_fixed: float = 0.3,
    p_continuous: float = 0.2,
    p_massless: float = 0.15,
    mimic: bool = False,
) -> tuple[str, list[str], dict]:
    """URDF text, link names and the mimic map {joint: (master, multiplier, offset)}."""
    links = [f"link{i}" for i in range(n_links)]
    out = ['<?xml version="1.0"?>', '<robot name="random_tree">']
    for name in links:
        out.append(f'  <link name="{name}">')
        if rng.random() > p_massless:
            m = rng.uniform(0.05, 2.0)
            d = rng.uniform(1e-4, 1e-2, 3)
            out += [
                "    <inertial>",
                f'      <origin xyz="{_vec(rng.uniform(-0.1, 0.1, 3))}" '
                f'rpy="{_vec(rng.uniform(-np.pi, np.pi, 3))}"/>',
                f'      <mass value="{m:.17g}"/>',
                f'      <inertia ixx="{d[0]}" ixy="0" ixz="0" iyy="{d[1]}" iyz="0" izz="{d[2]}"/>',
                "    </inertial>",
            ]
        out.append("  </link>")
    movable: list[str] = []
    mimics: dict = {}
    for i in range(1, n_links):
        parent = links[int(rng.integers(0, i))]
        u = rng.random()
        jtype = (
            "fixed" if u < p_fixed else ("continuous" if u < p_fixed + p_continuous else "revolute")
        )
        name = f"joint{i}"
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        out += [
            f'  <joint name="{name}" type="{jtype}">',
            f'    <parent link="{parent}"/>',
            f'    <child link="{links[i]}"/>',
            f'    <origin xyz="{_vec(rng.uniform(-0.2, 0.2, 3))}" '
            f'rpy="{_vec(rng.uniform(-np.pi, np.pi, 3))}"/>',
        ]
        if jtype != "fixed":
            out.append(f'    <axis xyz="{_vec(axis)}"/>')
        if jtype == "revolute":
            out.append('    <limit lower="-3" upper="3" effort="1" velocity="1"/>')
        if mimic and jtype != "fixed" and movable and rng.random() < 0.3:
            master = movable[int(rng.integers(0, len(movable)))]
            mult, off = rng.uniform(-2, 2), rng.uniform(-0.5, 0.5)
            out.append(
                f'    <mimic joint="{master}" multiplier="{mult:.17g}" offset="{off:.17g}"/>'
            )
            mimics[name] = (master, mult, off)
        elif jtype != "fixed":
            movable.append(name)
        out.append("  </joint>")
    out.append("</robot>")
    return "\n".join(out) + "\n", links, mimics
