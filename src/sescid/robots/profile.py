"""What is specific to one robot, as data: sole, free sole, stability box, servo encoding,
sensor layout, the paper's angle convention. Algorithms read these fields; none asks which
robot it is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from sescid.errors import DataError, check_choice

#: how pose candidates are drawn: plain uniform draws within the limits, or draws moved toward a
#: stable CoP by a few steps of the CoM Jacobian (``planning.adjust``)
PoseSampler = Literal["uniform", "adjusted"]


@dataclass(frozen=True)
class ServoEncoding:
    """A position servo's encoder: ``ticks = zero_tick + angle · ticks_per_turn / 2π``."""

    name: str
    ticks_per_turn: int
    zero_tick: int
    max_tick: int

    def to_ticks(self, q: ArrayLike) -> np.ndarray:
        """Servo angles (n, nq) [rad] → integer ticks; DataError outside 0..max_tick."""
        qq = np.asarray(q, dtype=float)
        ticks = np.rint(self.zero_tick + qq * self.ticks_per_turn / (2 * math.pi))
        bad = np.argwhere((ticks < 0) | (ticks > self.max_tick))
        if bad.size:
            i, j = bad[0][0], bad[0][-1]
            raise DataError(
                f"pose {i}, joint {j}: {qq[tuple(bad[0])]:g} rad is outside the {self.name} "
                f"range 0–{self.max_tick}"
            )
        return ticks.astype(np.int64)

    def to_rad(self, ticks: ArrayLike) -> np.ndarray:
        """Ticks → servo angles [rad] (float)."""
        return (np.asarray(ticks, dtype=float) - self.zero_tick) * (
            2 * math.pi / self.ticks_per_turn
        )


#: Dynamixel MX-28 (4096 counts per turn, 2048 = 0; darwinop Framework MX28.cpp)
MX28 = ServoEncoding("Dynamixel MX-28", 4096, 2048, 4095)


def mx28_kp(p_gain: float = 32, stall_torque: float = 2.5) -> float:
    """Stiffness [N·m/rad] of an MX-28 (protocol 1.0) position loop at P gain ``p_gain``.

    The firmware's gain P/8 gives PWM counts (of 1023) per encoder tick (4096 per turn) of
    error; full PWM at rest gives the stall torque (2.5 N·m at 12 V).
    """
    return p_gain / 8 * (4096 / (2 * math.pi)) / 1023 * stall_torque


@dataclass(frozen=True)
class ServoGains:
    """Position-servo model for a physics bench: stiffness, damping, rotor inertia."""

    kp: float  #: N·m/rad
    kv: float  #: N·m·s/rad
    armature: float  #: kg·m²


@dataclass(frozen=True)
class RobotProfile:
    """Robot facts the algorithms need beyond the model file; None where unknown."""

    name: str
    model_file: Path | None = None  #: embedded model file
    support: str | None = None  #: default support frame
    sole_size: tuple[float, float] | None = None  #: (length x, width y) of a sole, m
    free_sole: dict[str, str] = field(default_factory=dict)  #: support sole → the other sole
    cop_box: float | None = None  #: default half-width of the CoP stability box, m
    servo: ServoEncoding | None = None
    servo_gains: ServoGains | None = None
    sensors_file: Path | None = None  #: foot-sensor layout (sescid-fsr/1 JSON)
    paper_limits_file: Path | None = None  #: paper angle convention and Table 2 limits (CSV)
    body_table_file: Path | None = None  #: the paper's Table 1: index → body (CSV)
    #: pose candidates: "adjusted" (draws moved toward a stable CoP by a few steps of the CoM
    #: Jacobian, ``planning.adjust``) or "uniform" (plain uniform draws, the paper's study;
    #: the adjusted draws take over when uniform ones are too rarely accepted)
    pose_sampler: PoseSampler = "adjusted"
    #: link carrying the IMU whose roll/pitch (``imu_roll``, ``imu_pitch``) give the gravity
    #: direction; None: unknown (``--imu-link`` names it)
    imu_link: str | None = None
    #: N/m, vertical stiffness of each contact of a sole (a pad); None: unknown
    pad_stiffness: float | None = None
    #: rad, a joint's play around its commanded angle (uniform in ±); None: unknown
    servo_backlash: float | None = None
    #: support frame → direction (3,) of the line the robot balances on there (a wheel axle,
    #: an edge), in that frame: a support named here is a line contact, not a sole
    support_lines: dict[str, tuple[float, float, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_choice("pose_sampler", self.pose_sampler, PoseSampler)


def generic_profile(name: str) -> RobotProfile:
    """The profile of a model file sescid knows nothing else about."""
    return RobotProfile(name=name)
