"""Synthetic data with known truth: random poses, the CoP and the joint torques they give, with
sensor errors.

The paper's §3 settings (``PAPER_*``) live here, their one home; the study itself (simulate,
identify, validate) is ``sescid.study.paper_study``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from sescid.base import G0, check_ranges, option
from sescid.errors import OptionError
from sescid.tables.columns import MAX_COP_NOISE_M

if TYPE_CHECKING:  # pragma: no cover
    from sescid.robot import Robot

__all__ = [
    "BalanceData",
    "MAX_STABLE_DRAWS",
    "MEMORY_FACTOR",
    "PAPER_MAE",
    "PAPER_NOISE",
    "PAPER_POSES",
    "PAPER_RANGE_DEG",
    "SimData",
    "TorqueData",
    "TorqueNoise",
    "check_count",
    "random_poses",
    "simulate",
    "simulate_balance",
    "simulate_torques",
]

#: the paper's §3 settings
PAPER_POSES = 1000
PAPER_RANGE_DEG = 30.0
PAPER_NOISE = 0.00493  #: m, CoP noise standard deviation (Ha et al. 2013)
PAPER_MAE = 0.0040  #: m, the mean absolute CoP error the paper reports for n = 1000


@dataclass
class SimData:
    """Simulated poses (n, nq) [rad], noisy CoP (n, 2) [m] and the noise-free CoP (n, 2) [m]."""

    q: np.ndarray
    cop: np.ndarray
    cop_true: np.ndarray
    noise: float
    n_drawn: int = 0  #: raw draws (more than n when ``stable`` rejected some)
    n_clipped: int = 0  #: kept poses with at least one joint clipped to its limits
    #: (n, 3) gravity direction per pose in the support frame (a tilted support); None: level
    gravity: np.ndarray | None = None
    torques: TorqueData | None = None  #: simulated joint-torque readings, when asked for


@dataclass(frozen=True)
class TorqueNoise:
    """A torque sensor model: reading = τ + offset_j + side·friction + N(0, noise²) [N·m].

    ``offset``: std of a random constant offset per joint; ``friction``: half-width of the
    static-friction band (a held torque sits at its edge on the side the pose was approached
    from, a random side per pose, written as the ``approach`` column); ``g0``: |g| [m/s²];
    ``total_mass``: the true robot's mass [kg] (None: the model's)."""

    noise: float = option(
        0.05, "Joint-torque noise standard deviation [N·m].", low=0, high=1e3, flag="--tau-noise"
    )
    offset: float = option(
        0.0, "Std of a random constant offset per torque sensor [N·m].", low=0, high=1e3,
        flag="--tau-offset",
    )  # fmt: skip
    friction: float = option(
        0.0,
        "Half-width of each joint's static-friction band [N·m] (writes the approach column).",
        low=0, high=1e3, flag="--tau-friction",
    )  # fmt: skip
    g0: float = option(G0, "|g| [m/s²].", low=1, high=30, what="|g| in m/s² (1–30)")
    total_mass: float | None = None

    def check(self) -> None:
        """OptionError for a value out of range."""
        check_ranges(self)


@dataclass(frozen=True)
class TorqueData:
    """Simulated torque readings (n, J) [N·m] of ``joints`` and the truth behind them."""

    joints: tuple[str, ...]
    tau: np.ndarray  #: (n, J) readings
    tau_true: np.ndarray  #: (n, J) noise-free holding torques
    offsets: np.ndarray  #: (J,) true sensor offsets
    friction: float  #: half-width of the friction band
    approach: np.ndarray | None  #: (n,) ±1 approach sides (with friction)


def simulate_torques(
    robot: Robot, q: np.ndarray, model: TorqueNoise, rng: np.random.Generator, r_true=None
) -> TorqueData:
    """Torque readings of every joint at poses q (n, nq) for the sensor ``model`` (level)."""
    model.check()
    tau_true = robot.torques(q, r_true, total_mass=model.total_mass, g0=model.g0)
    offsets = rng.normal(0.0, model.offset, robot.nq) if model.offset > 0 else np.zeros(robot.nq)
    tau = tau_true + offsets + rng.normal(0.0, model.noise, tau_true.shape)
    approach = None
    if model.friction > 0:
        approach = np.where(rng.random(q.shape[0]) < 0.5, 1.0, -1.0)
        tau += approach[:, None] * model.friction
    return TorqueData(tuple(robot.joint_names), tau, tau_true, offsets, model.friction, approach)


#: peak bytes per stored float of a pose array while simulating it, with margin (measured: 10⁶
#: OP2 poses peak at 331 MB above the interpreter, 2.1 × the 160 MB of q; the CLI's writer adds
#: its buffers, 445 MB in all)
MEMORY_FACTOR = 3


def check_count(n: int, bytes_each: float, name: str, what: str) -> None:
    """OptionError before allocating when ``n`` items of ``bytes_each`` exceed half the
    machine's memory."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        return
    if n * bytes_each > total:
        fit = int(total // bytes_each)
        raise OptionError(
            name,
            f"{n:g} {what} need ~{n * bytes_each / 2**30:.3g} GiB, more than half this "
            f"machine's memory ({total / 2**30:.3g} GiB) (at most ~{fit:,} {what})",
        )


def random_poses(
    robot: Robot,
    n: int,
    range_deg: float = PAPER_RANGE_DEG,
    rng: np.random.Generator | int | None = 0,
    clip: bool = False,
) -> np.ndarray:
    """Joint angles (n, nq) [rad] uniform in ±range_deg; clipped to the joint limits if asked."""
    if n < 1:
        raise OptionError("n", f"number of poses must be ≥ 1, got {n}")
    if not (0 < range_deg <= 180):
        raise OptionError("range_deg", f"must be in (0, 180] degrees, got {range_deg}")
    check_count(n, 8 * robot.nq * MEMORY_FACTOR, "n", "poses")
    rng = np.random.default_rng(rng)
    half = math.radians(range_deg)
    q = rng.uniform(-half, half, size=(n, robot.nq))
    if clip:
        lim = robot.joint_limits
        q = np.clip(q, lim[:, 0], lim[:, 1])
    return q


def simulate(
    robot: Robot,
    n: int = PAPER_POSES,
    range_deg: float = PAPER_RANGE_DEG,
    noise: float = PAPER_NOISE,
    seed: int | None = 0,
    clip: bool | None = None,
    r_true: np.ndarray | None = None,
    stable: bool = False,
    tilt: float = 0.0,
    torques: TorqueNoise | None = None,
) -> SimData:
    """Random poses and their CoP = CoM projection + N(0, noise²) per axis.

    ``clip``: clip the poses to the joint limits (None: clip, unless the robot's profile carries
    the paper's convention — the OP2's ±30° study is unclipped).
    ``r_true``: SESC vectors of the "true" robot (default: the model's own). ``stable``: keep
    only poses whose noise-free CoP lies inside the support sole (``Robot.sole``), drawing
    until there are ``n``. ``tilt`` (rad): the support is tilted per pose by a random roll and
    pitch ~ N(0, tilt²); the CoP is then the CoM projected along gravity (``gravity``, support
    frame). The draws for ``tilt = 0`` are those of a level simulation. ``torques``: also the
    joints' torque readings under that sensor model (level support only; drawn after the CoP).
    """
    if not (noise >= 0 and math.isfinite(noise)):
        raise OptionError("noise", f"must be a finite standard deviation ≥ 0 m, got {noise}")
    if noise > MAX_COP_NOISE_M:
        raise OptionError(
            "noise", f"{noise:g} m is not a plausible CoP noise (millimetres for metres?)"
        )
    if not (0 <= tilt <= math.radians(30)):
        raise OptionError("tilt", f"must be a standard deviation in [0, 30°], got {tilt} rad")
    if clip is None:  # clip, unless the profile carries the paper's unclipped ±30° convention
        clip = robot.profile.paper_limits_file is None
    rng = np.random.default_rng(seed)
    if not stable:
        q = random_poses(robot, n, range_deg, rng, clip)
        n_drawn = n
    else:
        q, n_drawn = _stable_poses(robot, n, range_deg, rng, clip)
    lim = robot.joint_limits
    n_clipped = int(np.sum(np.any((q <= lim[:, 0]) | (q >= lim[:, 1]), axis=1))) if clip else 0
    e = rng.normal(0.0, noise, size=(q.shape[0], 2))
    gravity = None
    if tilt > 0:  # roll φ, pitch θ of the support: gravity (sin θ, −cos θ sin φ, −cos θ cos φ)
        roll, pitch = rng.normal(0.0, tilt, size=(2, q.shape[0]))
        gravity = np.stack(
            [np.sin(pitch), -np.cos(pitch) * np.sin(roll), -np.cos(pitch) * np.cos(roll)], axis=1
        )
    cop_true = robot.cop(q, r_true, gravity)
    cop = cop_true + e
    tau = None
    if torques is not None and robot.nq == 0:
        raise OptionError(
            "torques", f"{robot.name} has no joints: there is no joint torque to simulate"
        )
    if torques is not None:
        if gravity is not None:
            raise OptionError("tilt", "torques are simulated on a level support only")
        tau = simulate_torques(robot, q, torques, rng, r_true)
    return SimData(
        q=q,
        cop=cop,
        cop_true=cop_true,
        noise=noise,
        n_drawn=n_drawn,
        n_clipped=n_clipped,
        gravity=gravity,
        torques=tau,
    )


MAX_STABLE_DRAWS = 10_000_000  #: ``simulate(stable=True)`` gives up beyond this many draws


def _stable_poses(robot: Robot, n, range_deg, rng, clip) -> tuple[np.ndarray, int]:
    """Draw ``n`` poses whose model CoP is inside the support sole; also how many draws it took."""
    sole = robot.sole
    if sole is None:
        raise OptionError("stable", f"{robot.name}: no sole (profile size or foot geometry)")
    half = np.asarray(sole.size) / 2
    centre = robot.sole_centre
    kept, n_drawn, n_kept = [], 0, 0
    while n_kept < n:
        q = random_poses(robot, max(1000, 2 * (n - n_kept)), range_deg, rng, clip)
        n_drawn += len(q)
        q = q[np.all(np.abs(robot.cop(q) - centre) < half, axis=1)]
        kept.append(q)
        n_kept += len(q)
        if n_drawn > MAX_STABLE_DRAWS:
            raise OptionError(
                "stable", f"only {n_kept} of {n_drawn} poses have the CoP on the sole"
            )
    return np.concatenate(kept)[:n], n_drawn


@dataclass(frozen=True)
class BalanceData:
    """Simulated balanced poses of a robot on a line: joint angles (n, nq) [rad], the gravity
    direction (n, 3) in the support frame that an IMU with ``tilt_noise`` reports, and the true
    and measured tilts about the line (n,) [rad] (``sesc.balance_tilt``)."""

    q: np.ndarray
    gravity: np.ndarray
    tilt: np.ndarray
    tilt_measured: np.ndarray
    tilt_noise: float


def simulate_balance(
    robot: Robot,
    n: int = 40,
    range_deg: float = PAPER_RANGE_DEG,
    tilt_noise: float = math.radians(0.5),
    seed: int | None = 0,
    r_true: np.ndarray | None = None,
) -> BalanceData:
    """Random poses (uniform in ±range_deg, clipped to the joint limits) of a robot balancing
    on its support line (``Robot.line``), each at the tilt that balances the true robot
    (``r_true``, default the model's), read with a tilt error ~ N(0, tilt_noise²) [rad]."""
    from sescid.sesc import balance_gravity, balance_tilt

    if robot.line is None:
        raise OptionError("line", f"{robot.name}: the support '{robot.support}' is not a line")
    if not (math.isfinite(tilt_noise) and 0 <= tilt_noise <= math.radians(20)):
        raise OptionError("tilt_noise", f"must be in [0, 20°] (rad), got {tilt_noise}")
    rng = np.random.default_rng(seed)
    q = random_poses(robot, n, range_deg, rng, clip=True)
    r = robot.sesc_vectors() if r_true is None else np.asarray(r_true, dtype=float)
    tilt, _ = balance_tilt(robot.tree, robot.line, q, r)
    measured = tilt + rng.normal(0.0, tilt_noise, size=n)
    return BalanceData(q, balance_gravity(robot.line, measured), tilt, measured, tilt_noise)
