"""A guided session's estimate after each measured pose, and the quantity its stop rule watches.

- A CoP session (``CopEstimate``): the recursive estimator ``estimation.OnlineEstimator``
  (weighted by the CoP standard errors, gravity logged by the robot), at every step equal to
  ``identify --weighted`` on the poses so far; its stop quantity is the predicted RMS CoP
  standard error over reference poses.
- A session with joint torques, alone or with the CoP (``BatchEstimate``): ``identify`` itself
  on every pose measured so far, held in memory (a session has tens of poses: a few ms per
  fit) — weighted least squares with the offsets (and friction bands, when the robot says from
  which side it approached) estimated, exactly ``sescid identify --weighted`` on the session's
  measured.csv. Its stop quantity is the predicted RMS standard error of the CoM x/y over the
  same reference poses, in the subspace the session's kinds determine (torques never see the
  support body's own horizontal moments: that constant is the model's); infinite until the
  poses determine all of it.

Both converge when that standard error fell by less than ``tol`` (relative) over the last
``window`` measured poses.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from sescid.errors import DataError
from sescid.estimation import (
    IdentifyOptions,
    Measurements,
    Method,
    OnlineEstimator,
    fit_measurements,
)
from sescid.estimation.data.measurements import concatenate
from sescid.estimation.result.fit import Fit
from sescid.estimation.solvers.online import REFERENCE_POSES, std_converged
from sescid.kinds import COP, TORQUE, Kinds
from sescid.planning import Quantity
from sescid.robot import Robot
from sescid.session.records import BODY_PRIOR_SCALE
from sescid.simulation import random_poses

#: a torque estimate's CoP checks stability once its predicted std is below this share of the
#: stability box's half-size
TRUST = 0.25


@dataclass(frozen=True)
class Status:
    """After an update: the stop quantity's predicted std [m] (inf: not yet), the rank."""

    std: float
    rank: int
    converged: bool


def step_status(history: list[tuple[int, float]], n: int, std: float, rank: int, window: int,
                tol: float) -> Status:  # fmt: skip
    """The ``Status`` of an update at ``n`` poses, then appended to ``history`` ((poses, std) of
    the updates): converged by ``OnlineEstimator``'s rule (``std_converged``) over the last
    ``window`` poses."""
    past = [s for k, s in history if k <= n - window]
    done = std_converged(past[-1] if past else math.nan, std, tol)
    history.append((n, std))
    return Status(std, rank, done)


def _prior_std(basis: np.ndarray, info: np.ndarray, n_bodies: int) -> np.ndarray:
    """(N,) RMS SESC std per body [m] over ``basis`` (3N, p) given its information (p, p),
    with a prior of scale ``BODY_PRIOR_SCALE`` (undetermined directions show as the prior)."""
    h = info + np.eye(basis.shape[1]) / BODY_PRIOR_SCALE**2
    cov = basis @ np.linalg.inv(h) @ basis.T
    return np.sqrt(np.maximum(np.diag(cov).reshape(n_bodies, 3).sum(axis=1), 0.0))


class CopEstimate:
    """A CoP session's estimate (module docstring)."""

    quantity: Quantity = "CoP"

    def __init__(self, robot: Robot, basis: np.ndarray, window: int, tol: float):
        self.robot, self.basis = robot, basis
        self.est = OnlineEstimator(robot, window=window, tol=tol)

    @property
    def n_poses(self) -> int:
        """Poses measured so far."""
        return int(self.est.ne.n_poses)

    def update(self, m: Measurements) -> Status:
        """Add a measured pose (the data of one row of ``measure``'s output)."""
        st = self.est.update(m.q, m.cop, m.cop_se, m.gravity)  # as identify does
        return Status(st.cop_std, st.rank, st.converged)

    def estimate(self) -> np.ndarray:
        """(N, 3) least-squares SESC vectors in the identifiable subspace, the rest from the
        prior (minimum-norm step): its CoP equals the batch fit's once every identifiable
        combination is determined."""
        x0 = self.est.r_prior.reshape(-1)
        h = self.basis.T @ self.est.ne.ata @ self.basis
        g = self.basis.T @ (self.est.ne.atb - self.est.ne.ata @ x0)
        step = np.linalg.pinv(h, rcond=1e-10, hermitian=True) @ g
        return (x0 + self.basis @ step).reshape(-1, 3)

    def identified(self, rank: int, half: np.ndarray) -> bool:
        """Every combination the candidates determine is determined (its CoP is then trusted
        for the stability check)."""
        del half
        return rank >= self.basis.shape[1]

    def body_std(self) -> np.ndarray:
        """(N,) per-body SESC std [m] (prior scale ``BODY_PRIOR_SCALE``)."""
        s = self.est.history[-1].noise if self.est.history else 1.0
        s = s if math.isfinite(s) and s > 0 else 1.0
        info = self.basis.T @ self.est.ne.ata @ self.basis / s**2
        return _prior_std(self.basis, info, len(self.robot.body_names))

    def fit(self) -> Fit:
        """The fit of the poses so far (batch-equivalent)."""
        return self.est.fit()


def pose_measurements(data: Measurements, kinds: Kinds, source: str) -> Measurements:
    """One reduced pose's data with only the session's ``kinds``, named ``source`` (DataError
    when a torque is not determined; an approach side not determined is left out)."""
    if TORQUE in kinds and (data.tau is None or not np.all(np.isfinite(data.tau))):
        raise DataError(f"{source}: a joint's torque is not determined (too few samples)")
    if data.approach is not None and not np.all(np.isfinite(data.approach)):
        data = dataclasses.replace(data, approach=None)
    data = data if TORQUE in kinds else data.without(TORQUE)
    data = data if COP in kinds else data.without(COP)
    return dataclasses.replace(data, source=source)


class BatchEstimate:
    """A session with joint torques: ``identify`` on every pose so far (module docstring)."""

    quantity: Quantity = "CoM x/y"

    def __init__(
        self,
        robot: Robot,
        basis: np.ndarray,
        window: int,
        tol: float,
        total_mass: float | None = None,
        method: Method = "map",
    ):
        self.robot, self.basis = robot, basis
        self.window, self.tol, self.total_mass = window, tol, total_mass
        self.method = method
        q_ref = random_poses(robot, *REFERENCE_POSES)  # as ``OnlineEstimator``'s
        phi = robot.regressor(q_ref, (0, 1)).reshape(-1, basis.shape[0]) @ basis
        self._g = phi.T @ phi / len(q_ref)  # mean (φV)ᵀ(φV) per pose (two rows)
        self.parts: list[Measurements] = []
        self.last: Fit | None = None
        self.history: list[tuple[int, float]] = []

    @property
    def n_poses(self) -> int:
        """Poses measured so far."""
        return len(self.parts)

    def data(self) -> Measurements:
        """Every pose measured so far, one data set."""
        return concatenate(self.parts)

    def _identify(self, allow_exact: bool = False) -> Fit:
        options = IdentifyOptions(
            weighted=True, allow_exact=allow_exact, total_mass=self.total_mass
        )
        return fit_measurements(self.robot, self.data(), method=self.method, options=options)

    def update(self, m: Measurements) -> Status:
        """Add a measured pose; refit."""
        self.parts.append(m)
        try:
            self.last = self._identify()
        except DataError:  # no degrees of freedom yet: nothing said about the accuracy
            self.last = None
        std, rank = math.inf, 0
        if self.last is not None:
            rank = self.last.rank
            c = self.basis.T @ self.last.cov @ self.basis
            if rank >= self.basis.shape[1] and np.all(np.isfinite(c)):
                std = math.sqrt(max(float(np.sum(self._g * c)) / 2, 0.0))
        return step_status(self.history, self.n_poses, std, rank, self.window, self.tol)

    def estimate(self) -> np.ndarray:
        """(N, 3) the latest fit's SESC vectors (the model's before the first fit)."""
        return self.robot.sesc_vectors() if self.last is None else self.last.r

    def identified(self, rank: int, half: np.ndarray) -> bool:
        """Every combination the session's kinds determine is determined, and the predicted
        CoM std is below ``TRUST`` of the stability box's half-size ``half`` (2,) [m]: the
        estimate's CoP is then trusted for the stability check (torques determine everything
        from three poses, long before their offsets are known well)."""
        std = self.history[-1][1] if self.history else math.inf
        ok = self.last is not None and rank >= self.basis.shape[1]
        return ok and std < TRUST * float(np.min(half))

    def body_std(self) -> np.ndarray:
        """(N,) per-body SESC std [m] (prior scale ``BODY_PRIOR_SCALE``; the fit's information
        in the session's subspace, none before the first fit)."""
        info = np.zeros((self.basis.shape[1],) * 2)
        if self.last is not None and np.all(np.isfinite(self.last.cov)):
            info = self.basis.T @ np.linalg.pinv(self.last.cov, hermitian=True) @ self.basis
        return _prior_std(self.basis, info, len(self.robot.body_names))

    def fit(self) -> Fit:
        """The fit of every measured pose (an exact fit, flagged, when too few for noise)."""
        return self.last if self.last is not None else self._identify(allow_exact=True)
