"""A virtual bench experiment (paper §4) with a "real" robot that differs from its model.

The real robot carries **unmodelled mass** (screws, cables, boards: by default 7 % of the model's
mass spread over several bodies at offsets of a few centimetres), its joints have **backlash**
(each pose's actual angle differs from the commanded one by δ ~ U(−b, b), b = 1° by default),
and its foot sensors have **noise** and a **per-sensor bias**.

What the log shows, per pose and sample:

- joint read-backs in the profile's servo ticks (MX-28 for the OP2; radians, unquantised and
  without jitter, for a robot whose profile has no servo): the commanded angle plus the part
  ``readback_seen`` (default
  0.5) of δ that the servo's output-shaft encoder sees (gear play), rounded to ticks with
  ``readback_jitter_ticks`` of noise; the rest of δ (horn and bracket play) is invisible, so the
  read-backs still miss the actual angle by up to (1 − readback_seen)·b;
- the four forces of the support foot in mN: the true weight ``M g`` spread over the sensors by
  the bilinear weights of the true CoP in the sensor rectangle (their centroid is exactly the
  CoP), plus the sensor's bias and N(0, fsr_noise²) noise, rounded to integer mN and clipped to
  0–65535. The lifted foot reads 0 (an unloaded FSR conducts nothing);
- optionally the centroid registers computed from those counts as the board would
  (X = 254 (F2 + F4)/F, Y = 254 (F3 + F4)/F, 255 when the foot carries no load).

The truth (true SESC vectors, actual poses, true CoPs, biases) is returned beside the log.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sescid.base.files import read_json
from sescid.errors import DataError
from sescid.sensors.pads import Foot, SensorConfig
from sescid.sesc import sesc_vectors
from sescid.simulation import check_count

G = 9.80665  #: m/s², standard gravity
TRUTH_FORMAT = "sescid-experiment-truth/1"


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


@dataclass
class ExperimentConfig:
    """How the virtual real robot differs from the model (SI units, angles in degrees)."""

    extra_mass_fraction: float = 0.07  #: unmodelled mass / model mass
    extra: tuple[ExtraMass, ...] = DEFAULT_EXTRA
    backlash_deg: float = 1.0  #: actual − commanded angle ~ U(−b, b) per pose and joint
    readback_seen: float = 0.5  #: part of that offset the joint encoder reports
    readback_jitter_ticks: float = 0.3  #: read-back noise per sample, ticks (std)
    fsr_noise: float = 1.5  #: N, per sensor and sample (std)
    fsr_bias: float = 0.1  #: N, per-sensor constant bias (std over sensors)
    #: relative std of per-pad gain errors: a pad reads F / g + bias, g ~ N(1, fsr_gain²)
    fsr_gain: float = 0.0
    #: kinematic bench: feet whose sole the model puts on the floor share the load (two-foot
    #: poses); the split over all their pads is the elastic one (least squares, as a rigid
    #: body on equal springs): statics fixes only the total force and its moments
    double_support: bool = False
    registers: str = "forces"  #: "forces", "centroid" or "both"
    #: kinematic bench: the support stands tilted by a random roll and pitch ~ N(0, tilt_deg²)
    #: per pose (a sloped or soft floor); the log gets grav_x/y/z, the CoP follows gravity
    tilt_deg: float = 0.0

    def check(self) -> None:
        """DataError for a setting outside its range (the one check both benches use)."""
        if self.registers not in ("forces", "centroid", "both"):
            raise DataError(f"registers must be forces, centroid or both, got {self.registers}")
        for name, v in (
            ("backlash", self.backlash_deg),
            ("FSR noise", self.fsr_noise),
            ("FSR bias", self.fsr_bias),
            ("FSR gain error", self.fsr_gain),
            ("read-back jitter", self.readback_jitter_ticks),
            ("support tilt", self.tilt_deg),
        ):
            if not (v >= 0 and math.isfinite(v)):
                raise DataError(f"{name} must be a finite number ≥ 0, got {v}")


@dataclass
class Experiment:
    """The raw log (column name → array) and the truth behind it."""

    columns: dict[str, np.ndarray]
    truth: dict = field(default_factory=dict)
    skipped: list[tuple[str, str]] = field(default_factory=list)  #: (pose, why) not measured


def real_bodies(robot, config: ExperimentConfig) -> tuple[list, list[dict]]:
    """The real robot's bodies (the model's plus the unmodelled masses) and the masses placed."""
    if not (0 <= config.extra_mass_fraction < 1):
        raise DataError(f"extra mass fraction must be in [0, 1), got {config.extra_mass_fraction}")
    shares = sum(e.share for e in config.extra)
    if config.extra and not math.isclose(shares, 1.0, abs_tol=1e-9):
        raise DataError(f"extra-mass shares must sum to 1, got {shares:g}")
    names = robot.body_names
    extra_total = config.extra_mass_fraction * robot.total_mass
    bodies = list(robot.model.bodies)
    placed = []
    for e in config.extra:
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


def real_robot(robot, config: ExperimentConfig) -> tuple[np.ndarray, float, list[dict]]:
    """True SESC vectors (N, 3) [m] and mass [kg] of the model plus the unmodelled masses."""
    bodies, placed = real_bodies(robot, config)
    model = dataclasses.replace(robot.model, bodies=bodies)
    return sesc_vectors(model), float(sum(b.mass for b in bodies)), placed


def pad_gains(sensors: SensorConfig, config: ExperimentConfig, seed: int | None) -> dict:
    """Per-pad gains g ~ N(1, fsr_gain²) of each foot (a pad reads F / g + bias).

    Drawn from their own random stream (seed, 11), so adding gain errors leaves every other
    draw of a seeded bench unchanged; all ones when ``fsr_gain`` is 0.
    """
    if config.fsr_gain == 0:
        return {f.name: np.ones(4) for f in sensors.feet}
    rng = np.random.default_rng(None if seed is None else (seed, 11))
    out = {}
    for f in sensors.feet:
        g = 1.0 + rng.normal(0.0, config.fsr_gain, size=4)
        if np.any(g <= 0.1):
            raise DataError(f"FSR gain error {config.fsr_gain} gives a gain ≤ 0.1; use less")
        out[f.name] = g
    return out


def pads_in_support(robot, foot, q: np.ndarray) -> np.ndarray:
    """(n, 4, 2) a foot's pad centres in the support frame (x, y) at poses q (n, nq)."""
    rot, org = robot.link_poses(q, foot.sole_frame)
    return org[:, None, :2] + np.einsum("nij,kj->nki", rot[:, :2, :2], foot.sensors)


def two_foot_split(robot, sensors: SensorConfig, q: np.ndarray, cop: np.ndarray, weight: float):
    """Pad forces of every foot on the floor: the least-squares (elastic) split of the weight.

    Feet count as on the floor where the model puts their sole within 10 mm of the ground and
    5° of level at q (``sensors.OFF_FLOOR_*``). Returns forces {foot: (n, 4)} N, a mask of
    poses whose CoP needs a pulling pad (outside the support), and its description.
    """
    from sescid.sensors.feet import OFF_FLOOR_M, OFF_FLOOR_TILT

    n = q.shape[0]
    pts, on = [], []
    for f in sensors.feet:
        rot, org = robot.link_poses(q, f.sole_frame)
        tilt = np.arccos(np.clip(rot[:, 2, 2], -1.0, 1.0))
        on.append((np.abs(org[:, 2]) <= OFF_FLOOR_M) & (tilt <= OFF_FLOOR_TILT))
        pts.append(pads_in_support(robot, f, q))
    mask = np.repeat(np.stack(on, axis=1), 4, axis=1)  # (n, 4·feet)
    p = np.concatenate(pts, axis=1)  # (n, 4·feet, 2)
    a = np.concatenate([np.ones(p.shape[:2] + (1,)), p], axis=2) * mask[:, :, None]
    rhs = weight * np.concatenate([np.ones((n, 1)), cop], axis=1)
    lam = np.linalg.solve(np.einsum("nki,nkj->nij", a, a), rhs[:, :, None])[:, :, 0]
    forces = np.einsum("nki,ni->nk", a, lam)
    bad = np.any(forces < 0, axis=1)
    out = {f.name: forces[:, 4 * i : 4 * i + 4] for i, f in enumerate(sensors.feet)}
    return out, bad, "the pads of the feet on the floor (a pad would pull)"


def check_limits(robot, q: np.ndarray, where: str = "poses") -> None:
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


def pad_columns(
    foot: Foot, counts: np.ndarray, registers: str, sensors: SensorConfig
) -> dict[str, np.ndarray]:
    """Raw-log columns of one foot board from its force counts (m, 4): the four forces, the
    centroid registers the board computes from them (X = 254 (F2 + F4)/F, Y = 254 (F3 + F4)/F,
    ``no_load`` below the minimum foot force), or both (``registers``)."""
    cols: dict[str, np.ndarray] = {}
    if registers in ("forces", "both"):
        for k in range(4):
            cols[f"{foot.columns}{k + 1}"] = counts[:, k]
    if registers in ("centroid", "both"):
        total = counts.sum(axis=1)
        on = total * sensors.force_unit >= sensors.min_foot_force
        safe = np.where(on, total, 1)
        x = np.round(sensors.centroid_max * (counts[:, 1] + counts[:, 3]) / safe)
        y = np.round(sensors.centroid_max * (counts[:, 2] + counts[:, 3]) / safe)
        cols[f"{foot.columns}_x"] = np.where(on, x, sensors.no_load).astype(int)
        cols[f"{foot.columns}_y"] = np.where(on, y, sensors.no_load).astype(int)
    return cols


def truth_record(
    robot,
    config: ExperimentConfig,
    sensors: SensorConfig,
    seed: int | None,
    samples: int,
    mass_true: float,
    placed: list[dict],
    r_true: np.ndarray,
    bias: dict[str, np.ndarray],
    gain: dict[str, np.ndarray],
    units: str = "m, kg, N, rad",
) -> dict:
    """The part of a bench's truth record that every bench writes (format, settings, the true
    robot and the sensor errors); each bench adds its per-pose entries."""
    names = robot.body_names
    return {
        "format": TRUTH_FORMAT,
        "units": units,
        "robot": robot.source,
        "support": robot.support,
        "seed": seed,
        "samples": samples,
        "settings": {
            "extra_mass_fraction": config.extra_mass_fraction,
            "backlash_deg": config.backlash_deg,
            "readback_seen": config.readback_seen,
            "readback_jitter_ticks": config.readback_jitter_ticks,
            "fsr_noise_N": config.fsr_noise,
            "fsr_bias_N": config.fsr_bias,
            "fsr_gain": config.fsr_gain,
            "registers": config.registers,
            "sensors": sensors.source,
        },
        "model_mass_kg": robot.total_mass,
        "true_mass_kg": mass_true,
        "extra_masses": placed,
        "r_true": {bn: r_true[i].tolist() for i, bn in enumerate(names)},
        "r_model": {bn: robot.sesc_vectors()[i].tolist() for i, bn in enumerate(names)},
        "fsr_bias_N": {k: v.tolist() for k, v in bias.items()},
        "fsr_gain": {k: v.tolist() for k, v in gain.items()},
        "joint_names": robot.joint_names,
    }


def run_experiment(
    robot,
    q_cmd: np.ndarray,
    sensors: SensorConfig,
    samples: int = 100,
    seed: int | None = 0,
    config: ExperimentConfig | None = None,
    pose_ids: np.ndarray | None = None,
) -> Experiment:
    """Stand the real robot in each commanded pose (n, nq) [rad] and log ``samples`` readings.

    A pose whose real CoP falls outside the support foot's sensor rectangle cannot be measured
    (the sole edge would take part of the load, or the robot would tip): it is left out of the
    log and listed in ``skipped`` with the reason.
    """
    config = config or ExperimentConfig()
    q_cmd = np.asarray(q_cmd, dtype=float)
    n = q_cmd.shape[0]
    if samples < 1:
        raise DataError(f"samples per pose must be ≥ 1, got {samples}")
    check_count(n * samples, 8 * (robot.nq + 16) * 16, "samples", "samples (poses × samples)")
    config.check()
    check_limits(robot, q_cmd)
    pose_ids = np.array([str(i) for i in range(n)]) if pose_ids is None else pose_ids
    support = [f for f in sensors.feet if f.sole_frame == robot.support]
    if not support:
        raise DataError(
            f"no foot sensor board sits on the support link '{robot.support}' "
            f"(boards: {', '.join(f.sole_frame for f in sensors.feet)})"
        )
    foot = support[0]
    r_true, mass_true, placed = real_robot(robot, config)
    rng = np.random.default_rng(seed)

    b = math.radians(config.backlash_deg)
    delta = rng.uniform(-b, b, size=q_cmd.shape)
    q_act = q_cmd + delta
    grav = None
    if config.tilt_deg > 0:  # roll φ, pitch θ of the support: (sin θ, −cos θ sin φ, −cos θ cos φ)
        roll, pitch = rng.normal(0.0, math.radians(config.tilt_deg), size=(2, n))
        grav = np.stack(
            [np.sin(pitch), -np.cos(pitch) * np.sin(roll), -np.cos(pitch) * np.cos(roll)], axis=1
        )
    cop_true = robot.cop(q_act, r_true, grav)
    weight = mass_true * G
    if config.double_support:
        f_split, tips, where = two_foot_split(robot, sensors, q_act, cop_true, weight)
    else:
        uv = foot.board_coordinates(cop_true)
        tips = np.any((uv < 0) | (uv > 1), axis=1)
        where = f"the sensor rectangle of {robot.support}"
    skipped = [
        (
            str(pose_ids[i]),
            f"the real robot's CoP ({cop_true[i, 0] * 1e3:.1f}, {cop_true[i, 1] * 1e3:.1f}) mm "
            f"lies outside {where}: it would rest on the sole "
            "edge or tip over, so it was not measured",
        )
        for i in np.flatnonzero(tips)
    ]
    if tips.all():
        raise DataError(f"no pose can be measured: pose {skipped[0][0]}: {skipped[0][1]}")
    keep = ~tips
    q_cmd, delta, q_act = q_cmd[keep], delta[keep], q_act[keep]
    cop_true, pose_ids = cop_true[keep], pose_ids[keep]
    grav = None if grav is None else grav[keep]
    n = len(q_cmd)
    if config.double_support:
        f_feet = {name: f[keep] for name, f in f_split.items()}
    else:
        u, v = uv[keep, 0], uv[keep, 1]
        w = np.stack([(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v], axis=1)
        f_feet = {f.name: (weight * w if f is foot else np.zeros((n, 4))) for f in sensors.feet}
    bias = {f.name: rng.normal(0.0, config.fsr_bias, size=4) for f in sensors.feet}
    gain = pad_gains(sensors, config, seed)

    m = n * samples
    pose_of = np.repeat(np.arange(n), samples)
    cols: dict[str, np.ndarray] = {
        "pose": pose_ids[pose_of],
        "sample": np.tile(np.arange(samples), n),
    }
    q_read = q_cmd + config.readback_seen * delta
    servo = robot.profile.servo
    if servo is not None:
        exact = q_read * (servo.ticks_per_turn / (2 * math.pi)) + servo.zero_tick
        ticks = np.round(exact)[pose_of] + rng.normal(
            0.0, config.readback_jitter_ticks, size=(m, robot.nq)
        )
        ticks = np.clip(np.round(ticks), 0, servo.max_tick).astype(int)
        for j, name in enumerate(robot.joint_names):
            cols[f"{name}_ticks"] = ticks[:, j]
    else:
        for j, name in enumerate(robot.joint_names):
            cols[name] = q_read[pose_of, j]
    counts_by_foot = {}
    for f in sensors.feet:
        if f_feet[f.name].any():
            true = f_feet[f.name][pose_of]
            loaded = true / gain[f.name] + bias[f.name]
            noisy = loaded + rng.normal(0.0, config.fsr_noise, size=(m, 4))
            counts = np.clip(np.round(noisy / sensors.force_unit), 0, sensors.saturation)
            counts = np.where(true.sum(axis=1, keepdims=True) > 0, counts, 0)  # unloaded: 0
        else:
            counts = np.zeros((m, 4))
        counts = counts.astype(int)
        counts_by_foot[f.name] = counts
        cols |= pad_columns(f, counts, config.registers, sensors)

    # noise-free measured CoP: what a perfect average of the biased sensors gives
    num, den = np.zeros((n, 2)), np.zeros(n)
    for f in sensors.feet:
        on = f_feet[f.name].sum(axis=1) > 0
        fb = np.where(on[:, None], f_feet[f.name] / gain[f.name] + bias[f.name], 0.0)
        num += np.einsum("nk,nki->ni", fb, pads_in_support(robot, f, q_act))
        den += fb.sum(axis=1)
    cop_expected = num / den[:, None]
    if grav is not None:  # the pads sit on the sole plane, so their centroid is the tilted CoP
        cols |= {f"grav_{a}": grav[pose_of, i] for i, a in enumerate("xyz")}
    truth = truth_record(
        robot, config, sensors, seed, samples, mass_true, placed, r_true, bias, gain
    )
    truth["settings"] |= {"double_support": config.double_support, "tilt_deg": config.tilt_deg}
    truth |= {
        "pose": pose_ids.tolist(),
        "q_commanded": q_cmd.tolist(),
        "q_actual": q_act.tolist(),
        "q_readback": q_read.tolist(),
        "cop_true": cop_true.tolist(),
        "cop_expected": cop_expected.tolist(),
        "skipped": [{"pose": p, "reason": why} for p, why in skipped],
    }
    if grav is not None:
        truth["grav"] = grav.tolist()
    return Experiment(columns=cols, truth=truth, skipped=skipped)


def load_truth(path: str | Path) -> dict:
    """Read a truth JSON written by ``sescid experiment --truth`` (arrays as numpy)."""
    data = read_json(path, TRUTH_FORMAT, "an experiment truth file")
    for key in ("q_commanded", "q_actual", "q_readback", "cop_true", "cop_expected"):
        data[key] = np.array(data[key], dtype=float)
    return data
