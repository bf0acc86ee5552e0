"""The truth behind a bench's raw log, as a typed frozen record (``Truth``), and its JSON file.

A bench knows what a real robot hides: the true SESC vectors and mass, the poses actually taken
(joint play included), the true CoPs, the sensor errors it drew and, with torque sensors, the
true holding torques. ``Truth`` holds them with units and shapes; ``save``/``load`` write and
read the file ``sescid experiment --truth`` gives (JSON, format ``sescid-experiment-truth/1``;
files without the newer optional entries still load).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np

from sescid.base.files import atomic_open, read_json
from sescid.bench.log import expected_torques
from sescid.bench.real_robot import BenchMount, Engine
from sescid.errors import DataError, choices
from sescid.robot import Robot

TRUTH_FORMAT = "sescid-experiment-truth/1"


@dataclass(frozen=True)
class PlacedMass:
    """An unmodelled point mass of the real robot."""

    body: str
    mass: float  #: kg
    offset: tuple[float, float, float]  #: m, in the body's frame


@dataclass(frozen=True)
class TorqueTruth:
    """The joint torque sensors' truth (k measured joints, n poses)."""

    joints: tuple[str, ...]
    tau: np.ndarray  #: (n, k) true holding torque at the pose actually taken, N·m
    expected: np.ndarray  #: (n, k) noise-free reading gain τ + offset + approach f, N·m
    offset: np.ndarray  #: (k,) N·m
    gain: np.ndarray  #: (k,)
    friction: np.ndarray  #: (k,) N·m, half-width of the static-friction band
    approach: np.ndarray  #: (n,) ±1
    noise: float  #: N·m per sample


@dataclass(frozen=True)
class PhysicsTruth:
    """What only the physics bench knows, per pose (n poses, MuJoCo)."""

    q_target: np.ndarray  #: (n, nq) servo targets (command + backlash), rad
    servo_sag: np.ndarray  #: (n, nq) settled − target, rad
    foot_tilt: np.ndarray  #: (n,) support sole's tilt, rad
    sole_height: np.ndarray  #: (n,) m
    com_sole: np.ndarray  #: (n, 3) CoM in the sole frame, m
    cop_gravity: np.ndarray  #: (n, 2) gravity-aware statics CoP, m
    cop_pads: np.ndarray  #: (n, 2) noise-free pad CoP, m
    settle_s: np.ndarray  #: (n,) simulated time until still, s
    wall_s: np.ndarray  #: (n,) wall time per pose, s
    cop_ft: np.ndarray | None = None  #: (n, 2) welded foot: the sole F/T sensor's CoP, m


@dataclass(frozen=True)
class Truth:
    """The truth of one bench run (n measured poses; SI units, radians)."""

    engine: Engine
    robot: str  #: the model's source
    support: str
    seed: int | None
    samples: int
    settings: Mapping[str, Any]  #: the bench's settings as written (provenance)
    model_mass: float  #: kg
    true_mass: float  #: kg
    extra_masses: tuple[PlacedMass, ...]
    body_names: tuple[str, ...]
    joint_names: tuple[str, ...]
    r_true: np.ndarray  #: (N, 3) true SESC vectors, m
    r_model: np.ndarray  #: (N, 3) the model's, m
    pad_bias: Mapping[str, np.ndarray]  #: foot → (4,) N
    pad_gain: Mapping[str, np.ndarray]  #: foot → (4,)
    pose: tuple[str, ...]  #: measured pose ids
    q_commanded: np.ndarray  #: (n, nq) rad
    q_actual: np.ndarray  #: (n, nq) rad
    q_readback: np.ndarray  #: (n, nq) what the encoders report, rad
    cop_true: np.ndarray | None  #: (n, 2) flat-sole statics of the real robot, m (None: gantry)
    cop_expected: np.ndarray | None  #: (n, 2) noise-free CoP of the biased pads, m
    skipped: tuple[tuple[str, str], ...] = ()  #: (pose, why) not measured
    mount: BenchMount = "stand"
    grav: np.ndarray | None = None  #: (n, 3) gravity direction, support frame
    torque: TorqueTruth | None = None
    physics: PhysicsTruth | None = None
    units: str = "m, kg, N, N·m, rad"

    def to_json(self) -> dict:
        """The JSON document (``TRUTH_FORMAT``): nested lists, keys as the file has them."""
        return _to_json(self)

    def save(self, path: str | Path) -> None:
        """Write the truth file atomically."""
        with atomic_open(path, "w") as fh:
            json.dump(self.to_json(), fh, indent=1)
            fh.write("\n")

    @classmethod
    def load(cls, path: str | Path) -> Truth:
        """Read a truth file; DataError naming the file and the entry when malformed."""
        data = read_json(path, TRUTH_FORMAT, "an experiment truth file")
        try:
            return _from_json(data)
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise DataError(
                f"{path}: malformed truth file ({exc.__class__.__name__}: {exc})"
            ) from None


def _arr(v) -> np.ndarray:
    return np.asarray(v, dtype=float)


def _opt(v):
    return None if v is None else np.asarray(v, dtype=float)


def _list(a):
    if a is None:
        return None
    return np.asarray(a).tolist()


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _to_json(t: Truth) -> dict:
    doc: dict[str, Any] = {
        "format": TRUTH_FORMAT,
        "units": t.units,
        "engine": t.engine,
        "robot": t.robot,
        "support": t.support,
        "mount": t.mount,
        "seed": t.seed,
        "samples": t.samples,
        "settings": dict(t.settings),
        "model_mass_kg": t.model_mass,
        "true_mass_kg": t.true_mass,
        "extra_masses": [
            {"body": e.body, "mass_kg": e.mass, "offset_m": list(e.offset)} for e in t.extra_masses
        ],
        "r_true": {b: t.r_true[i].tolist() for i, b in enumerate(t.body_names)},
        "r_model": {b: t.r_model[i].tolist() for i, b in enumerate(t.body_names)},
        "fsr_bias_N": {k: _list(v) for k, v in t.pad_bias.items()},
        "fsr_gain": {k: _list(v) for k, v in t.pad_gain.items()},
        "joint_names": list(t.joint_names),
        "pose": list(t.pose),
        "q_commanded": _list(t.q_commanded),
        "q_actual": _list(t.q_actual),
        "q_readback": _list(t.q_readback),
        "cop_true": _list(t.cop_true),
        "cop_expected": _list(t.cop_expected),
        "skipped": [{"pose": p, "reason": why} for p, why in t.skipped],
    }
    if t.grav is not None:
        doc["grav"] = _list(t.grav)
    if t.torque is not None:
        tt = t.torque
        doc["torque"] = {
            "joints": list(tt.joints),
            "tau_true_Nm": _list(tt.tau),
            "tau_expected_Nm": _list(tt.expected),
            "offset_Nm": _list(tt.offset),
            "gain": _list(tt.gain),
            "friction_Nm": _list(tt.friction),
            "approach": _list(tt.approach),
            "noise_Nm": tt.noise,
        }
    if t.physics is not None:
        ph = t.physics
        doc |= {
            "q_target": _list(ph.q_target),
            "servo_sag": _list(ph.servo_sag),
            "foot_tilt": _list(ph.foot_tilt),
            "sole_height": _list(ph.sole_height),
            "com_sole": _list(ph.com_sole),
            "cop_gravity": _list(ph.cop_gravity),
            "cop_pads": _list(ph.cop_pads),
            "settle_s": _list(ph.settle_s),
            "wall_s": _list(ph.wall_s),
        }
        if ph.cop_ft is not None:
            doc["cop_ft"] = _list(ph.cop_ft)
    return doc


def _choice(d: dict, key: str, default: str, alias: Any) -> Any:
    """A field of a fixed set (``alias``, a Literal; ``default`` when absent); DataError for
    another value (``load`` names the file)."""
    value = str(d.get(key, default))
    if value not in choices(alias):
        raise DataError(f"field '{key}': {value!r} is not one of {', '.join(choices(alias))}")
    return cast(Any, value)


def _from_json(d: dict) -> Truth:
    bodies = tuple(d["r_true"])
    torque = None
    if d.get("torque") is not None:
        tj = d["torque"]
        torque = TorqueTruth(
            tuple(tj["joints"]), _arr(tj["tau_true_Nm"]), _arr(tj["tau_expected_Nm"]),
            _arr(tj["offset_Nm"]), _arr(tj["gain"]), _arr(tj["friction_Nm"]),
            _arr(tj["approach"]), float(tj["noise_Nm"]),
        )  # fmt: skip
    physics = None
    if "q_target" in d:
        keys = ("q_target", "servo_sag", "foot_tilt", "sole_height", "com_sole", "cop_gravity",
                "cop_pads", "settle_s", "wall_s")  # fmt: skip
        physics = PhysicsTruth(**{k: _arr(d[k]) for k in keys}, cop_ft=_opt(d.get("cop_ft")))
    return Truth(
        engine=_choice(d, "engine", "kinematic", Engine),
        robot=str(d["robot"]),
        support=str(d["support"]),
        seed=d.get("seed"),
        samples=int(d["samples"]),
        settings=dict(d.get("settings", {})),
        model_mass=float(d["model_mass_kg"]),
        true_mass=float(d["true_mass_kg"]),
        extra_masses=tuple(
            PlacedMass(str(e["body"]), float(e["mass_kg"]), tuple(e["offset_m"]))
            for e in d.get("extra_masses", [])
        ),
        body_names=bodies,
        joint_names=tuple(d["joint_names"]),
        r_true=_arr([d["r_true"][b] for b in bodies]),
        r_model=_arr([d["r_model"][b] for b in bodies]),
        pad_bias={k: _arr(v) for k, v in d.get("fsr_bias_N", {}).items()},
        pad_gain={k: _arr(v) for k, v in d.get("fsr_gain", {}).items()},
        pose=tuple(str(p) for p in d["pose"]),
        q_commanded=_arr(d["q_commanded"]),
        q_actual=_arr(d["q_actual"]),
        q_readback=_arr(d["q_readback"]),
        cop_true=_opt(d.get("cop_true")),
        cop_expected=_opt(d.get("cop_expected")),
        skipped=tuple((str(s["pose"]), str(s["reason"])) for s in d.get("skipped", [])),
        mount=_choice(d, "mount", "stand", BenchMount),
        grav=_opt(d.get("grav")),
        torque=torque,
        physics=physics,
        units=str(d.get("units", "m, kg, N, rad")),
    )


def load_truth(path: str | Path) -> Truth:
    """Read a truth file written by ``sescid experiment --truth`` (``Truth.load``)."""
    return Truth.load(path)


def settings_of(config, sensors) -> dict:
    """The bench settings a truth file records (``ExperimentConfig`` and the sensor file)."""
    tc = config.torque
    return {
        "extra_mass_fraction": config.extra_mass_fraction,
        "backlash_deg": config.backlash_deg,
        "readback_seen": config.readback_seen,
        "readback_jitter_ticks": config.readback_jitter_ticks,
        "fsr_noise_N": config.fsr_noise,
        "fsr_bias_N": config.fsr_bias,
        "fsr_gain": config.fsr_gain,
        "registers": config.registers,
        "sensors": sensors.source if sensors is not None else None,
        "double_support": config.double_support,
        "tilt_deg": config.tilt_deg,
        "mount": config.mount,
        "torque": {
            "joints": tc.joints if isinstance(tc.joints, str) else list(tc.joints),
            "noise_Nm": tc.noise,
            "offset_Nm": tc.offset,
            "gain": tc.gain,
            "friction_Nm": list(tc.friction),
            "approach": tc.approach,
        },
    }


def common_fields(robot: Robot, real: tuple, errors, run: tuple) -> dict:
    """The ``Truth`` fields every bench fills alike: ``real`` = (r_true, mass, placed) of
    ``real_robot``, ``errors`` the run's ``SensorErrors``, ``run`` = (seed, samples)."""
    r_true, mass, placed = real
    return {
        "robot": robot.source,
        "support": robot.support,
        "seed": run[0],
        "samples": run[1],
        "model_mass": robot.total_mass,
        "true_mass": mass,
        "extra_masses": tuple(
            PlacedMass(p["body"], p["mass_kg"], tuple(p["offset_m"])) for p in placed
        ),
        "body_names": tuple(robot.body_names),
        "joint_names": tuple(robot.joint_names),
        "r_true": np.asarray(r_true, dtype=float),
        "r_model": robot.sesc_vectors(),
        "pad_bias": dict(errors.pad_bias),
        "pad_gain": dict(errors.pad_gain),
    }


def torque_truth(errors, tau: np.ndarray, approach: np.ndarray, noise: float) -> TorqueTruth | None:
    """The torque sensors' truth from true torques (n, nq) [N·m] and approach sides (n,)."""
    if not errors.tau_joints:
        return None
    true = tau[:, errors.tau_index]
    expected = expected_torques(errors, tau, approach)
    return TorqueTruth(
        errors.tau_joints, true, expected, errors.tau_offset, errors.tau_gain,
        errors.tau_friction, np.asarray(approach, dtype=float), noise,
    )  # fmt: skip
