"""Poses that determine a payload best: a D-optimal choice over its 4 (or 3) parameters.

The candidates are the planner's own (``funnel.stance_candidates``: stable on the support
foot, clear of the floor, free of self-collision). Each candidate's rows in the payload's
parameters p = (m, h = m c) are those of ``estimation.payload``, linearised at a nominal payload
(its weighed mass, else ``NOMINAL_SHARE`` of the robot's mass, at BODY's origin): the CoP's two
rows ``(B − (CoM − d) e_mᵀ) / M`` over the CoP noise, each measured joint's torque row
``Φ_τ K D`` over the torque noise (the sensors' constant offsets are left out of the design:
they are estimated from the same poses, and every pose informs them alike). The choice maximises
log det of the information by the planner's one engine (``engine.select_poses``: greedy, then
exchange passes); the expected standard errors of the payload's mass and CoM follow from it,
beside those of as many random candidates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sescid.errors import OptionError
from sescid.estimation import check_payload
from sescid.estimation.solvers.payload import payload_map
from sescid.kinds import COP, TORQUE, Kinds, parse_kinds
from sescid.planning.design.engine import plain_block_rows, select_poses
from sescid.planning.funnel import sampling_range, stance_candidates
from sescid.planning.ordering import order_poses
from sescid.planning.plan_types import PlanOptions
from sescid.robot import Robot

#: the nominal payload mass the rows are linearised at, as a share of the robot's mass
NOMINAL_SHARE = 0.1
#: candidates a payload plan draws by default (its 4 parameters need few)
PAYLOAD_CANDIDATES = 2_000


@dataclass(frozen=True)
class PayloadPlan:
    """K poses (visiting order) for a payload on ``body``, and the standard errors of its mass
    [kg] and CoM (3,) [m] they are expected to give (nominal payload, the stated noise), beside
    the median over random choices of K candidates."""

    body: str
    q: np.ndarray  #: (K, nq) rad
    cop: np.ndarray  #: (K, 2) m, the model's CoP (without the payload)
    std: np.ndarray  #: (4,) expected std of (mass, com_x, com_y, com_z); mass 0 when weighed
    random_std: np.ndarray  #: (4,) the same, median over random choices
    n_candidates: int
    kinds: Kinds
    nominal_mass: float  #: kg, the payload the rows were linearised at (at BODY's origin)


def payload_rows(robot: Robot, body: str, q: np.ndarray, kinds: Kinds, mass: float,
                 sigma: float, tau_noise: float, joints=None) -> np.ndarray:  # fmt: skip
    """(n, r, 4) rows of the poses q in p = (m, h) at the payload (mass, CoM at the origin),
    each divided by its kind's noise (``kinds``: the CoP's rows and/or the torques')."""
    theta = robot.body_parameters()
    n_b = len(robot.body_names)
    base = float(theta[:n_b].sum())
    k = robot.sesc_matrix()
    d = payload_map(robot, body)
    kb, kd = k @ theta, k @ d
    theta_nom = np.zeros(4)
    theta_nom[0] = mass
    parts = []
    if COP in kinds:
        phi = robot.regressor(q, (0, 1))  # (n, 2, 3N)
        big_m = base + mass
        num = phi @ kb + phi @ kd @ theta_nom  # (n, 2): M (CoP − d)
        jac = (phi @ kd) / big_m
        jac[:, :, 0] -= num / big_m**2
        parts.append(jac / sigma)
    if TORQUE in kinds:
        phit = robot.torque_regressor(q, joints)  # (n, J, 3N)
        parts.append((phit @ kd) / tau_noise)
    return np.concatenate(parts, axis=1)


def _stds(rows: np.ndarray, free: list[int], mass: float) -> np.ndarray:
    """(4,) std of (mass, CoM) from the rows' information (nan where not determined)."""
    a = rows[:, :, free].reshape(-1, len(free))
    info = a.T @ a
    out = np.full(4, np.nan)
    if np.linalg.slogdet(info)[0] <= 0 or np.linalg.cond(info) > 1e12:
        return out
    cov = np.zeros((4, 4))
    cov[np.ix_(free, free)] = np.linalg.inv(info)
    jmc = np.eye(4)
    jmc[1:, 1:] /= mass  # c = h / m at a payload at BODY's origin (h = 0)
    std = np.sqrt(np.clip(np.diag(jmc @ cov @ jmc.T), 0, None))
    out[:] = std
    if 0 not in free:
        out[0] = 0.0
    return out


def plan_payload_poses(robot: Robot, body: str, count: int = 8, seed: int = 0,
                       options: PlanOptions | None = None, mass: float | None = None,
                       progress=None, draws: int = 50) -> PayloadPlan:  # fmt: skip
    """``count`` poses, standing on the robot's support, that determine a payload on ``body``
    best (module docstring); ``mass``: the payload's weighed mass [kg] (then only its CoM is
    designed for)."""
    check_payload(robot, body, mass)
    opt = options or PlanOptions()
    planned = parse_kinds(opt.kinds)
    free = [0, 1, 2, 3] if mass is None else [1, 2, 3]
    if count < 2:
        raise OptionError("count", "a payload needs at least 2 poses (its CoM seen twice)")
    n_cand = opt.n_candidates or PAYLOAD_CANDIDATES
    lim, _, _ = sampling_range(robot, opt)
    cand = stance_candidates(robot, "stand", n_cand, seed, opt, lim, progress)
    q = cand.q
    nominal = mass if mass is not None else NOMINAL_SHARE * robot.total_mass
    rows = payload_rows(robot, body, q, planned, nominal, opt.sigma, opt.tau_noise,
                        opt.tau_joints)  # fmt: skip
    idx = select_poses(plain_block_rows(rows[:, :, free]), count, seed).index
    rng = np.random.default_rng(seed)
    rand = np.array([_stds(rows[rng.choice(len(q), count, replace=False)], free, nominal)
                     for _ in range(draws)])  # fmt: skip
    chosen_q = q[idx]
    order = order_poses(chosen_q)
    qq = chosen_q[order]
    return PayloadPlan(
        body=body, q=qq, cop=robot.cop(qq), std=_stds(rows[idx], free, nominal),
        random_std=np.nanmedian(rand, axis=0) if np.any(np.isfinite(rand)) else rand[0],
        n_candidates=len(q), kinds=planned, nominal_mass=nominal,
    )  # fmt: skip
