"""A guided identification session: next-best pose, measure, update, stop when converged.

Loop (``run_session``):

1. once: candidate poses — stable on the support foot, ground-clear and collision-free
   (``planning.candidates``), or for a robot held in a gantry clear of the floor and of itself
   (``planning.gantry``) — and the sequential design for the kinds the robot reports
   (``session.design``: the CoP's two rows, or joint torques with an offset each, or both);
2. plan: the next pose by sequential D-optimal design near the current pose
   (``planning.sequential``: the nearest of the candidates whose information gain is at least
   ``near`` × the best);
3. safety, before every command: the pose is within the joint limits and statically stable —
   the model's CoP and, once every identifiable combination is determined, the current
   estimate's CoP inside the stability box (a held robot: the limits only); a pose that fails
   is never commanded (logged in ``rejected``, not counted in the budget) and the next
   candidate is taken;
4. command it through the adapter (``session.adapters``), wait until settled (a pose the
   adapter reports as failed — fell, did not settle — is skipped and logged), read ``samples``
   samples, reduce them to one measurement per pose exactly as ``sescid measure`` does;
   with a ``Journal`` each pose is written to disk before the next is commanded (resumable);
5. update the estimate (``session.estimate``): a CoP session's online estimator
   (``estimation.OnlineEstimator``, weighted by the CoP standard errors, with the gravity
   direction the adapter logs: at every step equal to ``identify --weighted``), or, with joint
   torques, ``identify --weighted`` itself on the poses so far;
6. stop when **converged** — the predicted RMS standard error over reference poses of the CoP
   (of the CoM x/y with torques) fell by less than ``tol`` (relative) over the last ``window``
   measured poses, with at least ``min_measured`` poses — or when it reached ``target_std``,
   or when the ``budget`` of commanded poses (failed ones included) is spent.

The decisions depend only on the options and on the measurements, so replaying a session's raw
log (``ReplayAdapter``) or its journal makes the same decisions. Pose ids are "0", "1", … in
command order.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sescid.errors import DataError, OptionError, SescidError
from sescid.estimation import check_total_mass, min_poses
from sescid.kinds import COP, TORQUE, Kinds
from sescid.planning.design.sequential import SequentialDesign
from sescid.robot import Robot
from sescid.sensors import SESSION_POSE, SensorConfig, measure
from sescid.session.adapters import RobotAdapter
from sescid.session.design import SessionDesign, session_mount, unsafe_pose
from sescid.session.estimate import BatchEstimate, CopEstimate, pose_measurements
from sescid.session.journal import Journal, JournalEntry, ResumingAdapter
from sescid.session.records import (
    BODY_PRIOR_SCALE,
    SessionObserver,
    SessionOptions,
    SessionResult,
    SessionStep,
)
from sescid.session.samples import (
    adapter_call,
    kept_on_error,
    pose_columns,
    raw_log,
    read_samples,
    samples_source,
)
from sescid.session.stances import PooledEstimate, StanceDesign, stance_result

__all__ = [
    "BODY_PRIOR_SCALE",
    "SessionObserver",
    "SessionOptions",
    "SessionResult",
    "SessionStep",
    "run_session",
]


def check_options(robot: Robot, opt: SessionOptions) -> int:
    """OptionError for options no session can run with; the least measured poses to stop."""
    if opt.stances:
        if len(opt.stances) < 2:
            raise OptionError("stances", "a session over stances needs two or more (one stance "
                              "is the support and its mount)")  # fmt: skip
        if opt.mount is not None:
            raise OptionError("mount", "over stances each stance names its mount")
        mount, kinds = "stances", (COP, TORQUE)
    else:
        mount, kinds = session_mount(robot, opt)
    need = min_poses(robot) if kinds == (COP,) else 2
    if opt.budget < need:
        raise OptionError("budget", f"{opt.budget} poses cannot identify {robot.name}: ≥ {need}")
    if opt.samples < opt.min_samples:
        raise OptionError("samples", f"need samples ≥ min_samples, got {opt.samples}")
    if opt.n_candidates < opt.budget:
        raise OptionError("n_candidates", f"must be ≥ the budget ({opt.budget})")
    if opt.total_mass is not None:
        check_total_mass(robot, opt.total_mass)
    return need if opt.min_measured is None else opt.min_measured


class _Run:
    """The state of one session between poses."""

    def __init__(self, robot: Robot, sensors, opt: SessionOptions, progress):
        self.robot, self.sensors, self.opt = robot, sensors, opt
        self.min_measured = check_options(robot, opt)
        self.multi = bool(opt.stances)
        self.plan: SessionDesign | StanceDesign = (
            StanceDesign(robot, opt, progress)
            if self.multi
            else SessionDesign(robot, opt, progress)
        )
        self.cand, self.half = self.plan.cand, self.plan.half
        self.est: CopEstimate | BatchEstimate | PooledEstimate | None = None
        self.stance: int | None = None  #: over stances: the stance the robot is in
        self.measured: list[int] = []  #: pool indices of the measured poses
        self.steps: list[SessionStep] = []
        self.raw_parts: list[dict[str, np.ndarray]] = []
        self.names: list[str] | None = None
        self.q_cur = np.zeros(robot.nq)
        self.r_est: np.ndarray | None = None
        self.rejected: list[tuple[int, str]] = []
        self.source = "session raw log"  #: where the current pose's samples came from

    @property
    def design(self) -> SequentialDesign:
        """The sequential design for the kinds planned for now."""
        return self.plan.design

    def next_safe(self):
        """The next safe candidate (unsafe ones are logged and never commanded)."""
        while True:
            if isinstance(self.plan, StanceDesign):
                nxt = self.plan.next(self.q_cur, self.stance)
                k = self.plan.stance_of(nxt.index)
                r = None
                if isinstance(self.est, PooledEstimate) and self.r_est is not None:
                    r = self.est.estimate(k)
                self.design.mark_tried(nxt.index)
                unsafe = self.plan.unsafe(nxt.index, r)
            else:
                nxt = self.design.next(self.cand.q, self.q_cur)
                self.design.mark_tried(nxt.index)
                q = self.cand.q[nxt.index]
                unsafe = unsafe_pose(
                    self.robot, q, self.half, self.r_est, self.plan.mount == "gantry"
                )
            if not unsafe:
                return nxt
            self.rejected.append((nxt.index, unsafe))

    def robot_at(self, i: int) -> Robot:
        """The robot as it stands for candidate ``i`` (its stance's, over stances)."""
        if isinstance(self.plan, StanceDesign):
            return self.plan.robots[self.plan.stance_of(i)]
        return self.robot

    def columns(self, pose: str, cols: dict, source: str) -> dict[str, np.ndarray]:
        """The pose's raw part (pose, sample, the adapter's columns), checked; ``source``
        (the adapter or the journal) names where the samples came from in the errors."""
        arrays = pose_columns(f"{source}: pose {pose}", cols, self.names)
        if self.names is None:
            self.names = list(arrays)
        m = len(next(iter(arrays.values())))
        self.source = source
        out = {"pose": np.full(m, pose), "sample": np.arange(m)}
        if isinstance(self.plan, StanceDesign) and self.stance is not None:
            out["support"] = np.full(m, self.plan.stances[self.stance].label)
        return out | {c: arrays[c] for c in self.names}

    def _kinds(self, meas, step: SessionStep) -> Kinds:
        """The kinds this pose measured for the session; at the first measured pose the
        estimator is made and the design switched to them (``SessionDesign.switch``)."""
        d = meas.data
        has_cop, has_tau = d.cop is not None and d.cop_se is not None, d.tau is not None
        if isinstance(self.plan, StanceDesign):
            assert self.stance is not None
            kinds = self.plan.measured_kinds(has_cop, has_tau, step.pose, self.stance)
            if self.est is None:
                self.plan.switch(kinds, self.measured)
                self.est = PooledEstimate(self.plan, self.plan.kinds, self.opt.window, self.opt.tol)
            return self.plan.kinds
        kinds = self.plan.measured_kinds(has_cop, has_tau, step.pose)
        if self.est is None:
            self.plan.switch(kinds, self.measured)
            window, tol = self.opt.window, self.opt.tol
            if kinds == (COP,):
                self.est = CopEstimate(self.robot, self.plan.basis, window, tol)
            else:
                o = self.opt
                self.est = BatchEstimate(self.robot, self.plan.basis, window, tol, o.total_mass,
                                         o.torque_method)  # fmt: skip
        return self.plan.kinds

    def reduce(self, part: dict, robot: Robot):
        """The pose's samples read and reduced as ``sescid measure`` does (DataError for
        samples that cannot be read: such a pose is never journaled)."""
        log = raw_log(robot, part, self.sensors, self.source)
        return measure(robot, log, self.sensors, self.opt.min_samples, SESSION_POSE)

    def measure(self, step: SessionStep, part: dict, meas) -> bool:
        """Update the estimate with the pose's reduced samples; False when it gave nothing."""
        robot = self.robot_at(step.candidate)
        kinds = self._kinds(meas, step)
        if len(meas.pose) == 0:
            none = "no usable CoP" if kinds == (COP,) else "no usable samples"
            step.reason = meas.dropped[0][1] if meas.dropped else none
            return False
        d = meas.data
        if d.cop_se is not None and COP in kinds and not np.all(d.cop_se[0] > 0):
            step.reason = "CoP standard error is zero (identical samples): cannot weight"
            return False
        assert self.est is not None
        pred = None
        k = self.stance if self.stance is not None else 0
        if d.cop is not None and self.est.n_poses:
            r = (
                self.est.estimate(k)
                if isinstance(self.est, PooledEstimate)
                else self.est.estimate()
            )
            pred = robot.cop(d.q, r, d.gravity)[0]
        if isinstance(self.est, PooledEstimate):
            st = self.est.update(d, k, kinds)
            step.tau = None if d.tau is None else d.tau[0]
        elif isinstance(self.est, CopEstimate):
            st = self.est.update(d)
        else:
            try:
                data = pose_measurements(d, kinds, f"pose {step.pose}")
            except DataError as exc:
                step.reason = str(exc).split(": ", 1)[1]
                return False
            st = self.est.update(data)
            step.tau = None if data.tau is None else data.tau[0]
        self.raw_parts.append(part)
        self.measured.append(step.candidate)
        step.status, step.q_measured, step.quantity = "measured", d.q[0], self.est.quantity
        if d.cop is not None and d.cop_se is not None:
            step.cop, step.cop_se, step.cop_predicted = d.cop[0], d.cop_se[0], pred
        step.cop_std, step.rank = st.std, st.rank
        need = self.min_measured if kinds == (COP,) else max(self.min_measured, self.plan.min_rows)
        step.converged = st.converged and self.est.n_poses >= need
        step.body_std = self.est.body_std()
        # identified: check stability on the estimate too (held in a gantry: no box to keep)
        if self.est.identified(st.rank, _box(self.half)):
            self.r_est = self.est.estimate()
        return True

    def stop_reason(self, step: SessionStep) -> str:
        """Why to stop after this measured pose ('' to go on)."""
        opt = self.opt
        what = step.quantity
        if step.converged:
            return (
                f"converged: predicted {what} std {step.cop_std * 1e3:.3f} mm fell by less than "
                f"{opt.tol:.0%} over the last {opt.window} poses"
            )
        if opt.target_std is not None and step.cop_std <= opt.target_std:
            return f"predicted {what} std reached {opt.target_std * 1e3:g} mm"
        return ""

    def result(self, stop: str) -> SessionResult:
        """The session's result (DataError when no pose was measured)."""
        if self.est is None or self.est.n_poses == 0:
            why = self.steps[0].reason if self.steps else "no pose commanded"
            raise DataError(f"the session measured no pose (first: {why})")
        raw = {k: np.concatenate([p[k] for p in self.raw_parts]) for k in self.raw_parts[0]}
        pooled = None
        if isinstance(self.plan, StanceDesign) and isinstance(self.est, PooledEstimate):
            measured, fit = stance_result(self.plan, raw, self.sensors)
            pooled = self.est.body_parameters()
        else:
            log = raw_log(self.robot, raw, self.sensors, "session raw log")
            measured = measure(self.robot, log, self.sensors, self.opt.min_samples)
            assert not isinstance(self.est, PooledEstimate)
            fit = self.est.fit()
        return SessionResult(
            steps=self.steps,
            stop_reason=stop,
            fit=fit,
            measured=measured,
            raw=raw,
            poses=np.array([s.q for s in self.steps]),
            pose_ids=np.array([s.pose for s in self.steps]),
            candidates=self.cand,
            options=self.opt,
            body_names=list(self.robot.body_names),
            rejected=self.rejected,
            pooled=pooled,
            stances=self.plan.stances if isinstance(self.plan, StanceDesign) else (),
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
    if run.multi and not callable(getattr(adapter, "change_stance", None)):
        raise OptionError("adapter", "a session over stances asks the robot to change stance: "
                          "the adapter needs change_stance(support, mount)")  # fmt: skip
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
            if isinstance(run.plan, StanceDesign):
                ks = run.plan.stance_of(nxt.index)
                st = run.plan.stances[ks]
                if ks != run.stance:  # ask for the change (the first stance too)
                    obs.stance(k, st.label, st.describe())
                    with adapter_call(bot, pose, journal):
                        bot.change_stance(st.support, st.mount)  # type: ignore[attr-defined]
                    run.stance = ks
                step.stance = st.label
            obs.planned(k, pose, q, run.q_cur)
            with adapter_call(bot, pose, journal):
                bot.move(pose, q)
                run.q_cur = q
                why = bot.wait_settled()
                if not isinstance(why, str):
                    raise DataError(f"wait_settled returned {type(why).__name__}, not a text")
                cols = None if why else read_samples(bot.read(opt.samples), opt.samples)
            meas = part = None
            if cols is not None:
                with kept_on_error(journal):
                    part = run.columns(pose, cols, samples_source(bot, journal))
                    meas = run.reduce(part, run.robot_at(nxt.index))
            if journal is not None and not getattr(bot, "replaying", False):
                journal.append(JournalEntry(pose, q, why, cols))
            step.reason = why
            measured = part is not None and run.measure(step, part, meas)
            if measured:
                run.design.add(nxt.index)
            run.steps.append(step)
            obs.finished_pose(step, run.steps)
            if measured and (reason := run.stop_reason(step)):
                stop = reason
                break
    finally:
        with adapter_call(bot, "", journal, "stop"):
            bot.stop()
    result = run.result(stop)
    obs.stopped(result)
    return result


def _box(half: np.ndarray | None) -> np.ndarray:
    """The stability box's half-sizes (2,) [m]; unbounded for a robot held in a gantry."""
    return np.full(2, np.inf) if half is None else half
