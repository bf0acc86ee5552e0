"""Raw foot-pad logs → calibration sessions, and the calibrated sensor file (``sescid-fsr/2``).

``pad_session`` reduces a raw log (the table ``sescid fsr`` reads, with the four pad forces of
each foot) to per-pose mean pad readings in N, the mean joint read-backs, which feet carry
load and the mean gravity direction: the input of
``calibrate_sensors``. Samples with a missing or saturated value
are dropped; a loaded pad that reads 0 in some samples (censored at the floor, its mean
biased) takes the median of its samples, and poses where that happens in 40 % of the samples
or more are dropped; a foot is loaded at a pose
when its mean total reading reaches the configuration's ``min_foot_force``.
``calibrated_sensor_document`` writes the layout back with the estimated gains and one
session's offsets, which ``load_sensors`` reads and ``fsr`` applies.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sescid.base.files import read_json
from sescid.errors import DataError
from sescid.robot import Robot
from sescid.sensors.calibration.model import PadFoot, PadSession, SensorCalibration
from sescid.sensors.pads import FSR_FORMAT, FSR_FORMAT_2, SensorConfig, check_sensors
from sescid.sensors.raw import read_raw
from sescid.sensors.stats import PoseGroups
from sescid.tables import Table

#: a pose is dropped when this share of its samples has a loaded pad reading 0 (censored);
#: below it, such a pad's reading is the median of its samples (unbiased by the floor)
FLOOR_SHARE = 0.4


@dataclass(frozen=True)
class PadSessionOptions:
    """How a raw log becomes a calibration session."""

    sensors: str = "default"  #: sensor set: sessions with the same label share the gains
    min_samples: int = 5  #: complete samples a pose needs
    noise_force: float | None = None  #: N, σ of the force rows (None: estimated)
    noise_cop: float | None = None  #: m, σ of the moment rows (None: estimated)


def pad_session(
    robot: Robot,
    table: Table,
    config: SensorConfig,
    name: str,
    options: PadSessionOptions | None = None,
) -> PadSession:
    """Per-pose mean pad readings (N), read-backs and loaded feet of a raw log (module doc)."""
    opt = options or PadSessionOptions()
    check_sensors(robot, config)
    log = read_raw(table, robot.joint_names, config, robot.profile.servo)
    if log.centroid or log.cop or not log.forces:
        raise DataError(
            f"{table.path}: calibration needs the four pad forces of each foot "
            "(<prefix>1..4), not centroid registers or a logged CoP"
        )
    groups = PoseGroups.of(log.pose)
    g, k = groups.g, groups.k
    feet = [f for f in config.feet if f.name in log.forces]
    ok = np.all(np.isfinite(log.q), axis=1)
    for f in feet:
        arr = log.forces[f.name]
        ok &= np.all(np.isfinite(arr), axis=1) & np.all(arr < config.saturation, axis=1)
    count = groups.count(ok)
    keep = count >= opt.min_samples
    if not keep.any():
        raise DataError(f"{table.path}: no pose has {opt.min_samples} complete samples")

    # a pad at its floor (0) while its foot is loaded is censored: its mean is biased upward;
    # the median is not while under half the samples floor, so such pads take the median and
    # poses where a loaded pad floors in FLOOR_SHARE of the samples or more are dropped
    out, fixes = [], []
    floored: list[tuple[int, str]] = []  # (poses dropped, the pad's column) per pad
    for f in feet:
        arr = np.nan_to_num(log.forces[f.name]) * config.force_unit
        on = ok & (arr.sum(axis=1) >= config.min_foot_force)
        y = groups.mean(arr, ok)
        hit = on[:, None] & (arr <= 0)
        hits = np.stack([np.bincount(g[hit[:, j]], minlength=k) for j in range(4)], 1)
        share = hits / np.maximum(count, 1)[:, None]
        keep &= ~np.any(share >= FLOOR_SHARE, axis=1)
        floored += [(int(np.sum(share[:, j] >= FLOOR_SHARE)), f"{f.columns}{j + 1}")
                    for j in range(4)]  # fmt: skip
        for i, j in zip(*np.nonzero((share > 0) & (share < FLOOR_SHARE)), strict=True):
            y[i, j] = float(np.median(arr[ok & (g == i), j]))  # few (pose, pad) pairs
        fixes.append(y)
    if not keep.any():
        n_dropped, pad = max(floored)
        raise DataError(
            f"{table.path}: every pose has a loaded pad reading 0 too often: column '{pad}' "
            f"reads 0 in {n_dropped} of {k} poses while its foot is loaded (a dead pad?)"
        )
    q = groups.mean(log.q, ok)[keep]
    for f, y in zip(feet, fixes, strict=True):
        y = y[keep]
        loaded = y.sum(axis=1) >= config.min_foot_force
        out.append(PadFoot(f.name, f.sole_frame, f.sensors.copy(), y, loaded))
    grav = None
    if log.gravity is not None:
        gm = groups.mean(np.nan_to_num(log.gravity), ok)[keep]
        grav = gm / np.linalg.norm(gm, axis=1, keepdims=True)
    return PadSession(
        name=name,
        q=q,
        feet=tuple(out),
        gravity=grav,
        sensors=opt.sensors,
        noise_force=opt.noise_force,
        noise_cop=opt.noise_cop,
    )


def calibrated_sensor_document(
    source: str | Path, calibration: SensorCalibration, session: str, sensors: str = "default"
) -> dict:
    """The sensor file ``source`` (sescid-fsr/1 or /2) with the calibration's gains (sensor set
    ``sensors``) and ``session``'s offsets: format ``sescid-fsr/2``."""
    data = copy.deepcopy(read_json(source, (FSR_FORMAT, FSR_FORMAT_2), "a sensor configuration"))
    names = [s.name for s in calibration.sessions]
    if session not in names:
        raise DataError(f"no session '{session}' in the calibration (sessions: {names})")
    data["format"] = FSR_FORMAT_2
    cal_feet = {}
    for foot_name, f in data.get("feet", {}).items():
        gains, gstd = calibration.gain(sensors, foot_name)
        if gains.size != 4:
            raise DataError(f"the calibration has no gains for the {foot_name} foot")
        # offsets: the chosen session's, else the last session that loads this foot
        source_session = None
        for name in [session] + names[::-1]:
            offs, ostd = calibration.offset(name, foot_name)
            if offs.size == 4:
                source_session = name
                break
        if source_session is None:
            offs, ostd = np.zeros(4), np.full(4, calibration.offset_prior)
        f["gains"] = [float(v) for v in gains]
        f["offsets_N"] = [float(v) for v in offs]
        cal_feet[foot_name] = {
            "gains_std": [float(v) for v in gstd],
            "offsets_std_N": [float(v) for v in ostd],
            "offsets_from_session": source_session,
        }
    unseen = [
        {"kind": d.kind, "direction": d.label(), "reason": d.reason}
        for d in calibration.unidentifiable
    ]
    data["calibration"] = {
        "model": "reading = force / gain + offset (N); fsr uses force = gain (reading - offset)",
        "offsets_from_session": session,
        "sensor_set": sensors,
        "total_mass_kg": calibration.total_mass,
        "total_mass_by": calibration.total_mass_by,
        "sessions": [
            {
                "name": s.name,
                "poses": s.poses,
                "share": s.share,
                "noise_force_N": s.noise_force,
                "noise_cop_m": s.noise_cop,
            }
            for s in calibration.sessions
        ],
        "feet": cal_feet,
        "unidentifiable": unseen,
        "note": "offsets drift between days: re-run a short session and recalibrate the offsets",
    }
    return data
