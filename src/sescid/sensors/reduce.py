"""The reduction step (``sescid measure``, alias ``fsr``): a raw log → one measurement per pose.

Per pose: the mean joint read-backs, the mean CoP in the support frame with its standard error
(from the foot sensors, ``sensors.feet``), the mean joint torques ``tau_<joint>`` with their
standard errors and the ``approach`` side (``sensors.torque``), and the mean gravity direction.
Samples are rejected (with the reason counted, ``REASONS``) when a value is missing, a sensor is
saturated, no foot carries load, two feet are loaded but some source has no force to weight
them, a loaded foot is off the floor in the model, or the CoP or the force is an outlier by the
median/MAD rule ``|v − median| > k · max(1.4826 MAD, floor)``. A pose left with fewer than
``min_samples`` usable samples gets no measurement (listed in ``dropped``). Torques are
averaged per joint over the samples with read-backs: a missing torque or one that is an outlier
of its joint (the same rule) drops that value only (with tens of joints and a handful of samples
a whole-sample rule would reject almost every sample); a joint left with fewer than
``min_samples`` values at a pose has no torque there (NaN, not determined).

A log whose feet carry no load anywhere but that has torques (a robot held in a gantry) is
reduced on its torques alone (mode ``torque``), as is a log without foot-sensor columns.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from sescid.base import G0
from sescid.base.text import listed
from sescid.errors import DataError
from sescid.estimation.data.measurements import Measurements
from sescid.robot import Robot
from sescid.sensors.feet import (
    REASONS,
    PadWatch,
    SampleStatus,
    check_pads,
    foot_samples,
    support_cop,
)
from sescid.sensors.imu import imu_gravity_samples
from sescid.sensors.measured import Measured, MeasuredFrom
from sescid.sensors.pads import SensorConfig, check_sensors
from sescid.sensors.raw import RawLog, read_raw
from sescid.sensors.stats import PoseGroups
from sescid.sensors.torque import (
    TORQUE_OUTLIER_FLOOR,
    TORQUE_SE_FLOOR,
    check_torque_scale,
    pose_approach,
)
from sescid.tables import APPROACH_COLUMN, TAU_PREFIX, Table, pose_ids

#: outlier rule without a sensor file (a torque-only log)
DEFAULT_OUTLIER_K = 4.0
#: a foot's logged normal force beyond this multiple of the robot's weight is not in N
FORCE_WEIGHT_FACTOR = 5.0


@dataclass(frozen=True)
class _Samples:
    """The reduction's per-sample state: groups, status, mean read-backs."""

    groups: PoseGroups
    status: SampleStatus
    q_mean: np.ndarray  #: (k, nq)


def _start(log: RawLog) -> _Samples:
    groups = PoseGroups.of(log.pose)
    status = SampleStatus(len(groups.g))
    q_ok = np.all(np.isfinite(log.q), axis=1)  # mean read-backs where every joint is present
    q_mean = groups.mean(log.q, q_ok)
    status.reject(~q_ok, "missing")
    return _Samples(groups, status, q_mean)


def _cop_part(robot: Robot, log: RawLog, config: SensorConfig, s: _Samples):
    """Per-sample CoP (m, 2), total force (m,) and mode; marks CoP and force outliers."""
    fs = foot_samples(log, config, s.status)
    cop, total = support_cop(robot, fs, s.q_mean, s.groups.g, s.status)
    force_n = total if fs.mode == "forces" else np.full(len(total), np.nan)
    ok = s.status.ok
    out = np.zeros(len(ok), dtype=bool)
    for axis in range(2):
        out |= s.groups.outliers(cop[:, axis], ok, config.outlier_k, config.outlier_floor)
    if fs.mode == "forces":
        out |= s.groups.outliers(force_n, ok, config.outlier_k, config.outlier_floor_force)
    return cop, force_n, fs, out


def _cop_means(log, config, fs, cop, force_n, s: _Samples):
    """Per pose: mean CoP (k, 2), its standard error (k, 2) and mean force (k,)."""
    ok, groups = s.status.ok, s.groups
    n_used = groups.count(ok)
    mean = groups.mean(cop, ok)
    var = groups.variance(cop, ok, mean)
    fmean = groups.mean(np.nan_to_num(force_n)[:, None], ok)[:, 0]
    if fs.mode == "centroid":
        # quantisation: one register count along each support-frame axis (conservative)
        boards = [f for f in fs.feet if f.name in log.centroid]
        spans = [np.abs(f.sensors[[1, 2]] - f.sensors[0]).max(axis=0) for f in boards]
        step = np.array(spans).max(axis=0) / config.centroid_max
        var = var + step**2 / 12
    if fs.mode != "forces":
        fmean = np.full(groups.k, np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        se = np.maximum(np.sqrt(var / n_used[:, None]), 1e-7)
    return mean, se, fmean


def _tau_values(log: RawLog, s: _Samples, outlier_k: float) -> np.ndarray:
    """(m, t) torque values to average: read-backs present, the value given, not an outlier of
    its joint within its pose (a torque outlier drops that value only, not the sample)."""
    assert log.tau is not None
    q_ok = np.all(np.isfinite(log.q), axis=1)
    use = q_ok[:, None] & np.isfinite(log.tau)
    for j in range(log.tau.shape[1]):
        use[:, j] &= ~s.groups.outliers(log.tau[:, j], use[:, j], outlier_k, TORQUE_OUTLIER_FLOOR)
    return use


def _tau_means(log: RawLog, s: _Samples, use: np.ndarray, min_samples: int):
    """Per pose: mean torques (k, t) and standard errors (k, t) [N·m]; NaN for a joint with
    fewer than ``min_samples`` values at that pose (not determined)."""
    assert log.tau is not None
    k, t = s.groups.k, log.tau.shape[1]
    mean, se = np.full((k, t), np.nan), np.full((k, t), np.nan)
    for j in range(t):
        ok = use[:, j]
        col = log.tau[:, j : j + 1]
        m = s.groups.mean(col, ok)
        var = s.groups.variance(col, ok, m)
        n = s.groups.count(ok)
        enough = n >= min_samples
        mean[enough, j] = m[enough, 0]
        with np.errstate(invalid="ignore", divide="ignore"):
            se[enough, j] = np.maximum(np.sqrt(var[enough, 0] / n[enough]), TORQUE_SE_FLOOR)
    return mean, se


def _pose_gravity(log: RawLog, s: _Samples) -> np.ndarray | None:
    """(k, 3) mean gravity direction over the usable samples, renormalised."""
    if log.gravity is None:
        return None
    og = s.status.ok & np.all(np.isfinite(log.gravity), axis=1)
    g_sum = np.stack(
        [np.bincount(s.groups.g[og], log.gravity[og, a], minlength=s.groups.k) for a in range(3)],
        1,
    )
    with np.errstate(invalid="ignore", divide="ignore"):
        return g_sum / np.linalg.norm(g_sum, axis=1, keepdims=True)


#: a log whose every logged foot force stays below this share of the robot's weight never
#: carried the robot: its forces are not in N (kN?)
FORCE_WEIGHT_FLOOR = 0.02


def check_force_scale(
    log: RawLog, config: SensorConfig, mass: float, whole_log: bool = True
) -> None:
    """DataError naming row and column of a logged foot force beyond ``FORCE_WEIGHT_FACTOR`` ×
    the robot's weight (a force in mN or a wrong unit, not a standing robot), or naming the
    columns when no logged force of a ``whole_log`` without pads reaches ``FORCE_WEIGHT_FLOOR``
    × the weight (kN; a session's single pose may be unloaded)."""
    limit = FORCE_WEIGHT_FACTOR * mass * G0
    logged = {f.cop_prefix: log.cop_force.get(f.name) for f in config.feet}
    logged = {k: v for k, v in logged.items() if v is not None and np.isfinite(v).any()}
    peak = max((float(np.nanmax(np.abs(v))) for v in logged.values()), default=None)
    weight = mass * G0
    # pads may carry the robot while a lifted foot's F/T reads nothing (one foot's stance)
    pads = any(v is not None for d in (log.forces, log.centroid) for v in d.values())
    if whole_log and not pads and peak is not None and peak < FORCE_WEIGHT_FLOOR * weight:
        cols = ", ".join(f"'{k}_fz'" for k in logged)
        what = "column" if len(logged) == 1 else "columns"
        raise DataError(
            f"{log.path}: {what} {cols}: at most {peak:.3g} N over the whole log, while the "
            f"robot weighs {weight:.4g} N: not a force in N (kN?)"
        )
    for foot in config.feet:
        fz = log.cop_force.get(foot.name)
        if fz is None:
            continue
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(np.abs(fz) > limit)
        if bad.size:
            i = int(bad[0])
            raise DataError(
                f"{log.path}: {log.where(i)}, column '{foot.cop_prefix}_fz': "
                f"{fz[i]:g} N is more than {FORCE_WEIGHT_FACTOR:g}× the robot's weight "
                f"({limit / FORCE_WEIGHT_FACTOR:.4g} N): not a force in N"
            )


def uses_feet(log: RawLog, config: SensorConfig | None) -> bool:
    """Foot sensors give the CoP unless absent, or unloaded throughout a log with torques."""
    if config is None or not log.has_feet:
        return False
    if log.tau is None:
        return True
    probe = SampleStatus(len(log.pose))
    fs = foot_samples(log, config, probe)
    return bool(fs.loaded.any())


@dataclass(frozen=True)
class LogPart:
    """Where a reduced log sits in a longer one (``measure``; the default: a whole log).

    ``feet``: whether the foot sensors give the CoP (None: ``uses_feet`` of this log; a part
    of a longer log takes the whole log's answer). ``whole_log`` (not one of a session's
    poses): a dead or stuck foot pad is an error, and ``finish_measured`` may leave out a
    dead torque column. ``finish``: drop the poses whose torques, approach side or gravity the
    samples do not determine (``finish_measured``; a part of a longer log is finished once
    joined). ``pads``: a part of a longer log adds its samples to the whole log's dead-pad
    check instead of being judged alone.
    """

    feet: bool | None = None
    whole_log: bool = True
    finish: bool = True
    pads: PadWatch | None = None


#: a whole log, reduced and finished alone
WHOLE_LOG = LogPart()
#: one of a session's poses (its pads and torque columns judged over the session)
SESSION_POSE = LogPart(whole_log=False)


def measure(
    robot: Robot,
    log: RawLog,
    config: SensorConfig | None,
    min_samples: int = 5,
    part: LogPart = WHOLE_LOG,
) -> Measured:
    """Per-pose means and standard errors of a raw log (module docstring).

    Poses left with fewer than ``min_samples`` usable samples are listed in ``dropped`` with
    the reason. The foot poses come from ``robot.link_poses`` at each pose's mean read-backs.
    ``part``: where the log sits in a longer one (``LogPart``).
    """
    if min_samples < 2:
        raise DataError(f"min_samples must be ≥ 2 (a standard error needs 2), got {min_samples}")
    s = _start(log)
    feet = uses_feet(log, config) if part.feet is None else part.feet
    whole_log, pads = part.whole_log, part.pads
    out = np.zeros(len(log.pose), dtype=bool)
    mode: MeasuredFrom
    if feet:
        assert config is not None
        check_sensors(robot, config)
        check_force_scale(log, config, robot.total_mass, whole_log)
        if pads is not None:
            pads.add(log)
        elif whole_log:
            check_pads(log, config)
        cop, force_n, fs, out = _cop_part(robot, log, config, s)
        mode = fs.mode
    else:
        mode = "torque" if log.tau is not None else "imu"
    use = None
    if log.tau is not None:
        check_torque_scale(log, robot.total_mass)
        use = _tau_values(log, s, config.outlier_k if config is not None else DEFAULT_OUTLIER_K)
    s.status.reject(out, "outlier")
    groups, ok = s.groups, s.status.ok
    n_used = groups.count(ok)
    rejected = np.zeros((groups.k, len(REASONS)), dtype=int)
    np.add.at(rejected, (groups.g[~ok], s.status.code[~ok]), 1)
    keep = (n_used >= min_samples) & np.isfinite(s.q_mean).all(axis=1)
    if feet:
        mean, se, fmean = _cop_means(log, config, fs, cop, force_n, s)
    tau = tau_se = None
    if use is not None:
        tau, tau_se = _tau_means(log, s, use, min_samples)
    approach = None
    if log.approach is not None:
        approach = pose_approach(log.approach, groups.g, groups.k, log.path, log.where)
    grav = _pose_gravity(log, s)
    data = Measurements(
        q=s.q_mean,
        cop=mean if feet else None,
        cop_se=se if feet else None,
        tau=tau,
        tau_joints=log.tau_joints,
        tau_se=tau_se,
        approach=approach,
        gravity=grav,
        source=str(log.path),
    )
    m = Measured(
        pose=groups.ids,
        data=data,
        force=fmean if feet else np.full(groups.k, np.nan),
        n_used=n_used,
        rejected=rejected,
        dropped=_dropped(groups.ids, n_used, rejected, keep, min_samples),
        mode=mode,
    ).take(keep)
    return finish_measured(m, whole_log) if part.finish else m


def finish_measured(m: Measured, whole_log: bool = True) -> Measured:
    """Never a value the samples do not determine: with ``whole_log`` a torque column without
    a value at any pose (a dead sensor) and an approach column without one are left out, with
    a note; then a pose whose torques, approach side or gravity is not determined is dropped,
    with the reason (a session's single pose is dropped, its columns kept)."""
    notes = list(m.notes)
    data = m.data
    tau, tau_se, joints, approach = data.tau, data.tau_se, data.tau_joints, data.approach
    if tau is not None and tau_se is not None and whole_log and len(m.pose):
        dead = ~np.isfinite(tau).any(axis=0)
        if dead.any():
            gone = [j for j, d in zip(joints, dead, strict=True) if d]
            notes.append(
                f"no usable {', '.join(TAU_PREFIX + j for j in gone)} sample at any pose (a dead "
                "sensor?): left out"
            )
            joints = tuple(j for j, d in zip(joints, dead, strict=True) if not d)
            tau, tau_se = (tau[:, ~dead], tau_se[:, ~dead]) if joints else (None, None)
    if approach is not None and whole_log and len(m.pose) and not np.isfinite(approach).any():
        notes.append(f"no '{APPROACH_COLUMN}' value at any pose: left out")
        approach = None
    keep = np.ones(len(m.pose), dtype=bool)
    dropped = list(m.dropped)
    for what, values in (("joint torque", tau), (APPROACH_COLUMN, approach),
                         ("gravity", data.gravity)):  # fmt: skip
        if values is None:
            continue
        finite = np.isfinite(values) if values.ndim == 1 else np.isfinite(values).all(axis=1)
        for i in np.flatnonzero(keep & ~finite):
            dropped.append((str(m.pose[i]), _undetermined(what, values, int(i), joints)))
        keep &= finite
    data = dataclasses.replace(data, tau=tau, tau_se=tau_se, approach=approach, tau_joints=joints)
    return dataclasses.replace(m, data=data, dropped=dropped, notes=notes).take(keep)


def _undetermined(what: str, values: np.ndarray, i: int, joints) -> str:
    """Why pose ``i`` is dropped: which of its values the samples did not determine."""
    if what == "joint torque":
        bad = [TAU_PREFIX + j for j, v in zip(joints, values[i], strict=True) if not np.isfinite(v)]
        return f"too few usable samples of {', '.join(bad)} (a torque not determined)"
    if what == APPROACH_COLUMN:
        return f"no '{APPROACH_COLUMN}' value in its samples (the side it was reached from)"
    return "no usable gravity direction (grav_x/y/z or IMU) in its samples"


def _dropped(ids, n_used, rejected, keep, min_samples) -> list[tuple[str, str]]:
    out = []
    for i in np.flatnonzero(~keep):
        why = [f"{r}={int(c)}" for r, c in zip(REASONS, rejected[i], strict=True) if c]
        out.append(
            (
                str(ids[i]),
                f"{int(n_used[i])} usable of {int(n_used[i] + rejected[i].sum())} samples "
                f"(need {min_samples}; rejected: {', '.join(why) or 'none'})",
            )
        )
    return out


def check_pose_ids(measured_ids: np.ndarray, list_ids: np.ndarray, where: str) -> list[str]:
    """Error on ids measured but absent from the pose list; return the list's unmeasured ids."""
    known = set(list_ids.tolist())
    unknown = [p for p in dict.fromkeys(measured_ids.tolist()) if p not in known]
    if unknown:
        ids = listed((f"'{p}'" for p in unknown), first=1)
        raise DataError(f"{where}: pose id {ids} is not in the pose list")
    seen = set(measured_ids.tolist())
    return [p for p in list_ids.tolist() if p not in seen]


def pose_list_ids(table: Table) -> np.ndarray:
    """Pose ids of a pose list: its ``pose`` column, else the row numbers 0, 1, …"""
    if "pose" in table.columns or "pose" in table.text:
        ids = pose_ids(table)
        dup = [p for p in dict.fromkeys(ids.tolist()) if (ids == p).sum() > 1]
        if dup:
            raise DataError(f"{table.path}: pose id '{dup[0]}' appears twice")
        return ids
    return np.array([str(i) for i in range(table.n)])


def read_log(robot: Robot, table: Table, config: SensorConfig | None, imu_link: str | None = None):
    """The raw log of ``table`` as the reduction reads it, IMU gravity included."""
    log = read_raw(table, robot.joint_names, config, robot.profile.servo)
    if log.gravity is None:
        log = dataclasses.replace(log, gravity=imu_gravity_samples(robot, table, log.q, imu_link))
    return log


def fsr(
    robot: Robot,
    log_table: Table,
    config: SensorConfig | None,
    min_samples: int = 5,
    pose_list: Table | None = None,
    imu_link: str | None = None,
) -> tuple[Measured, list[str]]:
    """Reduce a raw log table per pose; with a ``pose_list`` table, check the ids against it.

    ``config`` None: a log without foot sensors (joint torques). Without ``grav_x/y/z``
    columns, ``imu_roll``/``imu_pitch`` of the IMU on ``imu_link`` (or the profile's) give the
    gravity direction per sample. Returns the result and the pose-list ids not measured.
    """
    log = read_log(robot, log_table, config, imu_link)
    unmeasured: list[str] = []
    if pose_list is not None:
        unmeasured = check_pose_ids(log.pose, pose_list_ids(pose_list), str(log_table.path))
    return usable(measure(robot, log, config, min_samples), log_table.path), unmeasured


def usable(res: Measured | None, where: object) -> Measured:
    """``res`` when it kept a pose; else a DataError naming ``where`` and the first reasons."""
    if res is None or len(res.pose) == 0:
        dropped = [] if res is None else res.dropped
        reasons = "; ".join(f"pose {p}: {w}" for p, w in dropped[:3])
        what = "CoP" if res is not None and res.data.cop is not None else "measurement"
        raise DataError(f"{where}: no pose has a usable {what} ({reasons})")
    return res
