"""One measurement per pose (``Measured``): what the reduction of a raw log gives, and the
columns of its table (``sescid measure --out``)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from sescid.estimation.data.measurements import Measurements
from sescid.sensors.feet import REASONS, FootMode
from sescid.tables import APPROACH_COLUMN, TAU_PREFIX, TAU_SE_PREFIX

#: what a measurement was reduced from: the feet's sources (``FootMode``), joint torques only,
#: or an IMU only (a robot balancing on a line)
MeasuredFrom = Literal[FootMode, "torque", "imu"]


#: fields of ``Measured`` beside ``data`` with one row per pose
_POSE_ROWS = ("pose", "force", "n_used", "rejected")


@dataclass(frozen=True)
class Measured:
    """Per-pose results of ``measure`` (k kept poses): the measured quantities (``data``) and
    what the reduction adds; forces in N."""

    pose: np.ndarray  #: (k,) pose ids (text)
    #: the k poses' means (read-backs, CoP: None without foot sensors, gravity, torques) and
    #: their standard errors, approach sides
    data: Measurements
    force: np.ndarray  #: (k,) mean total vertical force, N (NaN without forces)
    n_used: np.ndarray  #: (k,) samples averaged
    rejected: np.ndarray  #: (k, len(REASONS)) samples rejected, per reason
    dropped: list[tuple[str, str]] = field(default_factory=list)  #: (pose, why) not kept
    mode: MeasuredFrom = "forces"
    #: what the reduction left out beside whole poses (a dead torque sensor's column, …)
    notes: list[str] = field(default_factory=list)

    def take(self, rows: np.ndarray) -> Measured:
        """The poses ``rows`` (a mask or index array) of every per-pose array."""
        taken = {f: getattr(self, f)[rows] for f in _POSE_ROWS}
        return dataclasses.replace(self, **taken, data=self.data.take(rows))

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
        d = self.data
        cols: dict[str, np.ndarray] = {"pose": self.pose}
        cols |= {j: d.q[:, i] for i, j in enumerate(joint_names)}
        if d.cop is not None and d.cop_se is not None:
            cols |= {
                "cop_x": d.cop[:, 0],
                "cop_y": d.cop[:, 1],
                "cop_se_x": d.cop_se[:, 0],
                "cop_se_y": d.cop_se[:, 1],
            }
        if d.tau is not None and d.tau_se is not None:
            cols |= {TAU_PREFIX + j: d.tau[:, i] for i, j in enumerate(d.tau_joints)}
            cols |= {TAU_SE_PREFIX + j: d.tau_se[:, i] for i, j in enumerate(d.tau_joints)}
        if d.approach is not None:
            cols[APPROACH_COLUMN] = d.approach
        cols |= {
            "n_used": self.n_used.astype(int),
            "n_rejected": self.n_rejected.astype(int),
            "reject_reasons": np.array(self.reasons()),
        }
        if self.mode == "forces":  # the registers carry no force
            cols["force_n"] = self.force
        if d.gravity is not None:
            cols |= {f"grav_{a}": d.gravity[:, i] for i, a in enumerate("xyz")}
        return cols


def concat_measured(parts: list[Measured]) -> Measured:
    """One ``Measured`` of the poses of several, in order (a quantity some did not measure:
    nan there; torques of different joint sets: dropped)."""
    first = parts[0]

    def cat(name: str):
        vals = [getattr(p.data, name) for p in parts]
        if all(v is None for v in vals):
            return None
        shape = next(v for v in vals if v is not None).shape[1:]
        return np.concatenate([np.full((len(p.pose), *shape), np.nan) if v is None else v
                               for p, v in zip(parts, vals, strict=True)])  # fmt: skip

    joints = {p.data.tau_joints for p in parts if p.data.tau is not None}
    tau_ok = len(joints) == 1
    data = dataclasses.replace(
        first.data,
        **{name: cat(name) for name in ("q", "cop", "cop_se", "gravity", "approach")},
        tau_joints=next(iter(joints)) if tau_ok else (),
        tau=cat("tau") if tau_ok else None,
        tau_se=cat("tau_se") if tau_ok else None,
    )
    rows: dict[str, Any] = {f: np.concatenate([getattr(p, f) for p in parts]) for f in _POSE_ROWS}
    return dataclasses.replace(
        first,
        **rows,
        data=data,
        dropped=[d for p in parts for d in p.dropped],
        notes=list(dict.fromkeys(n for p in parts for n in p.notes)),
    )
