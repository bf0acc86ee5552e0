"""The calibration's linear system: three rows per pose (total force, two moments as CoP).

Columns: the SESC vectors (3 per body), then per (sensor set, foot) the four gains and per
(session, foot it loads) the four offsets β = g·o; ``SystemIndex`` maps each block to its
columns. See the package docstring for the statics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.errors import DataError, OptionError
from sescid.kinematics import as_poses
from sescid.robot import Robot
from sescid.sensors.calibration.model import PadSession, ParameterKind


@dataclass
class Column:
    """One sensor column of the system: a pad's gain or a session's offset."""

    kind: ParameterKind
    owner: str
    foot: str
    pad: int

    @property
    def label(self) -> str:
        """``kind[owner/foot/pad]``."""
        return f"{self.kind}[{self.owner}/{self.foot}/{self.pad}]"


def check_sessions(robot: Robot, sessions: list[PadSession]) -> None:
    """DataError or OptionError for sessions the calibration cannot use (shapes, names)."""
    if not sessions:
        raise DataError("sensor calibration needs at least one session")
    names = [s.name for s in sessions]
    if len(set(names)) != len(names):
        raise DataError(f"session names must differ, got {names}")
    for s in sessions:
        q = as_poses(s.q, robot.nq)
        n = q.shape[0]
        for f in s.feet:
            if f.sole_frame not in robot.model.link_frames:
                raise DataError(f"session {s.name}: unknown sole frame '{f.sole_frame}'")
            if f.readings.shape != (n, f.pads.shape[0]) or f.loaded.shape != (n,):
                raise DataError(
                    f"session {s.name}, foot {f.name}: readings must be ({n}, "
                    f"{f.pads.shape[0]}) and loaded ({n},), got {f.readings.shape}, "
                    f"{f.loaded.shape}"
                )
            bad = f.loaded & ~np.all(np.isfinite(f.readings), axis=1)
            if bad.any():
                raise DataError(
                    f"session {s.name}, foot {f.name}: pose {int(np.flatnonzero(bad)[0])} is "
                    "loaded but has a missing reading"
                )
        if s.gravity is not None and np.asarray(s.gravity).shape != (n, 3):
            raise DataError(f"session {s.name}: gravity must be ({n}, 3)")
        for what, v in (("noise_force", s.noise_force), ("noise_cop", s.noise_cop)):
            if v is not None and not (math.isfinite(v) and v > 0):
                raise OptionError(what, f"session {s.name}: must be > 0, got {v}")


def sensor_columns(sessions: list[PadSession]) -> list[Column]:
    """The sensor columns: gains per (sensor set, foot), offsets per (session, loaded foot)."""
    cols: list[Column] = []
    seen = set()
    for s in sessions:  # gains: one block per (sensor set, foot)
        for f in s.feet:
            if (s.sensors, f.name) not in seen:
                seen.add((s.sensors, f.name))
                cols += [Column("gain", s.sensors, f.name, k + 1) for k in range(len(f.pads))]
    for s in sessions:  # offsets: one block per (session, foot that it loads)
        for f in s.feet:
            if f.loaded.any():
                cols += [Column("offset", s.name, f.name, k + 1) for k in range(len(f.pads))]
    return cols


@dataclass
class Rows:
    """The stacked rows of all sessions, with each row's session and type."""

    a: np.ndarray  #: (m, P) design
    y: np.ndarray  #: (m,)
    session: np.ndarray  #: (m,) session index
    moment: np.ndarray  #: (m,) bool: moment row (m) vs force row (N)
    n_poses: int
    double: list[int]  #: per session, double-support poses
    used: list[int]  #: per session, poses with a loaded foot


def _session_rows(robot: Robot, s: PadSession, index: dict, p_x: int, p: int, weight: float):
    """Rows (3 per pose with a loaded foot) of one session, vectorised across poses."""
    q = as_poses(s.q, robot.nq)
    n = q.shape[0]
    loaded = np.stack([f.loaded for f in s.feet], axis=1) if s.feet else np.zeros((n, 0), bool)
    use = loaded.any(axis=1)
    q = q[use]
    k = q.shape[0]
    if k == 0:
        return np.zeros((0, p)), np.zeros(0), 0, 0
    loaded = loaded[use]
    poses = {f.name: robot.link_poses(q, f.sole_frame) for f in s.feet}
    # ground frame: the support sole when loaded, else the first loaded foot
    order = sorted(range(len(s.feet)), key=lambda i: s.feet[i].sole_frame != robot.support)
    rot_g = np.zeros((k, 3, 3))
    org_g = np.zeros((k, 3))
    chosen = np.zeros(k, dtype=bool)
    for i in order:
        pick = loaded[:, i] & ~chosen
        rot, org = poses[s.feet[i].name]
        rot_g[pick], org_g[pick] = rot[pick], org[pick]
        chosen |= pick
    if s.gravity is None:
        g = np.tile([0.0, 0.0, -1.0], (k, 1))
    else:
        gs = np.asarray(s.gravity, dtype=float)[use]
        g = np.einsum("nji,nj->ni", rot_g, gs / np.linalg.norm(gs, axis=1, keepdims=True))
    if np.any(g[:, 2] >= -0.5):
        raise DataError(f"session {s.name}: gravity does not point down through the ground sole")
    tmat = np.concatenate([np.tile(np.eye(2), (k, 1, 1)), -(g[:, :2] / g[:, 2:3])[:, :, None]], 2)
    proj = np.einsum("nab,ncb->nac", tmat, rot_g)  # T R_Gᵀ (k, 2, 3)
    phi = robot.regressor(q, (0, 1, 2))  # (k, 3, 3N)
    a = np.zeros((k, 3, p))
    a[:, 1:, :p_x] = -np.einsum("nac,ncp->nap", proj, phi)
    rhs = np.zeros((k, 3))
    rhs[:, 0] = -weight * g[:, 2]
    rhs[:, 1:] = np.einsum("nac,nc->na", proj, robot.d[None, :] - org_g)
    for i, f in enumerate(s.feet):
        on = loaded[:, i]
        rot, org = poses[f.name]
        pad3 = np.concatenate([f.pads, np.zeros((len(f.pads), 1))], axis=1)
        world = org[:, None, :] + np.einsum("nij,kj->nki", rot, pad3)  # support frame
        pg = np.einsum("nji,nkj->nki", rot_g, world - org_g[:, None, :])[:, :, :2]  # ground xy
        y = np.where(on[:, None], np.nan_to_num(np.asarray(f.readings, float)[use]), 0.0)
        if not on.any():
            continue
        gi = index[("gain", s.sensors, f.name)]
        oi = index[("offset", s.name, f.name)]
        a[:, 0, gi] += y
        a[:, 0, oi] -= on[:, None]
        a[:, 1:, gi] += np.einsum("nk,nka->nak", y, pg) / weight
        a[:, 1:, oi] -= np.einsum("n,nka->nak", on.astype(float), pg) / weight
    double = int(np.sum(loaded.sum(axis=1) > 1))
    return a.reshape(3 * k, p), rhs.reshape(-1), k, double


def build_rows(robot: Robot, sessions: list[PadSession], cols: list[Column], weight: float):
    """All sessions' rows and the column index of each (kind, owner, foot) block."""
    p_x = 3 * len(robot.body_names)
    p = p_x + len(cols)
    index: dict[tuple[str, str, str], np.ndarray] = {}
    for j, c in enumerate(cols):
        index.setdefault((c.kind, c.owner, c.foot), [])  # type: ignore[arg-type]
        index[(c.kind, c.owner, c.foot)].append(p_x + j)  # type: ignore[attr-defined]
    index = {key: np.array(v) for key, v in index.items()}
    blocks, ys, sess, mom, double, used = [], [], [], [], [], []
    for si, s in enumerate(sessions):
        a, y, k, dbl = _session_rows(robot, s, index, p_x, p, weight)
        blocks.append(a)
        ys.append(y)
        sess.append(np.full(3 * k, si))
        mom.append(np.tile([False, True, True], k))
        double.append(dbl)
        used.append(k)
    return Rows(
        np.vstack(blocks),
        np.concatenate(ys),
        np.concatenate(sess),
        np.concatenate(mom),
        sum(used),
        double,
        used,
    ), index
