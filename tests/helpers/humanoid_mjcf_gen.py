"""A small MJCF humanoid split over files, as public MuJoCo models are: the main file includes
its assets and its robot (``<include>``), meshes live in a ``meshdir`` folder, and the only
collision geometry is the feet, colliding with the floor through ``<contact><pair>``."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

#: a tetrahedron (OBJ), the head's visual mesh
TETRA_OBJ = "v 0 0 0\nv 0.08 0 0\nv 0 0.08 0\nv 0 0 0.08\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"

_LEG = """
      <body name="{s}_thigh" pos="0 {y} -0.05">
        <joint name="{s}_hip_pitch" axis="0 1 0" range="-1.5 1.5"/>
        <joint name="{s}_hip_roll" axis="1 0 0" range="-0.6 0.6" pos="0 0 -0.01"/>
        <inertial pos="0 0 -0.1" mass="{mt}" diaginertia="0.004 0.004 0.001"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.03" contype="0" conaffinity="0"/>
        <body name="{s}_shin" pos="0 0 -0.2">
          <joint name="{s}_knee" axis="0 1 0" range="0 2.2"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.025" density="1100"
                contype="0" conaffinity="0"/>
          <body name="{s}_foot" pos="0 0 -0.22">
            <joint name="{s}_ankle_pitch" axis="0 1 0" range="-1 1"/>
            <joint name="{s}_ankle_roll" axis="1 0 0" range="-0.5 0.5"/>
            <inertial pos="0.02 0 -0.02" mass="0.25"
                      fullinertia="0.0003 0.0006 0.0007 0.00001 0 0"/>
            <geom name="{s}_foot_col" type="box" size="0.07 0.035 0.01" pos="0.02 0 -0.03"
                  contype="0" conaffinity="0"/>
{sole}{toes}
          </body>
        </body>
      </body>"""

#: toes on a hinge at the front of each foot: a sphere whose bottom lies ``TOE_DIP`` below the
#: sole at the zero pose (as the CMU humanoid's toes lie below its foot's touch site)
TOE_DIP = 0.005
_TOES = """
            <body name="{s}_toes" pos="0.09 0 -0.03">
              <joint name="{s}_toe" axis="0 1 0" range="-0.8 0.8"/>
              <inertial pos="0.015 0 0" mass="0.03" diaginertia="2e-6 2e-6 2e-6"/>
              <geom type="sphere" size="0.015" pos="0.015 0 0" contype="0" conaffinity="0"/>
            </body>"""

_SOLE = """
            <site name="{s}_sole" pos="0.02 0 -0.04"/>"""
#: sites at the four bottom corners of each foot box (as MuJoCo Playground's Apollo has)
_CORNERS = "".join(
    f"""
            <site name="{{s}}_foot_{n}" pos="{0.02 + 0.07 * x:g} {0.035 * y:g} -0.04"/>"""
    for n, x, y in (("fl", 1, 1), ("fr", 1, -1), ("bl", -1, 1), ("br", -1, -1))
)

_ARM = """
      <body name="{s}_upper_arm" pos="0 {y} 0.25">
        <joint name="{s}_shoulder" axis="0 1 0" range="-2 2"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.18" size="0.02" density="900"
              contype="0" conaffinity="0"/>
        <body name="{s}_forearm" pos="0 0 -0.18">
          <joint name="{s}_elbow" axis="0 1 0" range="-2 0"/>
          <inertial pos="0 0 -0.08" mass="0.2" diaginertia="0.0005 0.0005 0.0001"/>
        </body>
      </body>"""

MAIN = """<?xml version="1.0"?>
<!-- a generated humanoid: main file -->
<mujoco model="gen_humanoid">
  <compiler angle="radian" meshdir="assets"/>
  <include file="parts/assets.xml"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <include file="parts/robot.xml"/>
  </worldbody>
  <contact>
    <pair geom1="floor" geom2="r_foot_col"/>
    <pair geom1="floor" geom2="l_foot_col"/>
  </contact>
</mujoco>
"""

ASSETS = """<mujoco>
  <asset>
    <mesh name="head_mesh" file="tetra.obj"/>
    <texture name="skin" type="2d" file="textures/skin.png"/>
    <material name="skin" texture="skin"/>
  </asset>
</mujoco>
"""


def png_2x2() -> bytes:
    """A 2×2 RGB PNG (the head's texture; no texturedir: relative to the main file)."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    rows = b"".join(b"\x00" + bytes([200, 120, 90] * 2) for _ in range(2))
    header = struct.pack(">IIBBBBB", 2, 2, 8, 2, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(rows))
        + chunk(b"IEND", b"")
    )


def robot_xml(toes: bool = False, sole: bool = True, corners: bool = False) -> str:
    sites = (_SOLE if sole else "") + (_CORNERS if corners else "")
    legs = "".join(
        _LEG.format(s=s, y=y, mt=mt, toes=_TOES.format(s=s) if toes else "", sole=sites.format(s=s))
        for s, y, mt in (("r", -0.08, 0.9), ("l", 0.08, 0.95))
    )
    arms = "".join(_ARM.format(s=s, y=y) for s, y in (("r", -0.15), ("l", 0.15)))
    return f"""<mujoco>
  <!-- the robot, included by the main file -->
    <body name="pelvis" pos="0 0 0.7">
      <freejoint/>
      <inertial pos="0 0 0.02" mass="2.5" diaginertia="0.02 0.015 0.02"/>
      <geom type="box" size="0.06 0.1 0.05" contype="0" conaffinity="0"/>{legs}
      <body name="torso" pos="0 0 0.08">
        <joint name="waist" axis="0 0 1" range="-1 1"/>
        <inertial pos="0 0 0.15" mass="4.0" diaginertia="0.06 0.05 0.03"/>{arms}
        <body name="head" pos="0 0 0.32">
          <joint name="neck" axis="0 1 0" range="-0.5 0.5"/>
          <geom type="mesh" mesh="head_mesh" density="2000" material="skin"
                contype="0" conaffinity="0"/>
        </body>
      </body>
    </body>
</mujoco>
"""


def write_humanoid(
    folder: Path, toes: bool = False, sole: bool = True, corners: bool = False
) -> Path:
    """Write the humanoid's files under ``folder`` (``toes``: with toes, ``_TOES``; ``sole``:
    with the sole sites; ``corners``: with sole-corner sites, ``_CORNERS``); the main file's
    path."""
    (folder / "parts").mkdir(parents=True)
    (folder / "assets").mkdir()
    (folder / "textures").mkdir()
    (folder / "textures" / "skin.png").write_bytes(png_2x2())
    (folder / "assets" / "tetra.obj").write_text(TETRA_OBJ)
    (folder / "parts" / "assets.xml").write_text(ASSETS)
    (folder / "parts" / "robot.xml").write_text(robot_xml(toes, sole, corners))
    main = folder / "humanoid.xml"
    main.write_text(MAIN)
    return main
