"""The "real" robot of a bench: the model plus what its CAD lacks, and its sensors' errors.

The real robot carries **unmodelled mass** (screws, cables, boards: by default 7 % of the
model's mass spread over several bodies at offsets of a few centimetres), its joints have
**backlash** (each pose's actual angle differs from the commanded one by δ ~ U(−b, b), b = 1° by
default), its foot pads have a **bias** and a **gain error** per pad and **noise**, and its joint
torque sensors (``TorqueConfig``; none by default) read

    τ_measured = gain_j · τ_j + offset_j + approach · f_j + noise,

with a per-joint offset, an optional gain error, a static-friction band ±f_j (a held pose sits
at the edge of the band on the side it was approached from: ``approach`` +1 from below, −1 from
above, per pose) and noise per sample. ``draw_errors`` draws the sensor errors once per bench
run, each kind from its own random stream, so enabling one leaves every other draw unchanged.

``mount``: ``"stand"`` (on the support foot, which must carry the sensor board; poses that
would tip are not measured) or ``"gantry"`` (the support link, e.g. the pelvis, is held level in
a fixture: no balance, the robot hangs free, the feet carry no load) or ``"line"`` (the robot
balances on its support line, ``Robot.line``: a wheel axle or an edge; each pose at the tilt
that puts the true CoM above the line, read by an IMU).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from sescid.base import check_ranges, option
from sescid.errors import DataError, check_choice
from sescid.planning import Mount
from sescid.robot import Robot
from sescid.sensors.pads import SensorConfig
from sescid.sesc import sesc_vectors

#: random streams (seed, k) of the sensor errors and the approach sides
PAD_GAIN_STREAM = 11
TORQUE_STREAM = 13
APPROACH_STREAM = 17
#: the start of the error a bench raises when every pose fails (a caller may name its file)
NO_POSE_MEASURED = "no pose can be measured"
#: the side each pose is approached from: random, always from below (+1), from above (−1), or
#: alternating
Approach = Literal["random", "up", "down", "alternate"]
#: what the bench logs of a pad foot: the four forces, the board's centroid registers, or both
Registers = Literal["forces", "centroid", "both"]
#: the bench that makes a raw log: rigid statics, or the MuJoCo physics bench
Engine = Literal["kinematic", "mujoco"]
#: how the bench holds the robot: a plan's mounts (``planning.Mount``), or balancing on a line
BenchMount = Literal[Mount, "line"]


@dataclass(frozen=True)
class ExtraMass:
    """Unmodelled mass on one body: its share of the extra total and its offset (m, body frame)."""

    body: str
    share: float
    offset: tuple[float, float, float]


#: where a real OP2 carries mass its CAD model lacks (shares sum to 1)
DEFAULT_EXTRA = (
    ExtraMass("MP_BODY", 0.45, (-0.090, -0.040, 0.020)),  # cable bundle, sub-board at the back
    ExtraMass("MP_HEAD", 0.10, (-0.030, 0.000, 0.040)),  # camera cable, screws
    ExtraMass("MP_THIGH2_R", 0.08, (-0.030, -0.020, -0.030)),  # screws, cable loom
    ExtraMass("MP_THIGH2_L", 0.08, (-0.030, 0.020, -0.030)),
    ExtraMass("MP_ANKLE2_L", 0.12, (0.000, 0.010, -0.025)),  # the lifted foot's FSR board
    ExtraMass("MP_ANKLE2_R", 0.07, (0.000, -0.010, -0.025)),  # the support foot's FSR board
    ExtraMass("MP_ARM_HIGH_R", 0.05, (-0.015, -0.020, -0.030)),
    ExtraMass("MP_ARM_LOW_L", 0.05, (0.040, 0.010, 0.000)),
)


@dataclass(frozen=True)
class TorqueConfig:
    """Joint torque sensors of the real robot (N·m); ``joints`` () logs no torque."""

    joints: tuple[str, ...] | Literal["all"] = ()  #: measured joints, "all", or () for none
    noise: float = option(0.05, "Torque noise per sample [N·m].", low=0, flag="--torque-noise")
    offset: float = option(
        0.05, "Std of the per-joint torque offsets [N·m].", low=0, flag="--torque-offset"
    )
    gain: float = option(
        0.0, "Std of the per-joint torque gain errors (relative).", low=0, flag="--torque-gain"
    )
    friction: tuple[float, float] = option(
        (0.0, 0.0),
        "Static-friction band half-width f_j ~ U(LO, HI) per joint [N·m]: a held pose reads "
        "τ ± f_j on the side it came from.",
        low=0, metavar="LO HI",
    )  # fmt: skip
    approach: Approach = option(
        "random", "Side each pose is approached from (the approach column)."
    )

    def resolve(self, joint_names: list[str]) -> list[str]:
        """The measured joints in model order; DataError for a name the model lacks."""
        if self.joints == "all":
            if not joint_names:
                raise DataError("torque joints 'all': the model has no joints to measure")
            return list(joint_names)
        if isinstance(self.joints, str):
            raise DataError(f"torque joints: expected 'all' or joint names, got {self.joints!r}")
        unknown = [j for j in self.joints if j not in joint_names]
        if unknown:
            raise DataError(f"torque joints: no joint '{unknown[0]}' in the model")
        return [j for j in joint_names if j in self.joints]

    def check(self) -> None:
        """OptionError for a setting outside its range."""
        check_ranges(self)
        lo, hi = self.friction
        if lo > hi:
            raise DataError(f"friction band: lower {lo:g} above upper {hi:g} N·m")
        check_choice("approach", self.approach, Approach)


@dataclass
class ExperimentConfig:
    """How the virtual real robot differs from the model (SI units, angles in degrees)."""

    extra_mass_fraction: float = option(
        0.07, "Unmodelled mass as a fraction of the model's mass.", low=0, flag="--extra-mass"
    )
    #: where the unmodelled mass sits (None: ``DEFAULT_EXTRA`` on a robot with those bodies,
    #: else ``generic_extra``)
    extra: tuple[ExtraMass, ...] | None = None
    #: actual − commanded angle ~ U(−b, b) per pose and joint
    backlash_deg: float = option(1.0, "Joint play ±b [degrees].", low=0)
    readback_seen: float = 0.5  #: part of that offset the joint encoder reports
    readback_jitter_ticks: float = option(0.3, "Read-back noise per sample [ticks].", low=0)
    fsr_noise: float = option(1.5, "Per-sensor noise std [N].", low=0)
    fsr_bias: float = option(0.1, "Per-sensor bias std [N].", low=0)
    #: a pad reads F / g + bias, g ~ N(1, fsr_gain²)
    fsr_gain: float = option(
        0.0, "Per-pad gain error std (relative): a pad reads force / gain + bias.", low=0
    )
    #: kinematic bench: the split over all the feet's pads is the elastic one (least squares,
    #: as a rigid body on equal springs): statics fixes only the total force and its moments
    double_support: bool = option(
        False,
        "Both feet on the floor where the pose puts them there; the load splits over all "
        "their pads.",
    )
    registers: Registers = option("forces", "Log the four forces, the centroid registers, or both.")
    #: a sloped or soft floor: roll and pitch ~ N(0, tilt_deg²) per pose
    tilt_deg: float = option(
        0.0,
        "kinematic: the support stands tilted by a random roll and pitch of this standard "
        "deviation per pose [degrees]; the log gets grav_x, grav_y, grav_z.",
        low=0, high=30,
    )  # fmt: skip
    torque: TorqueConfig = field(default_factory=TorqueConfig)  #: joint torque sensors
    mount: BenchMount = option(
        "stand",
        "stand: on the support foot; gantry: the support link (--support pelvis) held level "
        "in a fixture, the robot hanging free (no balance; the feet carry nothing); line: "
        "balancing on its support line (--support axle --line y: a wheel axle, an edge), each "
        "pose at the tilt that balances it, read by an IMU (kinematic engine).",
    )
    imu_link: str | None = option(
        None,
        "line mount: the link carrying the IMU (default: the profile's, else the support frame).",
    )
    imu_noise_deg: float = option(
        0.5, "line mount: IMU roll/pitch noise per sample [degrees].", low=0, high=20
    )

    def check(self) -> None:
        """OptionError for a setting outside its range (the one check both benches use)."""
        check_ranges(self)
        check_choice("registers", self.registers, Registers)
        check_choice("mount", self.mount, BenchMount)
        if self.mount == "line" and self.double_support:
            raise DataError("a robot balancing on a line stands on no foot: no double support")
        if self.mount == "gantry" and self.double_support:
            raise DataError("a robot held in a gantry stands on no foot: no double support")
        self.torque.check()


def generic_extra(robot: Robot, n: int = 4) -> tuple[ExtraMass, ...]:
    """Unmodelled mass on the ``n`` heaviest bodies in proportion to their masses, 2 cm behind
    and 1 cm beside their frames' origins (cables and boards of a robot without a known list)."""
    order = np.argsort(-robot.masses, kind="stable")[:n]
    m = robot.masses[order]
    shares = m / m.sum() if m.sum() > 0 else np.full(len(order), 1.0 / len(order))
    return tuple(
        ExtraMass(robot.body_names[i], float(s), (-0.02, 0.01, 0.0))
        for i, s in zip(order, shares, strict=True)
    )


def default_rooting(robot: Robot):
    """The robot rooted where the default unmodelled masses are written: its profile's support
    (the OP2's right sole), else the model file's own root link. Every stance's bench carries
    them from there (``carried``), so every stance stands the same physical robot."""
    home = robot.profile.support or robot.model.model_root
    return robot.stance(home) if home else robot  # kept by the robot: loaded once


def extra_masses(robot: Robot, config: ExperimentConfig) -> tuple[ExtraMass, ...]:
    """The unmodelled masses of ``config`` on ``robot`` (``ExperimentConfig.extra``, offsets in
    ``robot``'s body frames); the defaults are those of ``default_rooting`` carried over."""
    if config.extra is not None:
        return config.extra
    home = default_rooting(robot)
    if all(e.body in home.body_names for e in DEFAULT_EXTRA):
        base = DEFAULT_EXTRA
    else:
        base = generic_extra(home)
    return base if home is robot else carried(home, robot, base)


def carried(reference: Robot, robot: Robot, extra: tuple[ExtraMass, ...]) -> tuple[ExtraMass, ...]:
    """Unmodelled masses with offsets in the body frames of ``reference`` carried into those of
    ``robot`` (the same model rooted elsewhere, ``Robot.at``) through each body's first link:
    the same physical masses."""
    out = []
    for e in extra:
        link = reference.model.bodies[reference.body_names.index(e.body)].links[0]
        b, x = robot.model.link_frames[link]
        x_ref = reference.model.link_frames[link][1]
        p = x[:3, :3] @ (x_ref[:3, :3].T @ (np.asarray(e.offset, float) - x_ref[:3, 3])) + x[:3, 3]
        out.append(ExtraMass(robot.body_names[b], e.share, (float(p[0]), float(p[1]), float(p[2]))))
    return tuple(out)


def stance_config(reference: Robot, robot: Robot, config: ExperimentConfig) -> ExperimentConfig:
    """``config`` for the same real robot in another stance: its unmodelled masses (those of
    ``extra_masses(reference, config)``, offsets in the reference robot's body frames) carried
    into the body frames of ``robot`` (``carried``), so every stance stands the same physical
    robot."""
    return dataclasses.replace(
        config, extra=carried(reference, robot, extra_masses(reference, config))
    )


def real_bodies(robot: Robot, config: ExperimentConfig) -> tuple[list, list[dict]]:
    """The real robot's bodies (the model's plus the unmodelled masses) and the masses placed."""
    if not (0 <= config.extra_mass_fraction < 1):
        raise DataError(f"extra mass fraction must be in [0, 1), got {config.extra_mass_fraction}")
    extra = extra_masses(robot, config)
    shares = sum(e.share for e in extra)
    if extra and not math.isclose(shares, 1.0, abs_tol=1e-9):
        raise DataError(f"extra-mass shares must sum to 1, got {shares:g}")
    names = robot.body_names
    extra_total = config.extra_mass_fraction * robot.total_mass
    bodies = list(robot.model.bodies)
    placed = []
    for e in extra:
        if e.body not in names:
            raise DataError(f"extra mass on unknown body '{e.body}' (bodies: {', '.join(names)})")
        i = names.index(e.body)
        b = bodies[i]
        me = e.share * extra_total
        off = np.asarray(e.offset, dtype=float)
        m = b.mass + me
        com = (b.mass * b.com + me * off) / m if m > 0 else b.com
        bodies[i] = dataclasses.replace(b, mass=m, com=com)
        placed.append({"body": e.body, "mass_kg": me, "offset_m": off.tolist()})
    return bodies, placed


def real_robot(robot: Robot, config: ExperimentConfig) -> tuple[np.ndarray, float, list[dict]]:
    """True SESC vectors (N, 3) [m] and mass [kg] of the model plus the unmodelled masses."""
    bodies, placed = real_bodies(robot, config)
    model = dataclasses.replace(robot.model, bodies=bodies)
    return sesc_vectors(model), float(sum(b.mass for b in bodies)), placed


def check_limits(robot: Robot, q: np.ndarray, where: str = "poses") -> None:
    """Error naming the first pose/joint outside the robot's joint limits."""
    lim = robot.joint_limits
    bad = np.argwhere((q < lim[:, 0]) | (q > lim[:, 1]))
    if bad.size:
        i, j = bad[0]
        lo, hi = np.degrees(lim[j])
        raise DataError(
            f"{where}: pose {i}, joint '{robot.joint_names[j]}': {math.degrees(q[i, j]):.2f}° is "
            f"outside the joint limits [{lo:.1f}°, {hi:.1f}°] ({len(bad)} values out of limits)"
        )


@dataclass(frozen=True)
class SensorErrors:
    """The sensor errors of one bench run (drawn once; ``draw_errors``)."""

    pad_bias: dict[str, np.ndarray]  #: foot → (4,) N
    pad_gain: dict[str, np.ndarray]  #: foot → (4,) relative
    tau_joints: tuple[str, ...] = ()  #: joints with a torque sensor, model order
    tau_index: np.ndarray = field(
        default_factory=lambda: np.zeros(0, dtype=int)
    )  #: their q columns
    tau_offset: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: (k,) N·m
    tau_gain: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: (k,)
    tau_friction: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: (k,) N·m


def pad_gains(sensors: SensorConfig | None, config: ExperimentConfig, seed: int | None) -> dict:
    """Per-pad gains g ~ N(1, fsr_gain²) of each foot (a pad reads F / g + bias).

    Drawn from their own random stream (seed, 11); all ones when ``fsr_gain`` is 0.
    """
    feet = sensors.feet if sensors is not None else ()
    if config.fsr_gain == 0:
        return {f.name: np.ones(4) for f in feet}
    rng = np.random.default_rng(None if seed is None else (seed, PAD_GAIN_STREAM))
    out = {}
    for f in feet:
        g = 1.0 + rng.normal(0.0, config.fsr_gain, size=4)
        if np.any(g <= 0.1):
            raise DataError(f"FSR gain error {config.fsr_gain} gives a gain ≤ 0.1; use less")
        out[f.name] = g
    return out


def draw_errors(robot: Robot, sensors, config: ExperimentConfig, seed, rng) -> SensorErrors:
    """The run's sensor errors: pad biases from ``rng`` (the bench's stream, in foot order),
    pad gains and torque errors from their own streams of ``seed``."""
    feet = sensors.feet if sensors is not None else ()
    bias = {f.name: rng.normal(0.0, config.fsr_bias, size=4) for f in feet}
    gain = pad_gains(sensors, config, seed)
    tc = config.torque
    joints = tc.resolve(robot.joint_names)
    if not joints:
        return SensorErrors(bias, gain)
    k = len(joints)
    trng = np.random.default_rng(None if seed is None else (seed, TORQUE_STREAM))
    offset = trng.normal(0.0, tc.offset, size=k)
    tgain = 1.0 + trng.normal(0.0, tc.gain, size=k)
    if np.any(tgain <= 0.1):
        raise DataError(f"torque gain error {tc.gain} gives a gain ≤ 0.1; use less")
    friction = trng.uniform(tc.friction[0], tc.friction[1], size=k)
    index = np.array([robot.joint_names.index(j) for j in joints], dtype=int)
    return SensorErrors(bias, gain, tuple(joints), index, offset, tgain, friction)


def approach_sides(config: ExperimentConfig, n: int, seed: int | None, start: int = 0):
    """(n,) ±1: the side each pose is approached from (``TorqueConfig.approach``).

    ``start`` is the index of the first pose (a session draws one pose at a time).
    """
    mode = config.torque.approach
    if mode == "up":
        return np.ones(n)
    if mode == "down":
        return -np.ones(n)
    if mode == "alternate":
        return np.where((np.arange(start, start + n) % 2) == 0, 1.0, -1.0)
    rng = np.random.default_rng(None if seed is None else (seed, APPROACH_STREAM, start))
    return rng.choice([-1.0, 1.0], size=n)
