"""One measurement per pose (``Measured``): what the reduction of a raw log gives, and the
columns of its table (``sescid measure --out``)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from sescid.sensors.feet import REASONS, FootMode
from sescid.tables import APPROACH_COLUMN, TAU_PREFIX, TAU_SE_PREFIX

#: what a measurement was reduced from: the feet's sources (``FootMode``), joint torques only,
#: or an IMU only (a robot balancing on a line)
MeasuredFrom = Literal[FootMode, "torque", "imu"]


@dataclass(frozen=True)
class Measured:
    """Per-pose results of ``measure`` (k kept poses); lengths in m, forces in N, torques N·m."""

    pose: np.ndarray  #: (k,) pose ids (text)
    q: np.ndarray  #: (k, nq) mean joint read-backs, rad
    cop: np.ndarray | None  #: (k, 2) mean CoP in the support frame, m (None: no foot sensors)
    cop_se: np.ndarray | None  #: (k, 2) standard error of that mean, m
    force: np.ndarray  #: (k,) mean total vertical force, N (NaN without forces)
    n_used: np.ndarray  #: (k,) samples averaged
    rejected: np.ndarray  #: (k, len(REASONS)) samples rejected, per reason
    dropped: list[tuple[str, str]] = field(default_factory=list)  #: (pose, why) not kept
    mode: MeasuredFrom = "forces"
    gravity: np.ndarray | None = None  #: (k, 3) mean gravity direction (unit), support frame
    tau_joints: tuple[str, ...] = ()  #: joints with torques, model order
    tau: np.ndarray | None = None  #: (k, len(tau_joints)) mean torque, N·m
    tau_se: np.ndarray | None = None  #: (k, len(tau_joints)) its standard error, N·m
    approach: np.ndarray | None = None  #: (k,) ±1
    #: what the reduction left out beside whole poses (a dead torque sensor's column, …)
    notes: list[str] = field(default_factory=list)

    @property
    def n_rejected(self) -> np.ndarray:
        """(k,) samples rejected per pose, all reasons."""
        return self.rejected.sum(axis=1)

    def reasons(self) -> list[str]:
        """Per pose, e.g. 'no_load=3 outlier=1' (or 'none')."""
        out = []
        for row in self.rejected:
            parts = [f"{r}={int(c)}" for r, c in zip(REASONS, row, strict=True) if c]
            out.append(" ".join(parts) if parts else "none")
        return out

    def columns(self, joint_names: list[str]) -> dict[str, np.ndarray]:
        """Output table: pose, joints (rad), cop_x/y, cop_se_x/y (m), tau_/tau_se_<joint>
        (N·m), approach, counts, reasons, force_n, grav_x/y/z."""
        cols: dict[str, np.ndarray] = {"pose": self.pose}
        cols |= {j: self.q[:, i] for i, j in enumerate(joint_names)}
        if self.cop is not None and self.cop_se is not None:
            cols |= {
                "cop_x": self.cop[:, 0],
                "cop_y": self.cop[:, 1],
                "cop_se_x": self.cop_se[:, 0],
                "cop_se_y": self.cop_se[:, 1],
            }
        if self.tau is not None and self.tau_se is not None:
            cols |= {TAU_PREFIX + j: self.tau[:, i] for i, j in enumerate(self.tau_joints)}
            cols |= {TAU_SE_PREFIX + j: self.tau_se[:, i] for i, j in enumerate(self.tau_joints)}
        if self.approach is not None:
            cols[APPROACH_COLUMN] = self.approach
        cols |= {
            "n_used": self.n_used.astype(int),
            "n_rejected": self.n_rejected.astype(int),
            "reject_reasons": np.array(self.reasons()),
        }
        if self.mode == "forces":  # the registers carry no force
            cols["force_n"] = self.force
        if self.gravity is not None:
            cols |= {f"grav_{a}": self.gravity[:, i] for i, a in enumerate("xyz")}
        return cols


def concat_measured(parts: list[Measured]) -> Measured:
    """One ``Measured`` of the poses of several, in order (a quantity some did not measure:
    nan there; torques of different joint sets: dropped)."""
    first = parts[0]

    def cat(name: str):
        vals = [getattr(p, name) for p in parts]
        if all(v is None for v in vals):
            return None
        shape = next(v for v in vals if v is not None).shape[1:]
        return np.concatenate([np.full((len(p.pose), *shape), np.nan) if v is None else v
                               for p, v in zip(parts, vals, strict=True)])  # fmt: skip

    joints = {p.tau_joints for p in parts if p.tau is not None}
    tau_ok = len(joints) == 1
    return dataclasses.replace(
        first,
        pose=np.concatenate([p.pose for p in parts]),
        q=np.concatenate([p.q for p in parts]),
        cop=cat("cop"),
        cop_se=cat("cop_se"),
        force=np.concatenate([p.force for p in parts]),
        n_used=np.concatenate([p.n_used for p in parts]),
        rejected=np.concatenate([p.rejected for p in parts]),
        dropped=[d for p in parts for d in p.dropped],
        gravity=cat("gravity"),
        tau_joints=next(iter(joints)) if tau_ok else (),
        tau=cat("tau") if tau_ok else None,
        tau_se=cat("tau_se") if tau_ok else None,
        approach=cat("approach"),
        notes=list(dict.fromkeys(n for p in parts for n in p.notes)),
    )
