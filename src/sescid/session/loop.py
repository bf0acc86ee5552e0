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
4. command it through the adapter (``session.adapters``), wait until settled (a pose the
   adapter reports as failed — fell, did not settle — is skipped and logged), read ``samples``
   samples, reduce them to one measurement per pose exactly as ``sescid measure`` does;
   with a ``Journal`` each pose is written to disk before the next is commanded (resumable);
5. update the online estimator (``estimation.OnlineEstimator``, weighted by the CoP standard
   errors, with the gravity direction the adapter logs (``grav_x/y/z``, or the IMU's roll/pitch
   on the profile's IMU link): at every step equal to the batch ``identify --weighted`` fit of
   the session's measured poses);
6. stop when **converged** — the predicted RMS CoP standard error over reference poses fell by
   less than ``tol`` (relative) over the last ``window`` measured poses, with at least
   ``min_measured`` poses — or when it reached ``target_std``, or when the ``budget`` of
   commanded poses (failed ones included) is spent.

The decisions depend only on the options and on the measurements, so replaying a session's raw
log (``ReplayAdapter``) or its journal makes the same decisions. Pose ids are "0", "1", … in
command order.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from sescid.base.columns import Table
from sescid.bench.real_robot import check_limits
from sescid.errors import DataError, OptionError, SescidError
from sescid.estimation import OnlineEstimator, min_poses
from sescid.planning import (
    candidates,
    cop_half_extents,
    identifiable_basis,
    projected_regressor,
)
from sescid.planning.sequential import SequentialDesign
from sescid.robot import Robot
from sescid.sensors import RawLog, SensorConfig, measure, read_log, table_from_columns
from sescid.session.adapters import RobotAdapter
from sescid.session.journal import Journal, JournalEntry, ResumingAdapter
from sescid.session.records import (
    BODY_PRIOR_SCALE,
    SessionObserver,
    SessionOptions,
    SessionResult,
    SessionStep,
)

__all__ = [
    "BODY_PRIOR_SCALE",
    "SessionObserver",
    "SessionOptions",
    "SessionResult",
    "SessionStep",
    "raw_table",
    "run_session",
]


def raw_table(cols: dict[str, np.ndarray]) -> Table:
    """In-memory raw-log table (as ``read_table`` gives it: numbers as float, text as text)."""
    return table_from_columns(cols, "session raw log")


def _read_log(robot: Robot, cols: dict[str, np.ndarray], sensors: SensorConfig) -> RawLog:
    """The raw log of these columns as ``sescid measure`` reads it (IMU gravity included)."""
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


def check_options(robot: Robot, opt: SessionOptions) -> int:
    """OptionError for options no session can run with; the least measured poses to stop."""
    need = min_poses(robot)
    if opt.budget < need:
        raise OptionError("budget", f"{opt.budget} poses cannot identify {robot.name}: ≥ {need}")
    if opt.samples < opt.min_samples or opt.min_samples < 2:
        raise OptionError("samples", f"need samples ≥ min_samples ≥ 2, got {opt.samples}")
    if opt.n_candidates < opt.budget:
        raise OptionError("n_candidates", f"must be ≥ the budget ({opt.budget})")
    if not (0 < opt.tol < 1 and 0 < opt.near <= 1 and opt.window >= 1):
        raise OptionError("tol", "need 0 < tol < 1, 0 < near ≤ 1 and window ≥ 1")
    return need if opt.min_measured is None else opt.min_measured


class _Run:
    """The state of one session between poses."""

    def __init__(self, robot: Robot, sensors, opt: SessionOptions, progress):
        self.robot, self.sensors, self.opt = robot, sensors, opt
        self.min_measured = check_options(robot, opt)
        self.half = (
            cop_half_extents(robot) if opt.half_extents is None else np.asarray(opt.half_extents)
        )
        self.cand = candidates(
            robot, opt.n_candidates, opt.seed, limits=opt.limits, half_extents=self.half,
            progress=progress,
        )  # fmt: skip
        self.basis = identifiable_basis(robot, self.cand.q)
        self.design = SequentialDesign(
            projected_regressor(robot, self.cand.q, self.basis), opt.near
        )
        self.est = OnlineEstimator(robot, window=opt.window, tol=opt.tol)
        self.steps: list[SessionStep] = []
        self.raw_parts: list[dict[str, np.ndarray]] = []
        self.names: list[str] | None = None
        self.q_cur = np.zeros(robot.nq)
        self.r_est: np.ndarray | None = None
        self.rejected: list[tuple[int, str]] = []

    def next_safe(self):
        """The next safe candidate (unsafe ones are logged and never commanded)."""
        while True:
            nxt = self.design.next(self.cand.q, self.q_cur)
            self.design.mark_tried(nxt.index)
            unsafe = _unsafe(self.robot, self.cand.q[nxt.index], self.half, self.r_est)
            if not unsafe:
                return nxt
            self.rejected.append((nxt.index, unsafe))

    def columns(self, pose: str, cols: dict) -> dict[str, np.ndarray]:
        """The pose's raw part (pose, sample, the adapter's columns), checked."""
        n = {len(np.atleast_1d(v)) for v in cols.values()}
        if len(n) != 1:
            raise DataError(f"pose {pose}: the adapter's columns differ in length ({n})")
        if self.names is None:
            self.names = list(cols)
        elif set(cols) != set(self.names):
            raise DataError(f"pose {pose}: the adapter changed its columns")
        m = n.pop()
        return {"pose": np.full(m, pose), "sample": np.arange(m)} | {
            c: np.asarray(cols[c]) for c in self.names
        }

    def measure(self, step: SessionStep, part: dict) -> bool:
        """Reduce the pose's samples and update the estimate; False when it gave no CoP."""
        robot, opt = self.robot, self.opt
        meas = measure(robot, _read_log(robot, part, self.sensors), self.sensors, opt.min_samples)
        if meas.cop is None or meas.cop_se is None:
            raise DataError(
                f"pose {step.pose}: the adapter logs no loaded foot sensor: a session measures "
                "the CoP (joint torques alone are recorded but not yet used to plan)"
            )
        if len(meas.pose) == 0:
            step.reason = meas.dropped[0][1] if meas.dropped else "no usable CoP"
            return False
        se = meas.cop_se[0]
        if not np.all(se > 0):
            step.reason = "CoP standard error is zero (identical samples): cannot weight"
            return False
        self.raw_parts.append(part)
        step.status = "measured"
        step.q_measured, step.cop, step.cop_se = meas.q[0], meas.cop[0], se
        if self.est.ne.n_poses:
            step.cop_predicted = robot.cop(meas.q, _estimate(self.est, self.basis), meas.gravity)[0]
        st = self.est.update(meas.q, meas.cop, meas.cop_se, meas.gravity)  # as identify does
        step.cop_std, step.rank = st.cop_std, st.rank
        step.converged = st.converged and st.n_poses >= self.min_measured
        step.body_std = _body_std(self.est, self.basis, len(robot.body_names))
        if st.rank >= self.basis.shape[1]:  # identified: check stability on the estimate too
            self.r_est = _estimate(self.est, self.basis)
        return True

    def stop_reason(self, step: SessionStep) -> str:
        """Why to stop after this measured pose ('' to go on)."""
        opt = self.opt
        if step.converged:
            return (
                f"converged: predicted CoP std {step.cop_std * 1e3:.3f} mm fell by less than "
                f"{opt.tol:.0%} over the last {opt.window} poses"
            )
        if opt.target_std is not None and step.cop_std <= opt.target_std:
            return f"predicted CoP std reached {opt.target_std * 1e3:g} mm"
        return ""

    def result(self, stop: str) -> SessionResult:
        """The session's result (DataError when no pose was measured)."""
        if self.est.ne.n_poses == 0:
            why = self.steps[0].reason if self.steps else "no pose commanded"
            raise DataError(f"the session measured no pose (first: {why})")
        raw = {k: np.concatenate([p[k] for p in self.raw_parts]) for k in self.raw_parts[0]}
        log = _read_log(self.robot, raw, self.sensors)
        return SessionResult(
            steps=self.steps,
            stop_reason=stop,
            fit=self.est.fit(),
            measured=measure(self.robot, log, self.sensors, self.opt.min_samples),
            raw=raw,
            poses=np.array([s.q for s in self.steps]),
            pose_ids=np.array([s.pose for s in self.steps]),
            candidates=self.cand,
            options=self.opt,
            body_names=list(self.robot.body_names),
            rejected=self.rejected,
        )


def run_session(
    robot: Robot,
    adapter: RobotAdapter,
    sensors: SensorConfig,
    options: SessionOptions | None = None,
    observer: SessionObserver | None = None,
    progress: Callable[[int, int], None] | None = None,
    journal: Journal | None = None,
) -> SessionResult:
    """Run a guided session (module docstring); ``progress`` follows the candidate sampling.

    ``journal``: write each pose to disk as it is done; the poses it already holds are
    replayed first (a resumed session), then the robot continues. Mark it ``finish``-ed once
    the result is saved.
    """
    opt = options or SessionOptions()
    obs = observer or SessionObserver()
    run = _Run(robot, sensors, opt, progress)
    bot = ResumingAdapter(journal, adapter) if journal is not None else adapter
    stop = f"budget of {opt.budget} poses spent"
    try:
        for k in range(opt.budget):
            try:
                nxt = run.next_safe()
            except SescidError as exc:
                stop = str(exc)
                break
            q, pose = run.cand.q[nxt.index], str(k)
            step = SessionStep(pose, nxt.index, q, nxt.gain, nxt.distance, "skipped")
            obs.planned(k, pose, q, run.q_cur)
            bot.move(pose, q)
            run.q_cur = q
            why = bot.wait_settled()
            cols = None if why else dict(bot.read(opt.samples))
            if journal is not None and not getattr(bot, "replaying", False):
                journal.append(JournalEntry(pose, q, why, cols))
            step.reason = why
            measured = cols is not None and run.measure(step, run.columns(pose, cols))
            if measured:
                run.design.add(nxt.index)
            run.steps.append(step)
            obs.finished_pose(step, run.steps)
            if measured and (reason := run.stop_reason(step)):
                stop = reason
                break
    finally:
        bot.stop()
    result = run.result(stop)
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
