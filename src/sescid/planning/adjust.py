"""Candidate generation that does not depend on how rarely a uniform draw is stable: draw the
joints uniformly, then move the supporting leg so that the CoP lands at a random point of the
stability box.

The supporting leg is the chain of joints from the support body up to the first body with more
than one child (the pelvis for a humanoid). A few damped Gauss–Newton steps on the model CoP
over those joints (finite-difference Jacobian, vectorised across poses, clipped to the sampling
limits) bring most draws inside the box; the usual stability, floor and self-collision checks
then decide. The other joints keep their draw. Draws (``draw``) mix uniform poses within the
limits with poses near already accepted ones (Gaussian steps of ``NEAR_STEP`` of each joint's
range; before any is accepted, uniform within ``NEAR_STEP`` of the range around the zero pose):
on a 32-joint humanoid almost no uniform draw is free of self-collision, a nearby one often is.
Draws already in self-collision are dropped before the (costlier) adjustment.
"""

from __future__ import annotations

import numpy as np

from sescid.planning.broadphase import collision_free_mask_broad
from sescid.planning.collision import Capsules
from sescid.robot import Robot

ADJUST_STEPS = 3  #: Gauss–Newton steps
_FD = 1e-6  #: rad, finite-difference step
_DAMP = 1e-8  #: m², damping of the 2×2 normal matrix
NEAR_STEP = 0.15  #: standard deviation of a step from an accepted pose, fraction of the range
UNIFORM_SHARE = 0.25  #: share of each chunk drawn uniformly within the limits


def draw(
    limits: np.ndarray, n: int, rng: np.random.Generator, accepted: np.ndarray | None
) -> np.ndarray:
    """(n, nq) raw draws [rad]: ``UNIFORM_SHARE`` uniform within ``limits``, the rest near
    ``accepted`` poses (or near the zero pose when there are none)."""
    lo, hi = limits[:, 0], limits[:, 1]
    width = hi - lo
    n_uni = int(round(UNIFORM_SHARE * n))
    q = lo + width * rng.random((n, len(lo)))
    m = n - n_uni
    if accepted is not None and len(accepted):
        base = accepted[rng.integers(0, len(accepted), m)]
        q[n_uni:] = base + NEAR_STEP * width * rng.standard_normal(base.shape)
    else:
        zero = np.clip(0.0, lo, hi)
        q[n_uni:] = zero + NEAR_STEP * width * rng.uniform(-1, 1, (m, len(lo)))
    return np.clip(q, lo, hi)


def support_chain(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    """Joint columns and bodies of the supporting leg: from the support body up to the first
    branch (each body's own joint, ordinary joints only)."""
    bodies = robot.model.bodies
    children: dict[int, list[int]] = {}
    for i, b in enumerate(bodies):
        children.setdefault(b.parent, []).append(i)
    cols: list[int] = []
    chain: list[int] = []
    cur = 0
    while len(children.get(cur, [])) == 1:
        cur = children[cur][0]
        j = bodies[cur].joint
        if j >= 0 and bodies[cur].multiplier == 1.0 and j not in cols:
            cols.append(j)
            chain.append(cur)
    if not cols:  # the support body branches at once: its direct children's joints
        for c in children.get(0, []):
            j = bodies[c].joint
            if j >= 0 and bodies[c].multiplier == 1.0 and j not in cols:
                cols.append(j)
                chain.append(c)
    return np.array(cols, dtype=np.int64), np.array(chain, dtype=np.int64)


def _subtrees(robot: Robot, chain: np.ndarray) -> np.ndarray:
    """(k, N) mass-weighting mask: body i lies at or beyond chain body k (away from support)."""
    parents = [b.parent for b in robot.model.bodies]
    out = np.zeros((len(chain), len(parents)))
    for i in range(len(parents)):
        a = i
        while a >= 0:
            out[chain == a, i] = 1.0
            a = parents[a]
    return out


def adjust_support_leg(
    robot: Robot,
    q: np.ndarray,
    limits: np.ndarray,
    half_extents: np.ndarray,
    centre: np.ndarray,
    rng: np.random.Generator,
    steps: int = ADJUST_STEPS,
) -> np.ndarray:
    """Poses ``q`` (n, nq) [rad] with the supporting leg moved toward a CoP target drawn
    uniformly in the central half of ``centre ± half_extents`` [m].

    Jacobian of the CoM in closed form: joint k turns the bodies beyond it about its axis
    w_k through its point p_k, so ∂CoM/∂q_k = s_k (w_k × (c_k − p_k)) M_k / M with M_k, c_k
    the mass and CoM beyond it."""
    q = np.array(q, dtype=float)
    cols, chain = support_chain(robot)
    if not len(cols) or not len(q):
        return q
    lo, hi = limits[cols, 0], limits[cols, 1]
    half = np.asarray(half_extents, dtype=float)
    target = np.asarray(centre, dtype=float) + half * rng.uniform(-0.5, 0.5, size=(len(q), 2))
    bodies = robot.model.bodies
    mass = np.array([b.mass for b in bodies])
    com = np.array([b.com for b in bodies])
    sub = _subtrees(robot, chain) * mass  # (k, N)
    m_sub = sub.sum(axis=1)  # (k,)
    axis = np.array([bodies[c].axis * bodies[c].sign for c in chain])  # (k, 3)
    total = mass.sum()
    for _ in range(steps):
        rot, org = robot.forward(q)
        cw = org + (rot @ com[:, :, None])[..., 0]  # body CoMs (n, N, 3)
        c_all = np.einsum("b,nbi->ni", mass, cw) / total
        c_sub = np.einsum("kb,nbi->nki", sub, cw)  # (n, k, 3): Σ m c beyond joint k
        w = (rot[:, chain] @ axis[:, :, None])[..., 0]
        jac = np.cross(w, c_sub - m_sub[:, None] * org[:, chain]) / total  # (n, k, 3)
        jac = jac[..., :2].transpose(0, 2, 1)  # (n, 2, k)
        err = target - c_all[:, :2]
        jjt = jac @ jac.transpose(0, 2, 1) + _DAMP * np.eye(2)
        dq = np.einsum("nij,ni->nj", jac, np.linalg.solve(jjt, err[..., None])[..., 0])
        q[:, cols] = np.clip(q[:, cols] + np.clip(dq, -0.5, 0.5), lo, hi)
    return q


def adjusted_draws(
    robot: Robot,
    cap: Capsules,
    limits: np.ndarray,
    n: int,
    rng: np.random.Generator,
    accepted: np.ndarray | None,
    half_extents: np.ndarray,
    centre: np.ndarray,
) -> np.ndarray:
    """``n`` draws (``draw``) less those already in self-collision, with the supporting leg
    adjusted (``adjust_support_leg``); every check is made again on the result."""
    q = draw(limits, n, rng, accepted)
    rot, org = robot.forward(q)
    q = q[collision_free_mask_broad(cap, rot, org)]
    return adjust_support_leg(robot, q, limits, half_extents, centre, rng)
