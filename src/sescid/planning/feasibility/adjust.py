"""Candidate draws that do not depend on how rarely a uniform draw is stable: draw joints, then
move the CoM over the support foot by a few steps of the CoM Jacobian.

Draws (``draw``, ``Search``) mix uniform poses within the limits with poses near accepted ones
(Gaussian steps of ``NEAR_STEP`` of the range on a random ``NEAR_JOINTS`` of the joints; before
any is accepted, uniform within ``NEAR_STEP`` of the range around the zero pose): on a 32-joint
humanoid almost no uniform draw is free of self-collision, a nearby one often is. Draws already
in self-collision are dropped; the others get ``SEARCH_STEPS`` damped Gauss–Newton steps that
move the model CoP toward a target drawn in the central half of the stability box
(``move_com``): all joints move, each in proportion to its range (the minimum-norm step in
range-scaled coordinates), joints at a limit that the step pushes further drop out, and the
result is clipped to the limits. Every check
(stability, compliant stability, floor, self-collision) is then made again. This finds the
stable poses of a robot whose uniform draws almost never are (a small foot, a heavy torso far
ahead); ``closest_box`` says how near a robot that cannot stand on one foot came.

``adjust_support_leg`` moves only the supporting leg's joints (the same steps).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sescid.planning.feasibility.broadphase import collision_free_poses
from sescid.planning.feasibility.collision import Capsules
from sescid.planning.feasibility.com import com_state
from sescid.robot import Robot

SEARCH_STEPS = 3  #: Gauss–Newton steps
ADJUST_STEPS = 3  #: steps of ``adjust_support_leg``
_DAMP = 1e-8  #: m², damping of the 2×2 normal matrix
_MAX_STEP = 0.5  #: rad, largest change of a joint per step
NEAR_STEP = 0.25  #: standard deviation of a step from an accepted pose, fraction of the range
NEAR_JOINTS = 0.3  #: share of the joints a step from an accepted pose moves (each by chance)
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
        step = NEAR_STEP * width * rng.standard_normal(base.shape)
        step *= rng.random(base.shape) < NEAR_JOINTS
        q[n_uni:] = base + step
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
    """(k, N) mask: body i lies at or beyond chain body k (away from the support)."""
    parents = [b.parent for b in robot.model.bodies]
    out = np.zeros((len(chain), len(parents)))
    for i in range(len(parents)):
        a = i
        while a >= 0:
            out[chain == a, i] = 1.0
            a = parents[a]
    return out


def move_com(
    robot: Robot,
    q: np.ndarray,
    limits: np.ndarray,
    target: np.ndarray,
    cols: np.ndarray | None = None,
    steps: int = SEARCH_STEPS,
) -> np.ndarray:
    """Poses ``q`` (n, nq) [rad] moved so that the CoM's x, y approach ``target`` (n, 2) [m]:
    damped Gauss–Newton on the joints ``cols`` (default all), range-scaled, within ``limits``
    (see the module docstring). Elementwise arithmetic: the same bits on every CPU."""
    q = np.array(q, dtype=float)
    cols = np.arange(robot.nq) if cols is None else np.asarray(cols)
    if not len(cols) or not len(q):
        return q
    lo, hi = limits[cols, 0], limits[cols, 1]
    scale = hi - lo  # range-scaled coordinates: dq = scale · dz
    free = np.ones((len(q), len(cols)), dtype=bool)
    for _ in range(steps):
        st = com_state(robot, q)
        err = target - st.com[:, :2]
        a = st.jac[:, :2][:, :, cols] * scale * free[:, None, :]  # (n, 2, k)
        g00 = np.sum(a[:, 0] * a[:, 0], axis=1) + _DAMP
        g01 = np.sum(a[:, 0] * a[:, 1], axis=1)
        g11 = np.sum(a[:, 1] * a[:, 1], axis=1) + _DAMP
        det = g00 * g11 - g01 * g01
        y0 = (g11 * err[:, 0] - g01 * err[:, 1]) / det
        y1 = (g00 * err[:, 1] - g01 * err[:, 0]) / det
        dq = np.clip((a[:, 0] * y0[:, None] + a[:, 1] * y1[:, None]) * scale, -_MAX_STEP, _MAX_STEP)
        new = q[:, cols] + dq
        free &= (new > lo) & (new < hi)  # a joint the step pushes past a limit stops there
        q[:, cols] = np.clip(new, lo, hi)
    return q


def _targets(
    rng: np.random.Generator, n: int, half_extents: np.ndarray, centre: np.ndarray
) -> np.ndarray:
    """(n, 2) CoP targets [m] uniform in the central half of ``centre ± half_extents``."""
    half = np.asarray(half_extents, dtype=float)
    return np.asarray(centre, dtype=float) + half * rng.uniform(-0.5, 0.5, size=(n, 2))


def adjust_support_leg(
    robot: Robot,
    q: np.ndarray,
    limits: np.ndarray,
    half_extents: np.ndarray,
    centre: np.ndarray,
    rng: np.random.Generator,
    steps: int = ADJUST_STEPS,
) -> np.ndarray:
    """Poses ``q`` (n, nq) [rad] with only the supporting leg moved toward a CoP target drawn
    uniformly in the central half of ``centre ± half_extents`` [m] (``move_com``)."""
    cols, _ = support_chain(robot)
    target = _targets(rng, len(q), half_extents, centre)
    return move_com(robot, q, limits, target, cols, steps)


@dataclass
class Search:
    """Adjusted draws for one robot and stability box: ``draws`` gives each chunk."""

    robot: Robot
    cap: Capsules
    limits: np.ndarray  #: (nq, 2) rad
    half_extents: np.ndarray  #: (2,) m
    centre: np.ndarray  #: (2,) m

    def draws(self, n: int, rng: np.random.Generator, accepted: np.ndarray | None) -> np.ndarray:
        """``n`` draws (``draw``) less those already in self-collision, moved toward a stable
        CoP by every joint (``move_com``); every check is made again on the result."""
        q = draw(self.limits, n, rng, accepted)
        q = q[collision_free_poses(self.robot, self.cap, q)]
        target = _targets(rng, len(q), self.half_extents, self.centre)
        return move_com(self.robot, q, self.limits, target)


def closest_box(robot: Robot, q: np.ndarray, half_extents, centre) -> float:
    """The smallest max(|CoP − centre| / half_extents) over poses q: < 1 when one is in the box."""
    if not len(q):
        return float("inf")
    off = np.abs(robot.cop(q) - np.asarray(centre)) / np.asarray(half_extents)
    return float(off.max(axis=1).min())
