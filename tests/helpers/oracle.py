"""Pinocchio as an independent oracle (tests only)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin


class PinOracle:
    """CoM in a support frame computed by Pinocchio (free-flyer root at identity)."""

    def __init__(self, urdf_path, support: str, joint_names: list[str], mimic: dict | None = None):
        # Free-flyer root: with a fixed base Pinocchio would drop the root link's mass.
        self.model = pin.buildModelFromUrdf(str(urdf_path), pin.JointModelFreeFlyer())
        self.data = self.model.createData()
        self.frame = self.model.getFrameId(support)
        assert self.frame < len(self.model.frames), support
        self.cols = {name: i for i, name in enumerate(joint_names)}
        self.mimic = mimic or {}  # joint → (master, multiplier, offset)

    def q_pin(self, q: np.ndarray) -> np.ndarray:
        out = pin.neutral(self.model)
        for jid in range(2, self.model.njoints):
            name = self.model.names[jid]
            jm = self.model.joints[jid]
            if name in self.cols:
                angle = q[self.cols[name]]
            else:
                master, mult, off = self.mimic[name]
                angle = mult * q[self.cols[master]] + off
            if jm.nq == 1:
                out[jm.idx_q] = angle
            else:  # continuous joint: (cos, sin)
                out[jm.idx_q : jm.idx_q + 2] = np.cos(angle), np.sin(angle)
        return out

    def com(self, q: np.ndarray) -> np.ndarray:
        """(n, 3) CoM in the support frame."""
        out = np.empty((len(q), 3))
        for k, qk in enumerate(q):
            qp = self.q_pin(qk)
            c = pin.centerOfMass(self.model, self.data, qp)
            pin.updateFramePlacements(self.model, self.data)
            out[k] = self.data.oMf[self.frame].actInv(c)
        return out

    def total_mass(self) -> float:
        return float(sum(inert.mass for inert in self.model.inertias))


class PinStatics(PinOracle):
    """Holding torques with one link held fixed, computed by Pinocchio (tests only).

    The model keeps the URDF's own root on a free-flyer; the held link's frame is placed at the
    world origin, level, and its 6-D contact wrench w balances the base rows of the generalized
    gravity g(q): J_bᵀ w = g_b, so the joints hold τ = g_a − J_aᵀ w (theory.md, joint torques).
    """

    def __init__(self, urdf_path, support: str, joint_names: list[str], g0: float = 9.81):
        super().__init__(urdf_path, support, joint_names)
        self.model.gravity.linear = np.array([0.0, 0.0, -g0])

    def torques(self, q: np.ndarray) -> np.ndarray:
        """(n, nq) holding torques [N·m], columns in ``joint_names`` order."""
        model, data = self.model, self.data
        out = np.zeros((len(q), len(self.cols)))
        for k, qk in enumerate(q):
            qp = self.q_pin(qk)
            pin.framesForwardKinematics(model, data, qp)
            qp[:7] = pin.SE3ToXYZQUAT(data.oMf[self.frame].inverse())  # held frame = world
            g = pin.computeGeneralizedGravity(model, data, qp)
            pin.computeJointJacobians(model, data, qp)
            pin.framesForwardKinematics(model, data, qp)
            jac = pin.getFrameJacobian(model, data, self.frame, pin.LOCAL_WORLD_ALIGNED)
            wrench = np.linalg.solve(jac[:, :6].T, g[:6])
            tau = g[6:] - jac[:, 6:].T @ wrench
            for jid in range(2, model.njoints):
                out[k, self.cols[model.names[jid]]] = tau[model.joints[jid].idx_v - 6]
        return out
