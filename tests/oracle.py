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
