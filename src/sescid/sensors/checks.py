"""Physical plausibility of numbers a user gives about the robot (the one home of the rules).

A weighed total mass far from the model's is a typo or a unit slip (grams, pounds), not a
measurement: it is refused in one line naming the option. (The checks of logged data — a CoP
within its sole, a positive normal force, torques in N·m, pad offsets — sit beside their
readers: ``sensors.raw``, ``sensors.torque``, ``sensors.pads``.)
"""

from __future__ import annotations

import math

from sescid.errors import OptionError

#: a weighed mass must lie within this factor range of the model's mass
TOTAL_MASS_RANGE = (0.5, 2.0)


def check_total_mass(robot, mass: float, name: str = "total_mass") -> None:
    """OptionError unless ``mass`` [kg] is finite and within ``TOTAL_MASS_RANGE`` × the model's."""
    model = robot.total_mass
    lo, hi = TOTAL_MASS_RANGE
    if not (math.isfinite(mass) and lo * model <= mass <= hi * model):
        raise OptionError(
            name,
            f"{mass:g} kg is not this robot's mass: the model weighs {model:.4g} kg and a "
            f"weighed mass lies within {lo:g}–{hi:g}× of it (kg, not g or lb)",
        )
