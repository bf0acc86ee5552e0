"""A guided session over several stances: candidates of every stance, one sequential design over
the body parameters they share, a stance change proposed when it is worth its cost, and the
pooled estimate.

Candidates: each stance's own (on a foot: the single-support rules; on both feet:
``planning.double``; held: ``planning.gantry``). Each candidate's rows over [θ̃; o]
(``planning.stances``) are projected on the pooled identifiable subspace; one
``SequentialDesign`` keeps every candidate's gain log det(I + A M⁻¹ Aᵀ).

Next pose (``StanceDesign.next``): the best gain left in the current stance g_c against the best
in any other stance g_o. A change costs ``cost`` poses, each worth at most g_c (gains only fall
as poses are added): the session asks for the change when g_o > (1 + cost) g_c (then the next
pose is chosen among the new stance's candidates, by the ``near`` rule from the zero pose: the
robot is set down afresh), else it stays (the ``near`` rule from the current pose). Before the
first measured pose every direction is unknown: the session starts in the first stance.

Estimate (``PooledEstimate``): the MAP of θ̃ with the per-body CAD prior at
``planning.pooled.PRIOR_TAU`` (the planner's expected error, as data come in) from every
measured pose's rows — the CoP weighted by its standard error, under the gravity the robot logs,
each joint torque by its own, an offset per joint shared by the stances. Its stop quantity is
the predicted RMS standard error of the CoM x/y in the reference frame over the reference poses
of ``session.estimate``, infinite until the poses determine every pooled direction.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from sescid.errors import DataError
from sescid.estimation import DEFAULT_RTOL, Measurements, identifiable_eigen
from sescid.estimation.result.fit import Fit
from sescid.estimation.solvers.online import REFERENCE_POSES
from sescid.kinds import COP, KINDS, TORQUE, Kinds, parse_kinds
from sescid.planning import (
    Quantity,
    Stance,
    design_kinds,
    parse_stances,
    stance_robot,
)
from sescid.planning.design.kinds import BlockRows
from sescid.planning.design.sequential import NextPose, SequentialDesign
from sescid.planning.design.stances import StanceRows, theta_information, theta_scale
from sescid.planning.feasibility.double import hull_margin, place_points
from sescid.planning.pooled import PRIOR_TAU
from sescid.robot import Robot
from sescid.sensors import Measured, concat_measured
from sescid.session.design import KindSwitch, kinds_of, session_candidates, unsafe_pose
from sescid.session.estimate import (
    TRUST,
    Status,
    step_status,
)
from sescid.session.records import BODY_PRIOR_SCALE, SessionOptions
from sescid.simulation import random_poses


def session_stances(robot: Robot, opt: SessionOptions) -> tuple[Stance, ...]:
    """The session's stances (``opt.stances``; empty: none given)."""
    return parse_stances(list(opt.stances), robot) if opt.stances else ()


def start_kinds(stances: tuple[Stance, ...], asked: str) -> Kinds:
    """The kinds planned for before the first measurement: the asked ones (``asked``: as the
    options spell them), or for "auto" the CoP where a stance stands and the torques where one
    is held."""
    if asked != "auto":
        return parse_kinds(asked)
    held = any(s.mount == "gantry" for s in stances)
    stand = any(s.mount != "gantry" for s in stances)
    return (COP, TORQUE) if held and stand else (TORQUE,) if held else (COP,)


class StanceDesign(KindSwitch):
    """The candidates of every stance and the sequential design over their union (module
    docstring); ``cand`` is their union (``cand.q`` indexed by the design)."""

    def __init__(self, robot: Robot, opt: SessionOptions, progress: Callable | None = None):
        self.robot, self.opt = robot, opt
        self.stances = session_stances(robot, opt)
        self.robots = [stance_robot(robot, s) for s in self.stances]
        self.mount = "stances"
        self.kinds = start_kinds(self.stances, opt.kinds)
        self.halves: list[np.ndarray | None] = []
        parts = []
        for k, (st, rb) in enumerate(zip(self.stances, self.robots, strict=True)):
            cand, half = session_candidates(
                rb, st.mount, opt, np.random.default_rng([opt.seed, k]), progress
            )
            parts.append(cand)
            self.halves.append(half)
        self.parts = parts
        self.owner = np.concatenate([np.full(len(c.q), k) for k, c in enumerate(parts)])
        self.start = np.r_[0, np.cumsum([len(c.q) for c in parts])]
        self.cand = dataclasses.replace(
            parts[0],
            q=np.concatenate([c.q for c in parts]),
            cop=np.concatenate([c.cop for c in parts]),
            n_sampled=sum(c.n_sampled for c in parts),
            n_free=sum(c.n_free for c in parts),
            notes=[f"{s.label}: {c.summary()}" for s, c in zip(self.stances, parts, strict=True)],
            mount="stances",
            placement=None,
        )
        self.half = self.halves[0]
        self.basis, self.design, self.min_rows = self._design(self.kinds)

    def rows(self, kinds: Kinds, unit: bool = False) -> list[StanceRows]:
        """Every stance's rows for ``kinds`` (``unit``: not divided by the noise levels)."""
        o = self.opt
        noise = (1.0, 1.0) if unit else (o.cop_noise, o.tau_noise)
        spec = design_kinds(self.robot, kinds, *noise)
        mass = o.total_mass or self.robot.total_mass
        return [StanceRows(self.robot, s, spec, mass) for s in self.stances]

    def _design(self, kinds: Kinds) -> tuple[np.ndarray, SequentialDesign, int]:
        """(basis of θ̃, sequential design over the union, fewest poses) for ``kinds``."""
        rows = self.rows(kinds)
        qs = [c.q for c in self.parts]
        info = np.sum([r.information(q) for r, q in zip(rows, qs, strict=True)], axis=0)
        n4 = rows[0].e.shape[1]
        basis = identifiable_eigen(theta_information(info, n4), DEFAULT_RTOL)[1]
        x = np.concatenate([r.projected(q, basis) for r, q in zip(rows, qs, strict=True)])
        r = x.shape[1]
        if r == 2:
            design = SequentialDesign(x, self.opt.near)
        else:
            design = SequentialDesign(BlockRows.plain(x), self.opt.near)
        return basis, design, int(math.ceil(x.shape[2] / r))

    def stance_of(self, i: int) -> int:
        """The stance index of union candidate ``i``."""
        return int(self.owner[i])

    def next(self, q_current: np.ndarray, current: int | None) -> NextPose:
        """The next pose (module docstring); ``current`` the stance the robot is in (None:
        not yet placed: the first stance)."""
        cur = 0 if current is None else current
        g = self.design.gains()
        here = self.owner == cur
        best_here = float(np.max(g[here])) if here.any() else -math.inf
        best_else = float(np.max(g[~here])) if (~here).any() else -math.inf
        if not math.isfinite(best_here) or (
            current is not None and best_else > (1.0 + self.opt.stance_cost) * max(best_here, 0)
        ):
            other = np.where(~here, g, -np.inf)
            cur = int(self.owner[int(np.argmax(other))]) if np.isfinite(other).any() else cur
            q_current = np.zeros_like(q_current)
        return self.design.next(self.cand.q, q_current, self.owner == cur)

    def measured_kinds(self, cop: bool, tau: bool, pose: str, k: int) -> Kinds:
        """The kinds a measurement in stance ``k`` gives the session; DataError when it lacks
        what that stance was planned for."""
        st = self.stances[k]
        want_cop = COP in self.kinds and st.cannot(COP) is None
        want_tau = TORQUE in self.kinds and st.cannot(TORQUE) is None
        if want_cop and not cop:
            raise DataError(f"pose {pose} ({st.label}): the adapter logs no loaded foot sensor")
        if want_tau and not tau:
            raise DataError(f"pose {pose} ({st.label}): the adapter logs no joint torques")
        if not cop and not tau:
            raise DataError(f"pose {pose}: the robot reports neither a CoP nor joint torques")
        if self.opt.kinds != "auto":
            return self.kinds
        seen = kinds_of(cop, tau)  # a CoP plan takes what was seen; torques planned are kept
        return seen if self.kinds == (COP,) else tuple(k for k in KINDS if k in seen + self.kinds)

    def unsafe(self, i: int, r_est: np.ndarray | None) -> str:
        """Why union candidate ``i`` must not be commanded ('' when it stands): its stance's
        robot within the limits, the model's (and an identified estimate's) CoP inside its
        support — the CoP box of a foot, the hull of both feet's boxes."""
        k = self.stance_of(i)
        st, rb, half = self.stances[k], self.robots[k], self.halves[k]
        q = self.cand.q[i]
        if st.mount != "double":
            return unsafe_pose(rb, q, half, r_est, st.mount == "gantry")
        part = self.parts[k]
        assert part.placement is not None and half is not None
        box = np.array([[1, 1], [1, -1], [-1, 1], [-1, -1]]) * half
        feet = np.concatenate(
            [rb.sole_centre + box, place_points(box, part.placement[[i - self.start[k]]])[0]]
        )
        for what, r in (("model", None), ("identified", r_est)):
            if what == "identified" and r is None:
                continue
            cop = rb.cop(q[None], r)
            if not hull_margin(feet[None], cop)[0] > 0:
                return (f"unstable: {what} CoP ({cop[0, 0] * 1e3:.1f}, {cop[0, 1] * 1e3:.1f}) mm "
                        "outside both feet's boxes; not commanded")  # fmt: skip
        return ""


class PooledEstimate:
    """The pooled MAP estimate of a session over stances (module docstring)."""

    quantity: Quantity = "CoM x/y"

    def __init__(self, plan: StanceDesign, kinds: Kinds, window: int, tol: float):
        self.plan, self.kinds, self.window, self.tol = plan, kinds, window, tol
        robot = plan.robot
        self.rows = plan.rows(kinds, unit=True)
        self.n4 = self.rows[0].e.shape[1]
        width = self.rows[0].width
        self.scale = theta_scale(robot)
        self.theta0 = robot.body_parameters() / self.scale
        self.mass = plan.opt.total_mass or robot.total_mass
        self.h = np.zeros((width, width))
        self.g = np.zeros(width)
        q_ref = random_poses(robot, *REFERENCE_POSES)
        e = robot.sesc_matrix(robot) * self.scale[None, :] / self.mass
        phi = (robot.regressor(q_ref, (0, 1)) @ e).reshape(-1, self.n4)
        self._g = phi.T @ phi / len(q_ref)
        self.n_poses = 0
        self.history: list[tuple[int, float]] = []
        self.cov = np.eye(width) * PRIOR_TAU**2
        self.theta = np.concatenate([self.theta0, np.zeros(width - self.n4)])
        self.rank = 0

    def update(self, m: Measurements, k: int, kinds: Kinds) -> Status:
        """Add one measured pose (the data of ``measure``'s output) taken in stance ``k``."""
        rows = self.rows[k]
        a = np.concatenate([x for _, x in rows.blocks(m.q, m.gravity)])[0]  # (r, 4N + J)
        y, w, use = np.zeros(len(a)), np.zeros(len(a)), np.zeros(len(a), dtype=bool)
        if rows.cop and COP in kinds and m.cop is not None and m.cop_se is not None:
            d = rows.robot.d[:2] if m.gravity is None else rows.robot.d_tilted(m.gravity, 1)[0]
            y[:2], w[:2], use[:2] = m.cop[0] - d, 1.0 / m.cop_se[0] ** 2, True
        if rows.tau and TORQUE in kinds and m.tau is not None and m.tau_se is not None:
            t = 2 if rows.spec.has_cop else 0
            for j, name in enumerate(m.tau_joints):
                row = t + rows.spec.tau_joints.index(name)
                y[row], w[row], use[row] = m.tau[0, j], 1.0 / m.tau_se[0, j] ** 2, True
        use &= np.isfinite(y) & np.isfinite(w) & (w > 0)
        a, y, w = a[use], y[use], w[use]
        z = y - a[:, : self.n4] @ self.theta0
        self.h += (a * w[:, None]).T @ a
        self.g += (a * w[:, None]).T @ z
        self.n_poses += 1
        return self._solve()

    def _solve(self) -> Status:
        n4, basis = self.n4, self.plan.basis
        data = theta_information(self.h, n4)
        self.rank = identifiable_eigen(basis.T @ data @ basis, DEFAULT_RTOL)[1].shape[1]
        prec = self.h.copy()
        prec[np.arange(n4), np.arange(n4)] += 1.0 / PRIOR_TAU**2
        off = np.arange(n4, len(prec))
        prec[off, off] += 1e-12 * max(float(np.max(np.diag(prec))), 1.0)  # offsets no pose saw
        self.cov = np.linalg.inv(prec)
        step = self.cov @ self.g
        self.theta = np.concatenate([self.theta0 + step[:n4], step[n4:]])
        std = math.inf
        if self.rank >= basis.shape[1]:
            std = math.sqrt(max(float(np.sum(self._g * self.cov[:n4, :n4])) / 2, 0.0))
        return step_status(self.history, self.n_poses, std, self.rank, self.window, self.tol)

    def estimate(self, k: int = 0) -> np.ndarray:
        """(N, 3) SESC vectors of stance ``k`` from the estimated body parameters."""
        e = self.rows[k].e  # (3N, 4N) over θ̃
        return (e @ self.theta[: self.n4] / self.mass).reshape(-1, 3)

    def body_parameters(self) -> tuple[np.ndarray, np.ndarray]:
        """(θ (4N,) [kg, kg·m], its standard deviation (4N,)): each body's mass and first moment
        in the reference robot's body frames."""
        sd = np.sqrt(np.maximum(np.diag(self.cov)[: self.n4], 0.0))
        return self.theta[: self.n4] * self.scale, sd * self.scale

    def identified(self, rank: int, half: np.ndarray) -> bool:
        """Every pooled direction determined and the CoM std below ``TRUST`` of the box."""
        std = self.history[-1][1] if self.history else math.inf
        return rank >= self.plan.basis.shape[1] and std < TRUST * float(np.min(half))

    def body_std(self) -> np.ndarray:
        """(N,) RMS SESC std per body [m] of the reference robot (prior ``BODY_PRIOR_SCALE`` on
        what the pooled estimate leaves at its prior)."""
        e = self.rows[0].robot.sesc_matrix(self.plan.robot) * self.scale[None, :] / self.mass
        cov_r = e @ self.cov[: self.n4, : self.n4] @ e.T
        var = np.minimum(np.diag(cov_r), BODY_PRIOR_SCALE**2)
        return np.sqrt(var.reshape(-1, 3).sum(axis=1))


def stance_result(plan: StanceDesign, raw: dict[str, np.ndarray], sensors) -> tuple[Measured, Fit]:
    """(measured, fit) of a session over stances: each stance's poses of the raw log (its
    ``support`` column) reduced with its robot, in the stances' order; the pooled fit of them
    all (``identify --weighted`` of the measurements, each with its ``support``: least squares
    for the CoP alone, the session's torque method with torques), reported for the robot's
    support."""
    from sescid.estimation import IdentifyOptions, fit_measurements
    from sescid.sensors import measure, read_log, table_from_columns
    from sescid.session.estimate import pose_measurements

    labels = np.asarray(raw["support"])
    parts, data = [], []
    for st, rb in zip(plan.stances, plan.robots, strict=True):
        rows = labels == st.label
        if not rows.any():
            continue
        log = read_log(rb, table_from_columns({c: v[rows] for c, v in raw.items()}), sensors)
        meas = measure(rb, log, sensors, plan.opt.min_samples)
        if not len(meas.pose):
            continue
        parts.append(meas)
        kinds: Kinds = plan.kinds
        if st.mount != "stand":  # on both feet the CoP alone, held the torques alone
            kinds = (COP,) if st.mount == "double" else (TORQUE,)
        if kinds == (COP, TORQUE) and meas.data.tau is None:
            kinds = (COP,)
        m = pose_measurements(meas.data, kinds, f"{st.label} poses")
        data.append(dataclasses.replace(m, support=st))
    if not data:
        raise DataError("the session measured no pose")
    torques = any(m.tau is not None for m in data)
    opts = IdentifyOptions(weighted=True, allow_exact=True, total_mass=plan.opt.total_mass)
    method = plan.opt.torque_method if torques else "ls"
    fit = fit_measurements(plan.robot, data, method=method, options=opts)
    return concat_measured(parts), fit
