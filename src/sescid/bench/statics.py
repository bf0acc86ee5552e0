"""Joint torques that hold a pose, from rigid statics with the support link fixed.

With the support link held (a foot flat on the floor in single support, or the pelvis in a
gantry), the actuator of joint j holds the bodies beyond it (away from the support: its subtree
in the tree rooted at the support) against gravity and any external force on them:

    τ_θj = −a_j · [ Σ_{i beyond j} (c_i − p_j) × m_i g⃗  +  Σ_k (x_k − p_j) × F_k ]

with ``a_j`` the joint's axis and ``p_j`` a point on it (the body's origin), ``c_i`` the body
CoMs, ``g⃗ = 9.80665 · gravity`` (support frame; level: (0, 0, −1)) and ``F_k`` external forces
at ``x_k`` on bodies beyond j (e.g. the floor under the other foot in double support). The
torque on the model's joint coordinate ``q`` sums ``coef · τ_θ`` over the bodies it drives
(``θ = coef · q + off``; mimic joints share a column). This is Pinocchio's
``computeGeneralizedGravity`` of a fixed-base model rooted at the support, and MuJoCo's
``qfrc_bias`` at zero velocity minus the contact forces' share (tests check both).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from sescid.base import G0
from sescid.kinematics import as_poses
from sescid.robot import Robot


@dataclass(frozen=True)
class ExternalForce:
    """A force on one body: ``force`` (n, 3) N at ``point`` (n, 3) m, both in the support frame."""

    body: int
    point: np.ndarray
    force: np.ndarray


def holding_torques(
    robot: Robot,
    q: ArrayLike,
    bodies: list | None = None,
    gravity: ArrayLike | None = None,
    external: tuple[ExternalForce, ...] = (),
) -> np.ndarray:
    """(n, nq) torques [N·m] on each joint coordinate that hold poses q (n, nq) [rad] still.

    ``bodies``: the bodies' masses and CoMs (default: the model's; a bench passes its real
    robot's); ``gravity`` (n, 3) or (3,) unit direction in the support frame (default level).
    """
    qq = as_poses(q, robot.nq)
    n = qq.shape[0]
    bodies = list(robot.model.bodies) if bodies is None else bodies
    rot, org = robot.forward(qq)  # (n, N, 3, 3), (n, N, 3)
    mass = np.array([b.mass for b in bodies])
    com = np.array([b.com for b in bodies])  # (N, 3) body frames
    c = org + np.einsum("nbij,bj->nbi", rot, com)  # (n, N, 3) body CoMs, support frame
    g = np.tile([0.0, 0.0, -1.0], (n, 1)) if gravity is None else np.asarray(gravity, float)
    g = np.broadcast_to(g, (n, 3)) * G0
    # per body: the gravity moment of its subtree and external moments, about the origin
    moment = np.cross(mass[None, :, None] * c, g[:, None, :])  # (n, N, 3)
    force = np.broadcast_to(mass[None, :, None] * g[:, None, :], (n, len(bodies), 3)).copy()
    for e in external:
        moment[:, e.body] += np.cross(e.point, e.force)
        force[:, e.body] += e.force
    parent = [b.parent for b in robot.model.bodies]
    for i in range(len(parent) - 1, 0, -1):  # children come after their parents
        moment[:, parent[i]] += moment[:, i]
        force[:, parent[i]] += force[:, i]
    # about the joint's point p: M_p = M_0 − p × F
    tau = np.zeros((n, robot.nq))
    tree = robot.tree
    for b in range(1, len(parent)):
        j = int(tree.jcol[b])
        if j < 0:
            continue
        axis = rot[:, b] @ robot.model.bodies[b].axis  # (n, 3)
        m_p = moment[:, b] - np.cross(org[:, b], force[:, b])
        tau[:, j] -= tree.coef[b] * np.einsum("ni,ni->n", axis, m_p)
    return tau
