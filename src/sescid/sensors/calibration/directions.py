"""Gains and offsets with their errors, and the sensor directions the sessions leave unseen.

The sensor block of the system with the SESC vectors eliminated (its Schur complement, in
prior-standard-deviation units) has a null space: the directions no session determines. They
are named by kind (package docstring): ``unloaded-foot``, ``offset-twist``,
``support-confounded`` (with the SESC components that hide them) and ``not-excited``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.estimation.result.identifiability import label_columns, sparse_terms
from sescid.robot import Robot
from sescid.sensors.calibration.model import (
    OFFSET_TWIST,
    PAD_NOT_EXCITED,
    SUPPORT_CONFOUNDED,
    UNLOADED_FOOT,
    SensorDirection,
    SensorParameter,
    SensorUnseen,
)
from sescid.sensors.calibration.rows import Column, Rows


@dataclass(frozen=True)
class Problem:
    """The system, its prior and which parameters are held fixed."""

    rows: Rows
    cols: list[Column]
    p_x: int  #: SESC columns (3 per body), first
    theta0: np.ndarray  #: (P,) prior mean (and the fixed values)
    prior_sd: np.ndarray  #: (P,) prior standard deviations (1 for the SESC block)
    fixed: np.ndarray  #: (P,) bool, held fixed
    sens_of: dict[str, str]  #: session → sensor set
    rtol: float

    @property
    def s_idx(self) -> np.ndarray:
        """Indices of the free sensor columns."""
        return np.flatnonzero(~self.fixed[self.p_x :]) + self.p_x


@dataclass(frozen=True)
class _Schur:
    """The sensor block's Schur complement and the pieces that name its null space."""

    null: np.ndarray  #: (s, d) orthonormal basis of the unseen sensor directions
    s_idx: np.ndarray
    pinv: np.ndarray  #: pseudo-inverse of the SESC block
    cross: np.ndarray  #: SESC × sensor block


def _schur(pb: Problem, sw: np.ndarray) -> _Schur:
    """Sensor-block Schur complement (x eliminated, no priors) in prior-std units, its null."""
    a = pb.rows.a * sw[:, None]
    ax = a[:, : pb.p_x]
    s_idx = pb.s_idx
    as_ = a[:, s_idx] * pb.prior_sd[s_idx]
    lam, vec = np.linalg.eigh(ax.T @ ax)
    keep = lam > (pb.rtol**2) * lam.max()
    pinv = (vec[:, keep] / lam[keep]) @ vec[:, keep].T
    cross = ax.T @ as_
    schur = as_.T @ as_ - cross.T @ pinv @ cross
    schur = 0.5 * (schur + schur.T)
    if schur.size == 0:
        return _Schur(np.zeros((0, 0)), s_idx, pinv, cross)
    lam, vec = np.linalg.eigh(schur)
    top = max(lam.max(), 1e-300)
    null = vec[:, np.sqrt(np.clip(lam, 0, None)) <= pb.rtol * math.sqrt(top) * 1e2]
    return _Schur(null, s_idx, pinv, cross)


def parameters(pb: Problem, theta: np.ndarray, cov: np.ndarray, sw) -> list[SensorParameter]:
    """Gains and offsets o = β / g (delta method for the offsets' standard errors)."""
    sc = _schur(pb, sw)
    null_proj = sc.null @ sc.null.T
    p_x = pb.p_x
    pos = {int(j): i for i, j in enumerate(sc.s_idx)}
    gain_of = {(c.owner, c.foot, c.pad): p_x + j for j, c in enumerate(pb.cols) if c.kind == "gain"}
    out = []
    for j, c in enumerate(pb.cols):
        col = p_x + j
        unseen = float(null_proj[pos[col], pos[col]]) if col in pos else 0.0
        if c.kind == "gain":
            value, var = float(theta[col]), cov[col, col]
        else:
            gc = gain_of[(pb.sens_of[c.owner], c.foot, c.pad)]
            g, beta = theta[gc], theta[col]
            value = float(beta / g)
            jac = np.array([-beta / g**2, 1.0 / g])
            sub = cov[np.ix_([gc, col], [gc, col])]
            var = float(jac @ sub @ jac)
            if gc in pos:
                unseen = max(unseen, float(null_proj[pos[gc], pos[gc]]))
        out.append(
            SensorParameter(
                c.kind, c.owner, c.foot, c.pad, value, math.sqrt(max(var, 0.0)),
                min(unseen, 1.0), bool(pb.fixed[col]),
            )
        )  # fmt: skip
    return out


class _Namer:
    """Collects named directions that lie in the null space."""

    def __init__(self, pb: Problem, sc: _Schur):
        self.proj = sc.null @ sc.null.T
        self.labels = [pb.cols[j - pb.p_x].label for j in sc.s_idx]
        self.found: list[np.ndarray] = []
        self.out: list[SensorDirection] = []

    def take(self, v: np.ndarray, kind: SensorUnseen, reason: str) -> None:
        v = v / np.linalg.norm(v)
        if np.linalg.norm(self.proj @ v) > 1 - 1e-6:
            self.found.append(v)
            terms = [(self.labels[i], float(v[i])) for i in np.flatnonzero(np.abs(v) > 1e-9)]
            self.out.append(SensorDirection(terms, kind, reason))


def _unloaded_and_twists(sessions, pb: Problem, sc: _Schur, namer: _Namer) -> None:
    """Gains of feet never loaded; per session and foot the offset twists (or unloaded)."""
    import scipy.linalg

    pos = {int(j): i for i, j in enumerate(sc.s_idx)}
    loaded_by: dict[tuple[str, str], bool] = {}
    for s in sessions:
        for f in s.feet:
            key = (s.sensors, f.name)
            loaded_by[key] = loaded_by.get(key, False) or bool(f.loaded.any())
    for j in sc.s_idx:
        c = pb.cols[j - pb.p_x]
        v = np.zeros(len(sc.s_idx))
        v[pos[int(j)]] = 1.0
        if c.kind == "gain" and not loaded_by[(c.owner, c.foot)]:
            namer.take(
                v, UNLOADED_FOOT, f"the {c.foot} foot never carries load with sensors {c.owner}"
            )
    for s in sessions:
        for f in s.feet:
            idx = [pos.get(int(pb.p_x + j)) for j, c in enumerate(pb.cols)
                   if c.kind == "offset" and c.owner == s.name and c.foot == f.name]  # fmt: skip
            if not f.loaded.any():
                namer.out.append(
                    SensorDirection(
                        [(f"offset[{s.name}/{f.name}/{k + 1}]", 1.0) for k in range(len(f.pads))],
                        UNLOADED_FOOT,
                        f"session {s.name} never loads the {f.name} foot: its offsets there are "
                        "not seen (not estimated)",
                    )
                )
                continue
            if not idx or any(i is None for i in idx):
                continue
            ii = np.array([int(i) for i in idx if i is not None])
            tw = scipy.linalg.null_space(np.column_stack([np.ones(len(f.pads)), f.pads]).T)
            for t in tw.T:
                v = np.zeros(len(sc.s_idx))
                v[ii] = t / pb.prior_sd[sc.s_idx[ii]]
                namer.take(
                    v,
                    OFFSET_TWIST,
                    f"session {s.name}, {f.name} foot: this offset combination changes neither "
                    "the total force nor its moments, so statics never sees it (from the prior)",
                )


def unseen_directions(robot: Robot, sessions, pb: Problem, sw: np.ndarray) -> list[SensorDirection]:
    """Name the sensor directions the sessions leave undetermined (module docstring)."""
    sc = _schur(pb, sw)
    namer = _Namer(pb, sc)
    _unloaded_and_twists(sessions, pb, sc, namer)
    rest = namer.proj.copy()
    if namer.found:
        qf, _ = np.linalg.qr(np.column_stack(namer.found))
        rest -= qf @ qf.T
    w, u = np.linalg.eigh(rest)
    mass_labels = label_columns(robot)
    for k in np.flatnonzero(w > 0.5):
        v = u[:, k]
        xcomp = -sc.pinv @ sc.cross @ v  # the SESC change that hides it
        terms = [(namer.labels[i], float(v[i])) for i in np.flatnonzero(np.abs(v) > 1e-3)]
        if np.linalg.norm(xcomp) <= 1e-6 * max(float(np.linalg.norm(v)), 1e-300):
            namer.out.append(
                SensorDirection(
                    terms,
                    PAD_NOT_EXCITED,
                    "the pads' load pattern did not vary independently of the CoP in these "
                    "poses (e.g. a split linear in the CoP), so these gains are not separated",
                )
            )
            continue
        namer.out.append(
            SensorDirection(
                terms,
                SUPPORT_CONFOUNDED,
                "these offsets shift the CoP by a constant in their foot's frame, as the SESC "
                "components of the body fixed to that sole do; poses on the other foot "
                "separate them",
                sparse_terms(xcomp, mass_labels, tol=1e-2),
            )
        )
    return namer.out
