"""Per-sample centre of pressure of each foot, and of the feet together in the support frame.

Per sample, a foot's CoP in its sole frame is the force-weighted centroid of its pads,
``c = Σ F_k p_k / Σ F_k``, or, from the registers, the bilinear map of ``(X/254, Y/254)`` onto
the pad rectangle (the same point when the board computes the linear centroid), or the logged
CoP itself. A CoP foot with ``_fz`` is loaded where ``fz ≥ min_foot_force``; without it,
wherever its CoP is given (a NaN CoP is an unloaded foot), and it then carries no force, like
the registers. Each loaded foot's CoP is carried into the support frame with the model's pose of
its sole at the pose's mean joint read-backs; two loaded feet combine weighted by their total
forces (a source without a force can only stand alone).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from sescid.errors import DataError
from sescid.robot import Robot
from sescid.sensors.pads import Foot, SensorConfig
from sescid.sensors.raw import RawLog

#: rejection reasons, in the order they are tested (a sample counts under the first that applies)
REASONS = ("missing", "saturated", "no_load", "two_feet_no_force", "off_floor", "outlier")
#: a loaded foot whose sole the model puts this far off the support plane breaks CoP = CoM_xy
OFF_FLOOR_M = 0.010
OFF_FLOOR_TILT = math.radians(5.0)


class SampleStatus:
    """Per-sample status: −1 usable, else the index of the first reason in ``REASONS``."""

    def __init__(self, m: int):
        self.code = np.full(m, -1)

    def reject(self, mask: np.ndarray, reason: str) -> None:
        """Reject the still usable samples where ``mask`` under ``reason``."""
        self.code[(self.code < 0) & mask] = REASONS.index(reason)

    @property
    def ok(self) -> np.ndarray:
        """(m,) usable samples."""
        return self.code < 0


#: what the feet's sources give: forces (every source has its force), the centroid registers,
#: or a logged CoP without its force
FootMode = Literal["forces", "centroid", "cop"]


@dataclass(frozen=True)
class FootSamples:
    """Per-sample CoP of each foot with a source (sole frame), its weight and load."""

    feet: tuple[Foot, ...]
    local: tuple[np.ndarray, ...]  #: per foot (m, 2) CoP in the sole frame, m
    weight: np.ndarray  #: (m, feet) force N (mode "forces") or 1 per loaded foot
    loaded: np.ndarray  #: (m, feet) bool
    mode: FootMode


def source_mode(log: RawLog, feet: list[Foot]) -> FootMode:
    """The source mode: centroid (registers), cop (a logged CoP, no force) or forces."""
    if log.centroid:
        return "centroid"
    if any(log.cop_force.get(f.name) is None for f in feet if f.name in log.cop):
        return "cop"
    return "forces"


def foot_samples(log: RawLog, config: SensorConfig, status: SampleStatus) -> FootSamples:
    """Each foot's per-sample CoP and load; rejects missing, saturated and unloaded samples."""
    feet = [
        f
        for f in config.feet
        if f.name in log.forces or f.name in log.centroid or f.name in log.cop
    ]
    mode = source_mode(log, feet)
    local, force, loaded = [], [], []
    for foot in feet:
        if foot.name in log.forces:
            c, on, total = _pad_cop(foot, log.forces[foot.name], config, status)
        elif foot.name in log.centroid:
            arr = log.centroid[foot.name]
            status.reject(~np.all(np.isfinite(arr), axis=1), "missing")
            on = np.all(arr != config.no_load, axis=1) & np.all(np.isfinite(arr), axis=1)
            uv = np.clip(np.nan_to_num(arr) / config.centroid_max, 0.0, 1.0)
            c = foot.centroid_point(uv[:, 0], uv[:, 1])
            total = on.astype(float)
        else:
            c, on, total = _logged_cop(log, foot, config, status)
        # without a force for every source, one loaded foot only (weight 1)
        force.append(np.where(on, total, 0.0) if mode == "forces" else on.astype(float))
        local.append(c)
        loaded.append(on)
    load = np.stack(loaded, axis=1)
    status.reject(np.asarray(~load.any(axis=1)), "no_load")
    if mode != "forces":
        status.reject(load.sum(axis=1) > 1, "two_feet_no_force")
    return FootSamples(tuple(feet), tuple(local), np.stack(force, axis=1), load, mode)


#: loaded samples a pad must be judged on before it is called dead or stuck
DEAD_PAD_SAMPLES = 20


@dataclass
class _PadStats:
    """One foot's pads over the samples where the foot is loaded: how many samples, and per
    pad (4,) how many values, their least and greatest."""

    n: int
    count: np.ndarray
    lo: np.ndarray
    hi: np.ndarray


class PadWatch:
    """The dead or stuck foot pad check over a whole log, fed in parts (``add``, a log read in
    chunks) and judged once (``check``): a pad that has no value while its foot's other pads
    have, or reads one value while they vary, over every sample where its foot is loaded —
    its foot's CoP and load would be wrong without a word. (A pad that reads 0 through a pose
    whose CoP sits at the other edge is not dead: the whole log decides.)"""

    def __init__(self, config: SensorConfig):
        self.config = config
        self.stats: dict[str, _PadStats] = {}

    def add(self, log: RawLog) -> None:
        """Count the samples of ``log`` (a whole raw log or a part of one)."""
        for foot in self.config.feet:
            arr = log.forces.get(foot.name)
            if arr is None:
                continue
            on = np.nansum(arr, axis=1) * self.config.force_unit >= self.config.min_foot_force
            sub = arr[on]
            given = np.isfinite(sub)
            k = sub.shape[1]
            st = self.stats.setdefault(
                foot.name, _PadStats(0, np.zeros(k, int), np.full(k, np.inf), np.full(k, -np.inf))
            )
            st.n += len(sub)
            st.count += given.sum(axis=0)
            st.lo = np.minimum(st.lo, np.where(given, sub, np.inf).min(axis=0, initial=np.inf))
            st.hi = np.maximum(st.hi, np.where(given, sub, -np.inf).max(axis=0, initial=-np.inf))

    def check(self, path: object) -> None:
        """DataError naming the first dead or stuck pad of the samples added so far."""
        for foot in self.config.feet:
            st = self.stats.get(foot.name)
            if st is None or st.n < DEAD_PAD_SAMPLES:
                continue
            for k in range(len(st.count)):
                name = f"{foot.columns}{k + 1}"
                others = [j for j in range(len(st.count)) if j != k]
                if not st.count[k] and any(st.count[j] for j in others):
                    raise DataError(
                        f"{path}: column '{name}' has no value in the {st.n} samples where the "
                        f"{foot.name} foot is loaded: a dead pad? (its foot's CoP needs all four)"
                    )
                moving = [st.hi[j] > st.lo[j] for j in others if st.count[j]]
                if st.count[k] and st.hi[k] == st.lo[k] and moving and all(moving):
                    raise DataError(
                        f"{path}: column '{name}' reads {st.lo[k]:g} in all {st.count[k]} samples "
                        f"where the {foot.name} foot is loaded while its other pads vary: a dead, "
                        "stuck or never loaded pad? (its foot's CoP and load would be wrong)"
                    )


def check_pads(log: RawLog, config: SensorConfig) -> None:
    """``PadWatch``'s check of one whole raw log."""
    watch = PadWatch(config)
    watch.add(log)
    watch.check(log.path)


def _pad_cop(foot: Foot, arr: np.ndarray, config: SensorConfig, status: SampleStatus):
    """A board's per-sample CoP (m, 2), loaded (m,) and total force (m,) from its counts."""
    status.reject(~np.all(np.isfinite(arr), axis=1), "missing")
    status.reject(np.any(arr >= config.saturation, axis=1), "saturated")
    f = np.nan_to_num(arr) * config.force_unit
    on = f.sum(axis=1) >= config.min_foot_force  # on the raw readings
    f = np.where(on[:, None], foot.pad_forces(f), 0.0)
    total = f.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        c = (f @ foot.sensors) / np.where(on, total, 1.0)[:, None]
    return c, on, total


def _logged_cop(log: RawLog, foot: Foot, config: SensorConfig, status: SampleStatus):
    """A logged CoP (already in the sole frame): CoP (m, 2), loaded (m,), force (m,)."""
    arr = log.cop[foot.name]
    given = np.all(np.isfinite(arr), axis=1)
    fz = log.cop_force.get(foot.name)
    if fz is None:  # no force: loaded wherever the CoP is given
        on = given
        total = on.astype(float)
    else:
        with np.errstate(invalid="ignore"):
            status.reject(
                np.asarray(np.isnan(fz) | (~given & (fz > config.min_foot_force))), "missing"
            )
            on = given & (fz >= config.min_foot_force)
        total = np.nan_to_num(fz)
    return np.where(on[:, None], arr, 0.0), on, total


def support_cop(
    robot: Robot, fs: FootSamples, q_mean: np.ndarray, g: np.ndarray, status: SampleStatus
):
    """(m, 2) CoP of the loaded feet in the support frame and (m,) their total weight.

    Each foot's sole is placed by the model at its pose's mean read-backs ``q_mean`` (k, nq);
    a loaded foot the model puts off the floor rejects the sample (``off_floor``).
    """
    k, m = q_mean.shape[0], len(g)
    good_q = np.isfinite(q_mean).all(axis=1)
    cop = np.zeros((m, 2))
    for fi, foot in enumerate(fs.feet):
        rot = np.tile(np.eye(3), (k, 1, 1))
        org = np.zeros((k, 3))
        if good_q.any():
            rot[good_q], org[good_q] = robot.link_poses(q_mean[good_q], foot.sole_frame)
        tilt = np.arccos(np.clip(rot[:, 2, 2], -1.0, 1.0))
        off = (np.abs(org[:, 2]) > OFF_FLOOR_M) | (tilt > OFF_FLOOR_TILT)
        status.reject(fs.loaded[:, fi] & off[g], "off_floor")
        p = org[g, :2] + np.einsum("nij,nj->ni", rot[g, :2, :2], fs.local[fi])
        cop += fs.weight[:, fi : fi + 1] * p
    total = fs.weight.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cop /= np.where(total > 0, total, 1.0)[:, None]
    return cop, total
