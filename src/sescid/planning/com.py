"""The whole-body CoM and its joint Jacobian for the planner's stability and search steps.

Computed from forward kinematics with separate elementwise multiplications and additions,
bodies summed in tree order (no BLAS, no fused multiply-add): the same bits on every CPU, so the
poses and CoPs the planner writes do not depend on the machine. Closed-form Jacobian: joint
column j turns every body beyond body b (each body b it drives) about the world axis
w_b = R_b a_b s_b k_b through the body's origin o_b, so ∂CoM/∂q_j = Σ_b w_b × (S_b − M_b o_b) / M
with M_b, S_b the mass and first moment of the subtree beyond b.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sescid.robot import Robot


@dataclass(frozen=True)
class ComState:
    """CoM and Jacobian of poses (support frame, m)."""

    com: np.ndarray  #: (n, 3) m
    jac: np.ndarray  #: (n, 3, nq) m/rad


def _apply(rot: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R v for rot (n, 3, 3) and v (3,) or (n, 3), elementwise (fixed order, no BLAS)."""
    v = np.broadcast_to(v, rot.shape[:-1])
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    return np.stack([rot[:, i, 0] * x + rot[:, i, 1] * y + rot[:, i, 2] * z for i in range(3)], 1)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross products a × b of (n, 3) arrays, elementwise."""
    return np.stack(
        [
            a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
            a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
            a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
        ],
        axis=1,
    )


def _moments(robot: Robot, rot: np.ndarray, org: np.ndarray) -> np.ndarray:
    """(n, N, 3) first moments m_b c_b [kg·m] of the bodies in the support frame."""
    bodies = robot.model.bodies
    out = np.empty(org.shape)
    for b, body in enumerate(bodies):
        out[:, b] = (org[:, b] + _apply(rot[:, b], body.com)) * body.mass
    return out


def level_cop(robot: Robot, q: np.ndarray) -> np.ndarray:
    """(n, 2) model CoP [m] on a level floor (the CoM's x, y), CPU-independent bits; equal to
    ``robot.cop(q)`` to rounding."""
    return com_state(robot, q, jacobian=False).com[:, :2]


def com_state(robot: Robot, q: np.ndarray, jacobian: bool = True) -> ComState:
    """CoM (n, 3) and, with ``jacobian``, ∂CoM/∂q (n, 3, nq) of poses q (n, nq) [rad]."""
    q = np.ascontiguousarray(q, dtype=float)
    rot, org = robot.forward(q)
    mom = _moments(robot, rot, org)
    bodies = robot.model.bodies
    total = sum(b.mass for b in bodies)
    s = mom.copy()  # subtree first moments, leaves first (children follow their parents)
    m_sub = np.array([b.mass for b in bodies])
    for i in range(len(bodies) - 1, 0, -1):
        p = bodies[i].parent
        s[:, p] += s[:, i]
        m_sub[p] += m_sub[i]
    com = s[:, 0] / total
    jac = np.zeros((len(q), 3, robot.nq))
    if jacobian:
        for b, body in enumerate(bodies):
            if body.joint < 0:
                continue
            w = _apply(rot[:, b], body.axis * (body.sign * body.multiplier))
            jac[:, :, body.joint] += _cross(w, s[:, b] - org[:, b] * m_sub[b]) / total
    return ComState(com=com, jac=jac)
