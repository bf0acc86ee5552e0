"""Test helper: a synthetic MJCF humanoid whose collision geometry is only the feet (MuJoCo
Playground style), with names that follow no left/right convention.

``humanoid_mjcf`` writes a 1.1 m, ~30 kg humanoid: pelvis (free joint), two 6-joint legs
(hip yaw/roll/pitch, knee, ankle pitch/roll), a torso on a waist joint with a head, two 3-joint
arms. Every limb carries visual capsules (contype = conaffinity = 0); only the feet carry
collision boxes. Sites: ``<right>_sole`` at the centre of the right foot's bottom face (z up),
``<right>_heel`` at the back of the right foot with its z axis pointing backwards (not level),
and ``<left>_sole``. ``foot`` sets the foot box, ``torso_forward`` moves the torso's CoM
forward (m), ``hip`` and ``roll`` set the hips' spacing and the roll joints' range: wide hips
with little roll (or a tiny foot) make uniform draws almost never stable.
"""

from __future__ import annotations

from dataclasses import dataclass

#: body-name prefixes of the two sides (deliberately unlike r_/l_, right/left)
RIGHT, LEFT = "legA", "legB"
ANKLE = 0.06  #: m, ankle axis above the foot's bottom face
THIGH = SHANK = 0.4  #: m


@dataclass(frozen=True)
class HumanoidSpec:
    """What varies between generated humanoids."""

    foot: tuple[float, float, float] = (0.2, 0.09, 0.03)  #: m, foot box (length, width, height)
    torso_forward: float = 0.0  #: m, torso CoM ahead of the waist axis
    torso_mass: float = 12.0  #: kg
    arm_mass: float = 1.5  #: kg per arm segment
    hip: float = 0.09  #: m, each hip joint beside the pelvis centre
    roll: float = 0.4  #: rad, ankle roll range ± (hip roll: this inward, 1.5 × outward)


def _f(*v: float) -> str:
    return " ".join(f"{x:.6g}" for x in v)


def _inertial(mass: float, pos=(0.0, 0.0, 0.0)) -> str:
    i = 0.02 * mass * 0.1
    return f'<inertial pos="{_f(*pos)}" mass="{mass:g}" diaginertia="{_f(i, i, i)}"/>'


def _vis(a, b, r: float) -> str:
    return (
        f'<geom type="capsule" fromto="{_f(*a, *b)}" size="{r:g}" contype="0" '
        'conaffinity="0" group="2"/>'
    )


def _joint(name: str, axis: str, lo: float, hi: float) -> str:
    return f'<joint name="{name}" axis="{axis}" range="{lo:g} {hi:g}"/>'


def _leg(side: str, y: float, spec: HumanoidSpec) -> str:
    fl, fw, fh = spec.foot
    s = 1.0 if y > 0 else -1.0
    foot = (
        f'<geom name="{side}_foot_box" type="box" size="{_f(fl / 2, fw / 2, fh / 2)}" '
        f'pos="{_f(0.03, 0, -ANKLE + fh / 2)}"/>'
    )
    sites = (
        f'<site name="{side}_sole" pos="{_f(0.03, 0, -ANKLE)}"/>'
        f'<site name="{side}_heel" pos="{_f(0.03 - fl / 2, 0, -ANKLE + fh / 2)}" '
        'zaxis="-1 0 0"/>'
    )
    ankle_roll = _joint(f"{side}_ankle_roll", "1 0 0", -spec.roll, spec.roll)
    return f"""
      <body name="{side}_hip" pos="0 {y:g} -0.05">
        {_inertial(1.0)}{_joint(f"{side}_hip_yaw", "0 0 1", -0.5, 0.5)}
        <body name="{side}_hip2">
          {_inertial(1.0)}{
        _joint(
            f"{side}_hip_roll",
            "1 0 0",
            -spec.roll if s > 0 else -1.5 * spec.roll,
            1.5 * spec.roll if s > 0 else spec.roll,
        )
    }
          <body name="{side}_thigh">
            {_inertial(3.0, (0, 0, -THIGH / 2))}{_joint(f"{side}_hip_pitch", "0 1 0", -1.6, 0.6)}
            {_vis((0, 0, -0.05), (0, 0, -THIGH + 0.05), 0.05)}
            <body name="{side}_shank" pos="0 0 {-THIGH:g}">
              {_inertial(2.0, (0, 0, -SHANK / 2))}{_joint(f"{side}_knee", "0 1 0", 0.0, 2.2)}
              {_vis((0, 0, -0.05), (0, 0, -SHANK + 0.05), 0.04)}
              <body name="{side}_ankle" pos="0 0 {-SHANK:g}">
                {_inertial(0.5)}{_joint(f"{side}_ankle_pitch", "0 1 0", -0.8, 0.8)}
                <body name="{side}_foot">
                  {_inertial(1.0, (0.03, 0, -0.04))}{ankle_roll}
                  {foot}{sites}
                </body>
              </body>
            </body>
          </body>
        </body>
      </body>"""


def _arm(side: str, y: float, spec: HumanoidSpec) -> str:
    s = 1.0 if y > 0 else -1.0
    m = spec.arm_mass
    return f"""
        <body name="{side}_shoulder" pos="0 {y:g} 0.35">
          {_inertial(0.5)}{_joint(f"{side}_sh_pitch", "0 1 0", -2.5, 1.0)}
          <body name="{side}_upperarm">
            {_inertial(m, (0, 0, -0.12))}{
        _joint(f"{side}_sh_roll", "1 0 0", min(-0.2 * s, 1.4 * s), max(-0.2 * s, 1.4 * s))
    }
            {_vis((0, 0, -0.03), (0, 0, -0.22), 0.035)}
            <body name="{side}_forearm" pos="0 0 -0.25">
              {_inertial(m * 0.8, (0, 0, -0.12))}{_joint(f"{side}_elbow", "0 1 0", -2.0, 0.0)}
              {_vis((0, 0, -0.03), (0, 0, -0.22), 0.03)}
            </body>
          </body>
        </body>"""


def humanoid_mjcf(spec: HumanoidSpec | None = None) -> str:
    """MJCF text of the humanoid (see the module docstring)."""
    spec = spec or HumanoidSpec()
    hip = spec.hip
    z0 = THIGH + SHANK + ANKLE + 0.05
    return f"""<mujoco model="synthetic_humanoid">
  <compiler angle="radian"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="pelvis" pos="0 0 {z0:g}">
      <freejoint/>
      {_inertial(4.0)}
      <geom type="box" size="0.08 0.12 0.06" contype="0" conaffinity="0" group="2"/>
      {_leg(RIGHT, -hip, spec)}
      {_leg(LEFT, hip, spec)}
      <body name="torso" pos="0 0 0.08">
        {_inertial(spec.torso_mass, (spec.torso_forward, 0, 0.2))}
        {_joint("waist", "0 0 1", -0.8, 0.8)}
        <geom type="box" size="0.08 0.13 0.18" pos="0 0 0.2" contype="0" conaffinity="0"/>
        <body name="head" pos="0 0 0.42">
          {_inertial(2.0, (0, 0, 0.08))}{_joint("neck", "0 1 0", -0.5, 0.5)}
          <geom type="sphere" size="0.09" pos="0 0 0.09" contype="0" conaffinity="0"/>
        </body>
        {_arm("armA", -0.17, spec)}
        {_arm("armB", 0.17, spec)}
      </body>
    </body>
  </worldbody>
</mujoco>
"""


#: uniform draws (almost) never stable: an 80 × 40 mm foot, wide hips with little roll, a 35 kg
#: torso 0.3 m ahead of the waist
H1_STYLE = HumanoidSpec(
    foot=(0.08, 0.04, 0.02), torso_forward=0.3, torso_mass=35.0, hip=0.15, roll=0.3
)
#: cannot stand on one foot: wide hips and almost no hip or ankle roll
STUCK = HumanoidSpec(hip=0.25, roll=0.02)
#: a 33 kg humanoid on a narrow sole (120 × 36 mm), its CoM 0.66 m up: contacts that sink a fixed
#: 0.5 mm under its weight would let the sole tilt as far as the CoM leans (no pose kept)
NARROW_33KG = HumanoidSpec(foot=(0.12, 0.036, 0.03), torso_mass=7.0, arm_mass=0.6)
