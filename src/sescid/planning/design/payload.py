"""Poses that determine a payload best: a D-optimal choice over its 4 (or 3) parameters.

The candidates are the planner's own (``funnel.stance_candidates``: stable on the support
foot, clear of the floor, free of self-collision). Each candidate's rows in the payload's
parameters p = (m, h = m c) are those of ``estimation.payload``, linearised at a nominal payload
(its weighed mass, else ``NOMINAL_SHARE`` of the robot's mass, at BODY's origin): the CoP's two
rows ``(B − (CoM − d) e_mᵀ) / M`` over the CoP noise, each measured joint's torque row
``Φ_τ K D`` over the torque noise with the joint's constant offset as a nuisance column (the
payload fit estimates every measured joint's offset from the same poses: ``kinds.BlockRows``, as
the ordinary torque design counts them). The choice maximises log det of the information about
p with the offsets marginalised (the Schur complement) by the planner's one engine
(``engine.select_poses``: greedy, then exchange passes); the expected standard errors of the
payload's mass and CoM follow from that information, beside those of as many random candidates.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from sescid.errors import OptionError
from sescid.estimation import check_payload
from sescid.estimation.solvers.payload import payload_map
from sescid.kinds import COP, TORQUE, Kinds, parse_kinds
from sescid.planning.design.engine import select_poses
from sescid.planning.design.kinds import BlockRows, offset_block_rows, schur_information
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
                 sigma: float, tau_noise: float, joints=None) -> BlockRows:  # fmt: skip
    """The rows (n, r, 4) of the poses q in p = (m, h) at the payload (mass, CoM at the origin),
    each divided by its kind's noise (``kinds``: the CoP's rows and/or the torques'), each
    torque row with its joint's offset as a nuisance column (``kinds.offset_block_rows``)."""
    theta = robot.body_parameters()
    n_b = len(robot.body_names)
    base = float(theta[:n_b].sum())
    k = robot.sesc_matrix()
    d = payload_map(robot, body)
    kb, kd = k @ theta, k @ d
    theta_nom = np.zeros(4)
    theta_nom[0] = mass
    cop = tau = None
    if COP in kinds:
        phi = robot.regressor(q, (0, 1))  # (n, 2, 3N)
        big_m = base + mass
        num = phi @ kb + phi @ kd @ theta_nom  # (n, 2): M (CoP − d)
        jac = (phi @ kd) / big_m
        jac[:, :, 0] -= num / big_m**2
        cop = jac / sigma
    if TORQUE in kinds:
        phit = robot.torque_regressor(q, joints)  # (n, J, 3N)
        tau = (phit @ kd) / tau_noise
    return offset_block_rows(cop, tau, tau_noise)


def _stds(rows: BlockRows, idx, free: list[int], mass: float) -> np.ndarray:
    """(4,) std of (mass, CoM) from the information of the candidates ``idx`` about the free
    parameters ``free`` (``rows``' columns), the offsets marginalised (nan where not
    determined)."""
    info = schur_information(rows, idx)
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
    full = payload_rows(robot, body, q, planned, nominal, opt.sigma, opt.tau_noise,
                        opt.tau_joints)  # fmt: skip
    rows = dataclasses.replace(full, x=np.ascontiguousarray(full.x[:, :, free]))
    idx = select_poses(rows, count, seed).index
    rng = np.random.default_rng(seed)
    rand = np.array([_stds(rows, rng.choice(len(q), count, replace=False), free, nominal)
                     for _ in range(draws)])  # fmt: skip
    chosen_q = q[idx]
    order = order_poses(chosen_q)
    qq = chosen_q[order]
    return PayloadPlan(
        body=body, q=qq, cop=robot.cop(qq), std=_stds(rows, idx, free, nominal),
        random_std=np.nanmedian(rand, axis=0) if np.any(np.isfinite(rand)) else rand[0],
        n_candidates=len(q), kinds=planned, nominal_mass=nominal,
    )  # fmt: skip
