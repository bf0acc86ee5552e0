"""Least squares over the pooled system: every kind weighed by its own noise, one rank rule.

θ = [vec(r); nuisance] solves the normal equations A θ = b with A = Σ_k A_k / σ_k² over the
measurement kinds k. Not every direction is determined (the OP2's CoP rows have rank 42 of 63):
the solution is taken in the eigenbasis of A and the undetermined directions are filled from the
prior θ0 = [vec(r_prior); 0] — the least-squares solution closest to the prior model:

    θ̂ = θ0 + V_p Λ_p⁻¹ V_pᵀ (b − A θ0).

Noise: with one kind, σ̂² = RSS / (n − p) as usual (the rows' scale does not change θ̂). With
several kinds, their noises are estimated together (variance components, Förstner's iteration):
σ_k² = RSS_k / r_k with r_k = n_k − tr(A_k/σ_k² · A⁺) each kind's share of the redundancy; a
given σ_k is held fixed. A fit with no residual degrees of freedom (n − p ≤ 0) cannot estimate
any noise: it is refused unless asked for, and then its σ̂ and every standard error are nan,
"not determined", never 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.errors import DataError
from sescid.estimation.result.identifiability import (
    DEFAULT_RTOL,
    check_rtol,
    eigen_rank,
    poses_needed,
)
from sescid.estimation.result.records import NoiseSource
from sescid.estimation.sums.normal_equations import NormalEquations
from sescid.estimation.sums.system import System
from sescid.kinds import BALANCE, COP, TORQUE, Kind

#: unit of each kind's rows, and the noise a weighted-free multi-kind fit starts from
UNITS: dict[Kind, str] = {COP: "m", TORQUE: "N·m", BALANCE: "rad"}
START_NOISE: dict[Kind, float] = {COP: 0.005, TORQUE: 0.05, BALANCE: 0.01}
#: a kind's estimated noise is never taken below this fraction of its measurements' RMS (a
#: noise-free kind would otherwise outweigh the others by any factor and hide what only they
#: determine below the rank tolerance)
NOISE_FLOOR = 1e-6
#: variance-component iterations stop when every σ_k changed by less than this (relative)
VCE_TOL = 1e-10
VCE_MAX_ITER = 200


@dataclass(frozen=True)
class Solution:
    """Least-squares estimate of θ and what the data determine (see the module docstring)."""

    theta: np.ndarray  #: (P,) estimate, undetermined directions from the prior
    theta0: np.ndarray  #: (P,) the prior
    cov: np.ndarray  #: (P, P) covariance (nan when no degrees of freedom are left)
    ata: np.ndarray  #: (P, P) the weighted normal matrix A = Σ A_k / σ_k²
    lam: np.ndarray  #: (P,) its eigenvalues, descending
    vecs: np.ndarray  #: (P, P) its eigenvectors (columns)
    rank: int
    n_rows: int
    scale: float  #: σ̂ of the weighted residuals (≈ 1 when the σ_k are right; m for one CoP kind)
    noise: dict[Kind, float]  #: σ_k per kind (nan: not determined)
    noise_by: dict[Kind, NoiseSource]
    dof: dict[Kind, float]  #: each kind's share of the redundancy
    rss: dict[Kind, float]  #: each kind's residual sum of squares (its own weights)

    @property
    def basis(self) -> np.ndarray:
        """(P, rank) orthonormal basis of the identifiable subspace of θ."""
        return self.vecs[:, : self.rank]

    @property
    def singular_values(self) -> np.ndarray:
        """(P,) √λ, descending."""
        return np.sqrt(np.clip(self.lam, 0, None))


def weighted_sums(system: System, noise: dict[Kind, float]) -> NormalEquations:
    """Σ_k (A_k, b_k, yᵀy_k) / σ_k²: one kind with σ = 1 is its own sums, unscaled (the same
    bits as before kinds existed)."""
    kinds = system.kinds
    if len(kinds) == 1 and noise[kinds[0]] == 1.0:
        return system.parts[kinds[0]].ne
    size = system.size
    out = NormalEquations.empty(size)
    for k in kinds:
        ne, w = system.parts[k].ne, 1.0 / noise[k] ** 2
        out.ata += ne.ata * w
        out.atb += ne.atb * w
        out.yty += ne.yty * w
        out.n_rows += ne.n_rows
    out.n_poses = system.n_poses
    return out


def _estimate(ne: NormalEquations, theta0: np.ndarray, rtol: float):
    lam, vecs, p = eigen_rank(ne.ata, rtol)
    vp, lp = vecs[:, :p], lam[:p]
    theta = theta0 + vp @ ((vp.T @ (ne.atb - ne.ata @ theta0)) / lp)
    return theta, lam, vecs, p


def solve_system(
    system: System,
    theta0: np.ndarray,
    *,
    rtol: float = DEFAULT_RTOL,
    noise: dict[Kind, float] | None = None,
    allow_exact: bool = False,
    structural: int = 0,
) -> Solution:
    """Least squares over the system's kinds (module docstring); ``noise`` gives σ_k of some
    kinds (m, N·m, or a dimensionless scale for weighted rows), the others are estimated.
    DataError when no residual degrees of freedom are left, unless ``allow_exact``;
    ``structural``: how many combinations such data determine on generic poses (for the
    number of poses the error asks for)."""
    check_rtol(rtol)
    if system.n_poses == 0:
        raise DataError("no poses to identify from")
    given = {k: float(v) for k, v in (noise or {}).items() if k in system.parts}
    kinds = system.kinds
    if len(kinds) == 1:
        sigma = {kinds[0]: given.get(kinds[0], 1.0)}
    else:
        sigma = {
            k: given.get(k, 1.0 if system.parts[k].weighted else START_NOISE[k]) for k in kinds
        }
    for _ in range(VCE_MAX_ITER if len(kinds) > 1 else 1):
        ne = weighted_sums(system, sigma)
        theta, lam, vecs, p = _estimate(ne, theta0, rtol)
        if len(kinds) == 1:
            break
        share = _dof_shares(system, sigma, lam, vecs, p)
        new = dict(sigma)
        for k in kinds:
            if k not in given and share[k] > 0:
                part = system.parts[k].ne
                floor = NOISE_FLOOR * math.sqrt(part.yty / max(part.n_rows, 1))
                new[k] = max(math.sqrt(max(part.rss(theta), 0.0) / share[k]), floor) or sigma[k]
        done = all(abs(new[k] - sigma[k]) <= VCE_TOL * sigma[k] for k in kinds)
        sigma = new
        if done:
            break
    n_rows = sum(system.parts[k].ne.n_rows for k in kinds)
    dof_total = n_rows - p
    if dof_total <= 0 and not allow_exact:
        need = poses_needed(max(p, structural), n_rows / max(system.n_poses, 1))
        poses = f"{system.n_poses} pose" + (" is" if system.n_poses == 1 else "s are")
        where = f"{', '.join(system.sources)}: " if system.sources else ""
        raise DataError(
            f"{where}{poses} too few: {n_rows} equations for the {p} combinations the data "
            "determine leave no degrees of freedom to estimate the noise, so nothing could be "
            f"said about the fit's accuracy; at least {need} poses are needed (or ask for an "
            "exact fit: "
            "allow_exact / --allow-exact)"
        )
    rss = {k: max(system.parts[k].ne.rss(theta), 0.0) for k in kinds}
    shares = _dof_shares(system, sigma, lam, vecs, p) if len(kinds) > 1 else {kinds[0]: dof_total}
    scale = math.sqrt(max(ne.rss(theta), 0.0) / dof_total) if dof_total > 0 else math.nan
    noise_out: dict[Kind, float] = {}
    noise_by: dict[Kind, NoiseSource] = {}
    for k in kinds:
        if k in given:
            noise_out[k], noise_by[k] = given[k], "given"
        elif dof_total <= 0 or shares[k] <= 0:
            noise_out[k], noise_by[k] = math.nan, "not determined"
        elif len(kinds) == 1:
            noise_out[k], noise_by[k] = scale, "estimated"
        else:
            noise_out[k], noise_by[k] = sigma[k], "estimated"
    vp, lp = vecs[:, :p], lam[:p]
    known = len(kinds) > 1 or kinds[0] in given  # rows already scaled by their noise
    if known:
        factor = 1.0 if all(noise_by[k] != "not determined" for k in kinds) else math.nan
    else:
        factor = scale**2
    cov = (vp / lp) @ vp.T * factor
    return Solution(
        theta=theta,
        theta0=theta0,
        cov=cov,
        ata=ne.ata,
        lam=lam,
        vecs=vecs,
        rank=p,
        n_rows=n_rows,
        scale=scale
        if not known
        else (math.sqrt(max(ne.rss(theta), 0.0) / dof_total) if dof_total > 0 else math.nan),
        noise=noise_out,
        noise_by=noise_by,
        dof=shares,
        rss=rss,
    )


def _dof_shares(system: System, sigma, lam, vecs, p) -> dict[Kind, float]:
    """r_k = n_k − tr(A_k/σ_k² A⁺): each kind's share of the redundancy n − p."""
    vp, lp = vecs[:, :p], lam[:p]
    out = {}
    for k in system.kinds:
        ne = system.parts[k].ne
        used = float(np.sum((vp.T @ ne.ata @ vp).diagonal() / lp)) / sigma[k] ** 2
        out[k] = ne.n_rows - used
    return out


def marginal_x(sol: Solution, n_x: int, rtol: float):
    """(λ, V, p) of the information about vec(r) with the nuisance marginalised (the Schur
    complement of A); A's own eigen-decomposition when there is no nuisance."""
    if sol.ata.shape[0] == n_x:
        return sol.lam, sol.vecs, sol.rank
    a = sol.ata
    axx, axn, ann = a[:n_x, :n_x], a[:n_x, n_x:], a[n_x:, n_x:]
    schur = axx - axn @ np.linalg.pinv(ann, rcond=1e-12, hermitian=True) @ axn.T
    return eigen_rank((schur + schur.T) / 2, rtol)
