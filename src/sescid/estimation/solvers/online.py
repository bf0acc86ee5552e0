"""Recursive (online) identification: information-form Kalman filter / RLS with the CAD prior.

The state is the information pair ``(H, η)``: ``H = ΦᵀWΦ + (σ²/τ²) I`` and
``η = ΦᵀWy + (σ²/τ²) x0`` (prior ``N(x0, τ²I)``, noise σ). Each pose adds its two rows
(``update`` takes one pose or a chunk, vectorised over the chunk), and the estimate
``x̂ = H⁻¹η`` is at every step exactly the batch MAP solution for the data seen so far
(``sescid.prior`` with the same τ, σ). With no prior (``prior_scale=None``) it is least squares,
undetermined directions filled from ``r_prior`` (``sescid.estimate.solve``).

Convergence: after each update the estimator predicts the RMS standard error ``s`` of the CoP
over a fixed set of reference poses (random ±30° poses unless given),
``s² = σ² tr(G H⁻¹) / 2``, ``G`` the mean of ``φᵀφ`` over them. It has converged when ``s`` is
finite and fell by less than ``tol`` (relative) over the last ``window`` poses.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from sescid.errors import SescidError
from sescid.estimation.result.fit import Fit
from sescid.estimation.result.identifiability import DEFAULT_RTOL, identifiable_eigen
from sescid.estimation.result.records import OnlineInfo
from sescid.estimation.solvers.least_squares import cop_system, fit_least_squares
from sescid.estimation.solvers.map import fit_map
from sescid.estimation.solvers.options import MapOptions
from sescid.estimation.sums.normal_equations import NormalEquations
from sescid.estimation.sums.system import accumulate
from sescid.robot import Robot
from sescid.simulation import random_poses


@dataclass
class Step:
    """Status after an update: poses seen, rank, predicted RMS CoP standard error (m)."""

    n_poses: int
    rank: int
    cop_std: float  #: predicted RMS CoP standard error over the reference poses, m (inf: not yet)
    noise: float  #: σ used (given, or the running residual estimate), m
    converged: bool


#: where the predicted CoP std is averaged: (count, range in degrees, seed) of random poses
REFERENCE_POSES = (200, 30.0, 12345)


def std_converged(past: float, std: float, tol: float) -> bool:
    """The stop rule of a sequential fit: the predicted std fell from ``past`` (``window``
    poses earlier; nan: none yet) to ``std`` by less than ``tol`` (relative)."""
    return math.isfinite(std) and math.isfinite(past) and (past - std) / std < tol


class OnlineEstimator:
    """Pose-by-pose identification; ``fit()`` gives the batch-equivalent ``Fit`` at any time.

    ``prior_scale`` τ (m) and ``noise`` σ (m) define the prior's weight σ²/τ²: both are needed
    for a prior (an online estimator cannot re-choose τ by evidence without revisiting the
    data). ``window`` poses and ``tol`` define convergence (module docstring).
    """

    def __init__(
        self,
        robot: Robot,
        *,
        prior_scale: float | None = None,
        noise: float | None = None,
        r_prior: np.ndarray | None = None,
        window: int = 20,
        tol: float = 0.05,
        rtol: float = DEFAULT_RTOL,
    ):
        if prior_scale is not None and noise is None:
            raise SescidError("an online prior needs the CoP noise σ (m) beside the prior scale")
        for value, what in ((prior_scale, "prior scale"), (noise, "noise")):
            if value is not None and not (math.isfinite(value) and value > 0):
                raise SescidError(f"{what} must be a positive number of metres, got {value}")
        if window < 1 or not 0 < tol < 1:
            raise SescidError(f"convergence needs window ≥ 1 and 0 < tol < 1, got {window}, {tol}")
        self.robot = robot
        self.prior_scale = prior_scale
        self.noise = noise
        self.r_prior = robot.sesc_vectors() if r_prior is None else np.asarray(r_prior, float)
        self.window, self.tol, self.rtol = window, tol, rtol
        q_ref = random_poses(robot, *REFERENCE_POSES)
        phi = robot.regressor(q_ref, (0, 1)).reshape(-1, 3 * len(robot.body_names))
        self._g = phi.T @ phi / q_ref.shape[0]  # mean φᵀφ per pose (two rows)
        self.ne = NormalEquations.empty(3 * len(robot.body_names))
        self.history: list[Step] = []
        self._weighted = False

    # --- the recursion ------------------------------------------------------------------
    def update(self, q, cop, sigma=None, gravity=None) -> Step:
        """Add one pose (nq,) / (1, nq) or a chunk (n, nq) [rad] with CoP (n, 2) [m];
        ``gravity`` (n, 3): the gravity direction per pose in the support frame (tilted rows)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        cop = np.atleast_2d(np.asarray(cop, dtype=float))
        g = None if gravity is None else np.atleast_2d(np.asarray(gravity, dtype=float))
        accumulate(self.robot, [(q, cop, sigma, g)], self.ne)
        self._weighted = self._weighted or sigma is not None
        step = self._status()
        self.history.append(step)
        return step

    def _ridge(self) -> float:
        if self.prior_scale is None or self.noise is None:
            return 0.0
        return (self.noise / self.prior_scale) ** 2

    def _information(self) -> tuple[np.ndarray, np.ndarray]:
        lam = self._ridge()
        x0 = self.r_prior.reshape(-1)
        return self.ne.ata + lam * np.eye(x0.size), self.ne.atb + lam * x0

    def estimate(self) -> np.ndarray:
        """Current SESC vectors (N, 3), m."""
        import scipy.linalg  # lazy: scipy's import is ~0.3 s of every command

        if self.prior_scale is None:
            return self.fit().r
        h, eta = self._information()
        return scipy.linalg.solve(h, eta, assume_a="pos").reshape(-1, 3)

    def _status(self) -> Step:
        import scipy.linalg

        ne = self.ne
        if self.prior_scale is not None:
            h, _ = self._information()
            hinv = scipy.linalg.inv(h)
            rank = identifiable_eigen(ne.ata, self.rtol)[0].size if ne.n_rows else 0
            assert self.noise is not None  # a prior needs σ (checked in __init__)
            noise = self.noise
            std = noise * math.sqrt(max(np.sum(self._g * hinv), 0.0) / 2)
        else:
            lp, vp = identifiable_eigen(ne.ata, self.rtol)
            rank = lp.size
            unseen = np.trace(self._g) - np.sum((self._g @ vp) * vp)
            noise = self.noise if self.noise is not None else self._running_noise(vp, lp)
            if unseen > 1e-9 * np.trace(self._g) or not math.isfinite(noise):
                std = math.inf  # the reference CoPs depend on directions not yet determined
            else:
                std = noise * math.sqrt(np.sum((self._g @ vp) * vp / lp) / 2)
        return Step(
            ne.n_poses, rank, std, noise, std_converged(self._past(ne.n_poses), std, self.tol)
        )

    def _running_noise(self, vp, lam) -> float:
        dof = self.ne.n_rows - vp.shape[1]
        if dof <= 0:
            return math.inf
        x0 = self.r_prior.reshape(-1)
        c = vp.T @ (self.ne.atb - self.ne.ata @ x0)
        ztz = self.ne.rss(x0)
        return math.sqrt(max(ztz - np.sum(c**2 / lam), 0.0) / dof)

    def _past(self, n: int) -> float:
        """The predicted std ``window`` poses before ``n`` poses (nan: none yet)."""
        past = [s.cop_std for s in self.history if s.n_poses <= n - self.window]
        return past[-1] if past else math.nan

    @property
    def converged_at(self) -> int | None:
        """Poses seen when convergence was first reached (None: not yet)."""
        for s in self.history:
            if s.converged:
                return s.n_poses
        return None

    def fit(self) -> Fit:
        """The batch-equivalent Fit for the data seen so far (MAP with the prior, else LS)."""
        if self.ne.n_poses == 0:
            raise SescidError("no poses seen yet")
        system = cop_system(self.robot, self.ne, weighted=self._weighted)
        if self.prior_scale is None:
            fit = fit_least_squares(
                self.robot, system, rtol=self.rtol, r_prior=self.r_prior, allow_exact=True
            )
        else:
            fit = fit_map(
                self.robot,
                system,
                MapOptions(prior_scale=self.prior_scale, noise=self.noise, prior="sesc"),
                r_prior=self.r_prior,
                rtol=self.rtol,
            )
        return dataclasses.replace(
            fit,
            online=OnlineInfo(
                window=self.window,
                tol=self.tol,
                converged_at=self.converged_at,
                cop_std=[s.cop_std for s in self.history],
                n_poses=[s.n_poses for s in self.history],
            ),
        )
