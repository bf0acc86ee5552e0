"""Test helper: a small (~3 kg, 0.45 m) URDF biped whose collision geometry is meshes only:
every link's collision is a binary STL box written next to the URDF (``meshes/``), the feet
included; sole links ``r_sole``/``l_sole`` sit at the centre of each foot mesh's bottom face."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

FOOT = (0.10, 0.06, 0.02)  #: m, foot mesh box (length, width, height)
ANKLE = 0.035  #: m, ankle axis above the foot's bottom face


def box_stl(size, centre=(0.0, 0.0, 0.0)) -> bytes:
    """A binary STL of the box ``size`` (m) centred on ``centre``: 12 triangles."""
    h = np.asarray(size, dtype=float) / 2
    c = np.asarray(centre, dtype=float)
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * h + c
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
             (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]  # fmt: skip
    out = bytearray(b"\0" * 80 + struct.pack("<I", len(faces)))
    for f in faces:
        out += struct.pack("<3f", 0.0, 0.0, 0.0)
        for i in f:
            out += struct.pack("<3f", *v[i])
        out += b"\0\0"
    return bytes(out)


#: Z-up coordinates → a Collada file's own (the inverse of the spec's turn to Z up)
_FROM_Z = {
    "Z_UP": np.eye(3),
    "Y_UP": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
    "X_UP": np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]),
}


def box_dae(size, centre=(0.0, 0.0, 0.0), up: str = "Z_UP") -> str:
    """A Collada file of the box ``size`` (m) centred on ``centre`` (Z-up coordinates), its
    vertices written in the coordinates of the up axis ``up`` (so that a reader that applies
    ``<up_axis>`` gets the box back, one that ignores it gets it turned)."""
    h = np.asarray(size, dtype=float) / 2
    c = np.asarray(centre, dtype=float)
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * h + c
    v = v @ _FROM_Z[up].T
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
             (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]  # fmt: skip
    pos = " ".join(f"{x:.9g}" for x in v.ravel())
    idx = " ".join(str(i) for f in faces for i in f)
    xyz = "".join(f'<param name="{a}" type="float"/>' for a in "XYZ")
    return f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<asset><unit name="meter" meter="1"/><up_axis>{up}</up_axis></asset>
<library_geometries><geometry id="g" name="g"><mesh>
<source id="p"><float_array id="pa" count="{v.size}">{pos}</float_array>
<technique_common><accessor source="#pa" count="{len(v)}" stride="3">{xyz}</accessor>
</technique_common></source>
<vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
<triangles count="{len(faces)}"><input semantic="VERTEX" source="#v" offset="0"/><p>{idx}</p>
</triangles></mesh></geometry></library_geometries>
<library_visual_scenes><visual_scene id="s"><node id="n" name="n"><instance_geometry url="#g"/>
</node></visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
"""


def _inertial(m: float, c=(0.0, 0.0, 0.0)) -> str:
    i = 0.001 * m
    inertia = f'<inertia ixx="{i}" iyy="{i}" izz="{i}" ixy="0" ixz="0" iyz="0"/>'
    return f'<inertial><origin xyz="{c[0]} {c[1]} {c[2]}"/><mass value="{m}"/>{inertia}</inertial>'


def write_mesh_robot(folder: Path, up: str | None = None, package: str | None = None) -> Path:
    """The URDF (and its meshes) in ``folder``; returns the URDF's path. ``up``: the meshes as
    Collada files with this up axis (``box_dae``) instead of STL; ``package``: ``folder`` is
    the ROS package of that name (a ``package.xml``, the URDF in ``urdf/``) and the meshes are
    named ``package://{package}/meshes/…``."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "meshes").mkdir(exist_ok=True)
    ext = "stl" if up is None else "dae"
    where = "meshes" if package is None else f"package://{package}/meshes"
    meshes = {
        "pelvis": ((0.08, 0.12, 0.05), (0, 0, 0)),
        "thigh": ((0.04, 0.04, 0.09), (0, 0, -0.06)),
        "shank": ((0.04, 0.04, 0.09), (0, 0, -0.06)),
        "foot": (FOOT, (0.01, 0, -ANKLE + FOOT[2] / 2)),
        "torso": ((0.08, 0.12, 0.12), (0, 0, 0.08)),
        "arm": ((0.03, 0.03, 0.12), (0, 0, -0.07)),
    }
    for name, (size, centre) in meshes.items():
        if up is None:
            (folder / "meshes" / f"{name}.stl").write_bytes(box_stl(size, centre))
        else:
            (folder / "meshes" / f"{name}.dae").write_text(box_dae(size, centre, up))

    def link(name, mesh, m, c=(0.0, 0.0, 0.0)):
        col = f'<collision><geometry><mesh filename="{where}/{mesh}.{ext}"/></geometry></collision>'
        return f'<link name="{name}">{_inertial(m, c)}{col}</link>'

    def joint(name, parent, child, xyz, axis, lo, hi, kind="revolute"):
        lim = "" if lo is None else f'<limit lower="{lo}" upper="{hi}" effort="5" velocity="5"/>'
        ends = f'<parent link="{parent}"/><child link="{child}"/>'
        where = f'<origin xyz="{xyz}"/><axis xyz="{axis}"/>'
        return f'<joint name="{name}" type="{kind}">{ends}{where}{lim}</joint>'

    parts = [link("pelvis", "pelvis", 0.6)]
    for s, y in (("r", -0.035), ("l", 0.035)):
        parts += [
            f'<link name="{s}_hip">{_inertial(0.05)}</link>',
            joint(f"{s}_hip_roll", "pelvis", f"{s}_hip", f"0 {y} -0.03", "1 0 0", -0.5, 0.5),
            link(f"{s}_thigh", "thigh", 0.3, (0, 0, -0.06)),
            joint(f"{s}_hip_pitch", f"{s}_hip", f"{s}_thigh", "0 0 0", "0 1 0", -1.2, 0.6),
            link(f"{s}_shank", "shank", 0.25, (0, 0, -0.06)),
            joint(f"{s}_knee", f"{s}_thigh", f"{s}_shank", "0 0 -0.12", "0 1 0", 0.0, 1.8),
            f'<link name="{s}_ankle">{_inertial(0.05)}</link>',
            joint(
                f"{s}_ankle_pitch", f"{s}_shank", f"{s}_ankle", "0 0 -0.12", "0 1 0", -0.8, 0.8
            ),  # fmt: skip
            link(f"{s}_foot", "foot", 0.15, (0.01, 0, -0.02)),
            joint(f"{s}_ankle_roll", f"{s}_ankle", f"{s}_foot", "0 0 0", "1 0 0", -0.5, 0.5),
            f'<link name="{s}_sole"/>',
            joint(
                f"{s}_sole_fixed",
                f"{s}_foot",
                f"{s}_sole",
                f"0.01 0 {-ANKLE}",
                "0 0 1",
                None,
                None,
                "fixed",
            ),  # fmt: skip
        ]
    parts += [link("torso", "torso", 0.9, (0, 0, 0.08)),
              joint("waist", "pelvis", "torso", "0 0 0.03", "0 0 1", -0.8, 0.8)]  # fmt: skip
    for s, y in (("r", -0.075), ("l", 0.075)):
        parts += [
            link(f"{s}_arm", "arm", 0.15, (0, 0, -0.07)),
            joint(f"{s}_shoulder", "torso", f"{s}_arm", f"0 {y} 0.13", "0 1 0", -2, 2),
        ]
    path = folder / "mesh_robot.urdf"
    if package is not None:
        (folder / "package.xml").write_text(f"<package><name>{package}</name></package>\n")
        (folder / "urdf").mkdir(exist_ok=True)
        path = folder / "urdf" / "mesh_robot.urdf"
    body = "".join(parts)
    path.write_text(f'<?xml version="1.0"?>\n<robot name="mesh_robot">{body}</robot>\n')
    return path
