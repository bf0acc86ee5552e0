"""The whole-body CoM and its joint Jacobian for the planner's stability and search steps.

From forward kinematics, one compiled pass per pose (``_com_jac``): body CoMs, the subtree first
moments (leaves first), the CoM, and the closed-form Jacobian — joint column j turns every body
beyond body b (each body b it drives) about the world axis w_b = R_b a_b s_b k_b through the
body's origin o_b, so ∂CoM/∂q_j = Σ_b w_b × (S_b − M_b o_b) / M with M_b, S_b the mass and first
moment of the subtree beyond b. No ``fastmath`` and no BLAS: every sum in the written order, the
same bits on every CPU, so the poses and CoPs the planner writes do not depend on the machine.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from sescid.kinematics import lazy_njit
from sescid.robot import Robot

_BLOCK = 8192  #: poses per forward-kinematics block (bounded memory)


@dataclass(frozen=True)
class ComState:
    """CoM and Jacobian of poses (support frame, m)."""

    com: np.ndarray  #: (n, 3) m
    jac: np.ndarray  #: (n, 3, nq) m/rad (zeros when not asked for)


class MassTree(NamedTuple):
    """The bodies' masses and joints as the kernel reads them (parents before children)."""

    mass: np.ndarray  #: (N,) kg
    com: np.ndarray  #: (N, 3) m, each body's CoM in its frame
    parent: np.ndarray  #: (N,) int64
    joint: np.ndarray  #: (N,) int64 q column of the body's joint (−1: none)
    axis: np.ndarray  #: (N, 3) joint axis scaled by sign × mimic multiplier
    total: float  #: kg


def mass_tree(robot: Robot) -> MassTree:
    """The robot's ``MassTree``."""
    bodies = robot.model.bodies
    return MassTree(
        mass=np.array([b.mass for b in bodies]),
        com=np.array([b.com for b in bodies], dtype=float).reshape(-1, 3),
        parent=np.array([b.parent for b in bodies], dtype=np.int64),
        joint=np.array([b.joint for b in bodies], dtype=np.int64),
        axis=np.array([b.axis * (b.sign * b.multiplier) for b in bodies], dtype=float).reshape(
            -1, 3
        ),
        total=float(sum(b.mass for b in bodies)),
    )


@lazy_njit(cache=True, nogil=True)
def _com_jac(rot, org, tree, want_jac, out_com, out_jac):  # pragma: no cover
    """CoM (n, 3) and, with ``want_jac``, ∂CoM/∂q (n, 3, nq) into ``out_*`` (module docstring).

    ``rot`` (n, N, 3, 3), ``org`` (n, N, 3) from forward kinematics; ``tree`` a ``MassTree``."""
    mass, com, parent, joint, axis, total = tree
    n, nb = org.shape[0], org.shape[1]
    s = np.empty((nb, 3))
    m_sub = np.empty(nb)
    for k in range(n):
        for b in range(nb):
            for i in range(3):
                c = org[k, b, i] + (
                    rot[k, b, i, 0] * com[b, 0]
                    + rot[k, b, i, 1] * com[b, 1]
                    + rot[k, b, i, 2] * com[b, 2]
                )
                s[b, i] = c * mass[b]
            m_sub[b] = mass[b]
        for b in range(nb - 1, 0, -1):  # children follow their parents
            p = parent[b]
            for i in range(3):
                s[p, i] += s[b, i]
            m_sub[p] += m_sub[b]
        for i in range(3):
            out_com[k, i] = s[0, i] / total
        if want_jac:
            for b in range(nb):
                j = joint[b]
                if j < 0:
                    continue
                a0 = axis[b, 0]
                a1 = axis[b, 1]
                a2 = axis[b, 2]
                w0 = rot[k, b, 0, 0] * a0 + rot[k, b, 0, 1] * a1 + rot[k, b, 0, 2] * a2
                w1 = rot[k, b, 1, 0] * a0 + rot[k, b, 1, 1] * a1 + rot[k, b, 1, 2] * a2
                w2 = rot[k, b, 2, 0] * a0 + rot[k, b, 2, 1] * a1 + rot[k, b, 2, 2] * a2
                d0 = s[b, 0] - org[k, b, 0] * m_sub[b]
                d1 = s[b, 1] - org[k, b, 1] * m_sub[b]
                d2 = s[b, 2] - org[k, b, 2] * m_sub[b]
                out_jac[k, 0, j] += (w1 * d2 - w2 * d1) / total
                out_jac[k, 1, j] += (w2 * d0 - w0 * d2) / total
                out_jac[k, 2, j] += (w0 * d1 - w1 * d0) / total


def com_state(robot: Robot, q: np.ndarray, jacobian: bool = True) -> ComState:
    """CoM (n, 3) and, with ``jacobian``, ∂CoM/∂q (n, 3, nq) of poses q (n, nq) [rad]."""
    q = np.ascontiguousarray(q, dtype=float).reshape(-1, robot.nq)
    tree = mass_tree(robot)
    com = np.empty((len(q), 3))
    jac = np.zeros((len(q), 3, robot.nq))
    for s in range(0, len(q), _BLOCK):
        rot, org = robot.forward(q[s : s + _BLOCK])
        _com_jac(rot, org, tree, jacobian, com[s : s + _BLOCK], jac[s : s + _BLOCK])
    return ComState(com=com, jac=jac)


def level_cop(robot: Robot, q: np.ndarray) -> np.ndarray:
    """(n, 2) model CoP [m] on a level floor (the CoM's x, y), CPU-independent bits; equal to
    ``robot.cop(q)`` to rounding."""
    return com_state(robot, q, jacobian=False).com[:, :2]
