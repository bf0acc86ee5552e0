"""A guided identification session: next-best pose, measure, update, stop when converged.

Loop (``run_session``):

1. once: stable, ground-clear, collision-free candidate poses (``planning.candidates``) and their
   x/y regressor projected on the identifiable subspace;
2. plan: the next pose by sequential D-optimal design near the current pose
   (``planning.sequential``: the nearest of the candidates whose information gain is at least
   ``near`` × the best);
3. safety, before every command: the pose is within the joint limits and statically stable —
   the model's CoP and, once every identifiable combination is determined, the current
   estimate's CoP inside the stability box; a pose that fails is never commanded (logged in
   ``rejected``, not counted in the budget) and the next candidate is taken;
4. command it through the adapter (``experiment.adapters``), wait until settled (a pose the
   adapter reports as failed — fell, did not settle — is skipped and logged), read ``samples``
   samples, reduce them to one CoP per pose exactly as ``sescid fsr`` does (``measure``);
5. update the online estimator (``estimation.OnlineEstimator``, weighted by the CoP standard
   errors, with the gravity direction the adapter logs (``grav_x/y/z``, or the IMU's roll/pitch
   on the profile's IMU link): at every step equal to the batch ``identify --weighted`` fit of
   the session's measured poses);
6. stop when **converged** — the predicted RMS CoP standard error over reference poses fell by
   less than ``tol`` (relative) over the last ``window`` measured poses, with at least
   ``min_measured`` poses — or when it reached ``target_std``, or when the ``budget`` of
   commanded poses (failed ones included) is spent.

The decisions depend only on the options and on the measurements, so replaying a session's raw
log (``ReplayAdapter``) makes the same decisions. Pose ids are "0", "1", … in command order.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from sescid.base.columns import Table
from sescid.bench.kinematic import check_limits
from sescid.errors import DataError, OptionError, SescidError
from sescid.estimation import OnlineEstimator, min_poses
from sescid.estimation.fit import Fit
from sescid.planning import (
    Candidates,
    candidates,
    cop_half_extents,
    identifiable_basis,
    projected_regressor,
)
from sescid.planning.sequential import SequentialDesign
from sescid.robot import Robot
from sescid.sensors import Measured, RawLog, SensorConfig, measure, read_log, table_from_columns
from sescid.session.adapters import RobotAdapter

#: m, prior scale of a body's SESC components, for the per-body uncertainty shown (0..1 scale)
BODY_PRIOR_SCALE = 0.005


@dataclass(frozen=True)
class SessionOptions:
    """How a guided session plans, measures and stops (SI units, radians)."""

    budget: int = 60  #: poses commanded at most (failed ones count)
    samples: int = 100  #: samples read per pose
    min_samples: int = 5  #: usable samples a pose needs (as ``sescid fsr``)
    n_candidates: int = 5000  #: stable, collision-free candidate poses to choose from
    seed: int = 0  #: candidate sampling
    near: float = 0.8  #: take the nearest candidate whose gain is ≥ near × the best gain
    window: int = 10  #: convergence: measured poses looked back
    tol: float = 0.10  #: convergence: relative fall of the predicted CoP std over the window
    min_measured: int | None = None  #: at least this many measured poses (None: the rank's min)
    target_std: float | None = None  #: m, also stop when the predicted CoP std reaches this
    limits: np.ndarray | None = None  #: (nq, 2) sampling limits, rad (None: the robot's)
    half_extents: np.ndarray | None = None  #: (2,) CoP stability box, m (None: the profile's)


@dataclass
class SessionStep:
    """One commanded pose: the decision, and what was measured (or why not)."""

    pose: str  #: id, "0", "1", … in command order
    candidate: int  #: index in the candidate pool
    q: np.ndarray  #: (nq,) commanded, rad
    gain: float  #: log det rise expected from this pose
    distance: float  #: rad, joint-space distance from the previous pose
    status: str  #: "measured" or "skipped"
    reason: str = ""  #: why skipped
    q_measured: np.ndarray | None = None  #: (nq,) mean read-backs, rad
    cop: np.ndarray | None = None  #: (2,) measured CoP, m
    cop_se: np.ndarray | None = None  #: (2,) its standard error, m
    cop_predicted: np.ndarray | None = None  #: (2,) predicted before this pose was added, m
    cop_std: float = math.inf  #: predicted RMS CoP std after this pose, m
    rank: int = 0
    converged: bool = False
    body_std: np.ndarray | None = None  #: (N,) per-body SESC std after this pose, m


@dataclass
class SessionResult:
    """What a session did and found; ``raw`` and ``poses`` are the files' columns."""

    steps: list[SessionStep]
    stop_reason: str
    fit: Fit
    measured: Measured
    raw: dict[str, np.ndarray]  #: the raw log (pose, sample, the adapter's columns)
    poses: np.ndarray  #: (k, nq) commanded poses, rad, in command order
    pose_ids: np.ndarray  #: (k,) their ids
    candidates: Candidates
    options: SessionOptions
    body_names: list[str] = field(default_factory=list)
    #: (candidate, why) chosen but found unsafe before commanding (not counted in the budget)
    rejected: list[tuple[int, str]] = field(default_factory=list)

    @property
    def n_measured(self) -> int:
        """Poses measured (not skipped)."""
        return sum(s.status == "measured" for s in self.steps)

    @property
    def cop_std(self) -> float:
        """Predicted RMS CoP std at the end, m."""
        done = [s.cop_std for s in self.steps if s.status == "measured"]
        return done[-1] if done else math.inf


class SessionObserver:
    """Hooks a session calls (all optional to override): a terminal printer, a live view."""

    def planned(self, step_no: int, pose: str, q: np.ndarray, q_current: np.ndarray) -> None:
        """The next pose was chosen (before it is commanded)."""

    def finished_pose(self, step: SessionStep, steps: list[SessionStep]) -> None:
        """A pose was measured or skipped."""

    def stopped(self, result: SessionResult) -> None:
        """The session ended."""


def raw_table(cols: dict[str, np.ndarray]) -> Table:
    """In-memory raw-log table (as ``read_table`` gives it: numbers as float, text as text)."""
    return table_from_columns(cols, "session raw log")


def _read_log(robot: Robot, cols: dict[str, np.ndarray], sensors: SensorConfig) -> RawLog:
    """The raw log of these columns as ``sescid fsr`` reads it (IMU gravity included)."""
    return read_log(robot, raw_table(cols), sensors)


def _body_std(est: OnlineEstimator, basis: np.ndarray, n_bodies: int) -> np.ndarray:
    """(N,) RMS SESC std per body [m] over the identifiable directions (prior scale τ)."""
    s = est.history[-1].noise if est.history else 1.0
    s = s if math.isfinite(s) and s > 0 else 1.0
    h = basis.T @ est.ne.ata @ basis / s**2 + np.eye(basis.shape[1]) / BODY_PRIOR_SCALE**2
    cov = basis @ np.linalg.inv(h) @ basis.T
    return np.sqrt(np.maximum(np.diag(cov).reshape(n_bodies, 3).sum(axis=1), 0.0))


def _estimate(est: OnlineEstimator, basis: np.ndarray) -> np.ndarray:
    """(N, 3) least-squares SESC vectors in the identifiable subspace, the rest from the prior.

    The directions the poses so far leave undetermined keep the prior (minimum-norm step); the
    CoP it predicts equals the batch fit's once every identifiable combination is determined.
    """
    x0 = est.r_prior.reshape(-1)
    h = basis.T @ est.ne.ata @ basis
    g = basis.T @ (est.ne.atb - est.ne.ata @ x0)
    return (x0 + basis @ (np.linalg.pinv(h, rcond=1e-10, hermitian=True) @ g)).reshape(-1, 3)


def run_session(
    robot: Robot,
    adapter: RobotAdapter,
    sensors: SensorConfig,
    options: SessionOptions | None = None,
    observer: SessionObserver | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> SessionResult:
    """Run a guided session (module docstring); ``progress`` follows the candidate sampling."""
    opt = options or SessionOptions()
    obs = observer or SessionObserver()
    need = min_poses(robot)
    min_measured = need if opt.min_measured is None else opt.min_measured
    if opt.budget < need:
        raise OptionError("budget", f"{opt.budget} poses cannot identify {robot.name}: ≥ {need}")
    if opt.samples < opt.min_samples or opt.min_samples < 2:
        raise OptionError("samples", f"need samples ≥ min_samples ≥ 2, got {opt.samples}")
    if opt.n_candidates < opt.budget:
        raise OptionError("n_candidates", f"must be ≥ the budget ({opt.budget})")
    half = cop_half_extents(robot) if opt.half_extents is None else np.asarray(opt.half_extents)
    cand = candidates(
        robot, opt.n_candidates, opt.seed, limits=opt.limits, half_extents=half, progress=progress
    )
    basis = identifiable_basis(robot, cand.q)
    design = SequentialDesign(projected_regressor(robot, cand.q, basis), opt.near)
    est = OnlineEstimator(robot, window=opt.window, tol=opt.tol)
    n_bodies = len(robot.body_names)
    steps: list[SessionStep] = []
    raw_parts: list[dict[str, np.ndarray]] = []
    names: list[str] | None = None
    q_cur = np.zeros(robot.nq)
    r_est: np.ndarray | None = None
    rejected: list[tuple[int, str]] = []
    stop = f"budget of {opt.budget} poses spent"
    try:
        for k in range(opt.budget):
            try:
                while True:  # the next safe candidate; unsafe ones are never commanded
                    nxt = design.next(cand.q, q_cur)
                    design.mark_tried(nxt.index)
                    unsafe = _unsafe(robot, cand.q[nxt.index], half, r_est)
                    if not unsafe:
                        break
                    rejected.append((nxt.index, unsafe))
            except SescidError as exc:
                stop = str(exc)
                break
            q = cand.q[nxt.index]
            pose = str(k)
            step = SessionStep(pose, nxt.index, q, nxt.gain, nxt.distance, "skipped")
            obs.planned(k, pose, q, q_cur)
            adapter.move(pose, q)
            q_cur = q
            why = adapter.wait_settled()
            if why:
                step.reason = why
                steps.append(step)
                obs.finished_pose(step, steps)
                continue
            cols = dict(adapter.read(opt.samples))
            n = {len(np.atleast_1d(v)) for v in cols.values()}
            if len(n) != 1:
                raise DataError(f"pose {pose}: the adapter's columns differ in length ({n})")
            if names is None:
                names = list(cols)
            elif set(cols) != set(names):
                raise DataError(f"pose {pose}: the adapter changed its columns")
            m = n.pop()
            part = {"pose": np.full(m, pose), "sample": np.arange(m)} | {c: cols[c] for c in names}
            log = _read_log(robot, part, sensors)
            meas = measure(robot, log, sensors, opt.min_samples)
            if meas.cop is None or meas.cop_se is None:
                raise DataError(
                    f"pose {pose}: the adapter logs no loaded foot sensor: a session measures "
                    "the CoP (joint torques alone are recorded but not yet used to plan)"
                )
            if len(meas.pose) == 0:
                step.reason = meas.dropped[0][1] if meas.dropped else "no usable CoP"
                steps.append(step)
                obs.finished_pose(step, steps)
                continue
            se = meas.cop_se[0]
            if not np.all(se > 0):
                step.reason = "CoP standard error is zero (identical samples): cannot weight"
                steps.append(step)
                obs.finished_pose(step, steps)
                continue
            raw_parts.append(part)
            step.status = "measured"
            step.q_measured, step.cop, step.cop_se = meas.q[0], meas.cop[0], se
            if est.ne.n_poses:
                step.cop_predicted = robot.cop(meas.q, _estimate(est, basis), meas.gravity)[0]
            st = est.update(meas.q, meas.cop, meas.cop_se, meas.gravity)  # as identify does
            design.add(nxt.index)
            step.cop_std, step.rank = st.cop_std, st.rank
            step.converged = st.converged and st.n_poses >= min_measured
            step.body_std = _body_std(est, basis, n_bodies)
            if st.rank >= basis.shape[1]:  # identified: check stability on the estimate too
                r_est = _estimate(est, basis)
            steps.append(step)
            obs.finished_pose(step, steps)
            if step.converged:
                stop = (
                    f"converged: predicted CoP std {st.cop_std * 1e3:.3f} mm fell by less than "
                    f"{opt.tol:.0%} over the last {opt.window} poses"
                )
                break
            if opt.target_std is not None and st.cop_std <= opt.target_std:
                stop = f"predicted CoP std reached {opt.target_std * 1e3:g} mm"
                break
    finally:
        adapter.stop()
    if est.ne.n_poses == 0:
        why = steps[0].reason if steps else "no pose commanded"
        raise DataError(f"the session measured no pose (first: {why})")
    raw = {k: np.concatenate([p[k] for p in raw_parts]) for k in raw_parts[0]}
    log = _read_log(robot, raw, sensors)
    result = SessionResult(
        steps=steps,
        stop_reason=stop,
        fit=est.fit(),
        measured=measure(robot, log, sensors, opt.min_samples),
        raw=raw,
        poses=np.array([s.q for s in steps]),
        pose_ids=np.array([s.pose for s in steps]),
        candidates=cand,
        options=opt,
        body_names=list(robot.body_names),
        rejected=rejected,
    )
    obs.stopped(result)
    return result


def _unsafe(robot: Robot, q: np.ndarray, half: np.ndarray, r_est: np.ndarray | None) -> str:
    """Why ``q`` must not be commanded ('' when it is within limits and statically stable).

    Stable: the model's CoP, and once every identifiable combination is determined the current
    estimate's CoP too, strictly inside the stability box ``half``.
    """
    try:
        check_limits(robot, q[None], "command")
    except DataError as exc:
        return str(exc)
    for what, r in (("model", None), ("identified", r_est)):
        if what == "identified" and r is None:
            continue
        cop = robot.cop(q[None], r)[0]
        if np.any(np.abs(cop) >= half):
            return (
                f"unstable: {what} CoP ({cop[0] * 1e3:.1f}, {cop[1] * 1e3:.1f}) mm outside "
                f"±({half[0] * 1e3:.1f}, {half[1] * 1e3:.1f}) mm; not commanded"
            )
    return ""
