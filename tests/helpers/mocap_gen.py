"""Test helper: a motion-capture-style MJCF humanoid (as dm_control's CMU humanoid is built),
written from scratch with the traits that make such models hard to plan for:

- every limb is capsules that overlap their neighbours' at the joints, and hips and shoulders are
  single bodies with three (two) hinges, which sescid splits into massless bodies in between;
- the zero pose lifts the left leg (hip flexed 70°, knee 90°): the free foot is nowhere near
  the floor, so it is found as the supporting leg's mirror;
- each foot is three parallel capsules (a narrow contact strip) with a ``<side>foot_touch`` site
  a few mm above their bottoms, and a toes body on a hinge whose spheres reach below the sole
  plane at the zero pose;
- a 1.6 m, 61 kg body on those feet (a tall robot on a narrow sole);
- the top body is turned by its ``euler`` (the model is y-up inside it, as the CMU file is).
"""

from __future__ import annotations

import math

FOOT_RADIUS = 0.02  #: m, each foot capsule
TOUCH_ABOVE = 0.005  #: m, the touch site above the capsules' bottoms


def _capsule(a, b, r: float, extra: str = "") -> str:
    f = " ".join(f"{v:.6g}" for v in (*a, *b))
    return f'<geom type="capsule" fromto="{f}" size="{r:g}" {extra}/>'


def _leg(side: str, x: float, lifted: bool) -> str:
    """One leg in the y-up frame of the top body: hip (3 hinges), thigh, shin, foot, toes."""
    hip = "0.819152 -0.573576 0 0" if lifted else "1 0 0 0"  # 70° about −x: the thigh raised
    knee = "0.707107 0.707107 0 0" if lifted else "1 0 0 0"  # 90° back at the knee
    r = FOOT_RADIUS
    feet = "".join(
        _capsule((dx, -0.04, 0.03), (dx, -0.04, -0.11), r) for dx in (-0.022, 0.0, 0.022)
    )
    touch = -0.04 - r + TOUCH_ABOVE
    return f"""
      <body name="{side}femur" pos="{x:g} -0.08 0" quat="{hip}">
        <joint name="{side}femurrz" axis="0 0 1" range="-60 70"/>
        <joint name="{side}femurry" axis="0 1 0" range="-70 70"/>
        <joint name="{side}femurrx" axis="1 0 0" range="-110 20"/>
        <inertial pos="0 -0.2 0" mass="7.5" diaginertia="0.12 0.02 0.12"/>
        {_capsule((0, 0.02, 0), (0, -0.42, 0), 0.06)}
        <body name="{side}tibia" pos="0 -0.42 0" quat="{knee}">
          <joint name="{side}tibiarx" axis="1 0 0" range="0 150"/>
          <inertial pos="0 -0.19 0" mass="3.5" diaginertia="0.05 0.006 0.05"/>
          {_capsule((0, 0.03, 0), (0, -0.4, 0), 0.045)}
          <body name="{side}foot" pos="0 -0.41 0">
            <joint name="{side}footrz" axis="0 0 1" range="-30 30"/>
            <joint name="{side}footrx" axis="1 0 0" range="-45 45"/>
            <inertial pos="0 -0.03 -0.03" mass="1.0" diaginertia="0.004 0.004 0.001"/>
            {feet}
            <site name="{side}foot_touch" pos="0 {touch:g} -0.04" zaxis="0 1 0"
                  type="box" size=".04 .08 .01"/>
            <body name="{side}toes" pos="0 -0.04 -0.13">
              <joint name="{side}toesrx" axis="1 0 0" range="-60 20"/>
              <inertial pos="0 0 -0.02" mass="0.15" diaginertia="0.0002 0.0002 0.0002"/>
              <geom type="sphere" pos="-0.02 -0.006 -0.02" size="0.02"/>
              <geom type="sphere" pos="0.02 -0.006 -0.02" size="0.02"/>
            </body>
          </body>
        </body>
      </body>"""


def _arm(side: str, x: float) -> str:
    s = 1.0 if x > 0 else -1.0
    return f"""
        <body name="{side}humerus" pos="{x:g} 0.42 0">
          <joint name="{side}humerusrz" axis="0 0 1" range="-90 90"/>
          <joint name="{side}humerusry" axis="0 1 0" range="-90 90"/>
          <inertial pos="{0.14 * s:g} 0 0" mass="2.0" diaginertia="0.003 0.02 0.02"/>
          {_capsule((0, 0, 0), (0.28 * s, 0, 0), 0.04)}
          <body name="{side}radius" pos="{0.28 * s:g} 0 0">
            <joint name="{side}radiusrx" axis="0 1 0" range="-150 0"/>
            <inertial pos="{0.13 * s:g} 0 0" mass="1.2" diaginertia="0.002 0.01 0.01"/>
            {_capsule((0, 0, 0), (0.26 * s, 0, 0), 0.035)}
          </body>
        </body>"""


def mocap_mjcf() -> str:
    """The model's MJCF text (module docstring)."""
    arms = _arm("l", 0.18) + _arm("r", -0.18)
    return f"""<mujoco model="mocap_humanoid">
  <compiler angle="degree"/>
  <default>
    <joint limited="true" damping="1"/>
    <geom contype="1" conaffinity="1"/>
  </default>
  <worldbody>
    <body name="root" pos="0 0 1" euler="90 0 0">
      <freejoint name="root"/>
      <inertial pos="0 0.05 0" mass="12" diaginertia="0.1 0.1 0.1"/>
      {_capsule((-0.09, 0, 0), (0.09, 0, 0), 0.09)}
      {_leg("l", 0.1, True)}
      {_leg("r", -0.1, False)}
      <body name="lowerback" pos="0 0.1 0">
        <joint name="lowerbackrz" axis="0 0 1" range="-30 30"/>
        <joint name="lowerbackrx" axis="1 0 0" range="-20 40"/>
        <inertial pos="0 0.25 0" mass="14" diaginertia="0.3 0.1 0.3"/>
        {_capsule((0, 0, 0), (0, 0.4, 0), 0.11)}
        {arms}
        <body name="head" pos="0 0.5 0">
          <joint name="neckrx" axis="1 0 0" range="-40 40"/>
          <inertial pos="0 0.1 0" mass="4.5" diaginertia="0.02 0.02 0.02"/>
          {_capsule((0, -0.06, 0), (0, 0.12, 0), 0.09)}
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


#: the right foot's touch site: a level support frame 5 mm above the foot's capsule bottoms
SUPPORT = "rfoot_touch"
_ = math  # the euler angles above are in degrees (compiler)
