"""The CAD prior of a MAP fit: its precision over θ = [vec(r); nuisance] at a scale τ, per
SESC component or per body (masses and first moments, their sum held), decoupled from what a CoP
cannot see."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from sescid.estimation.result.records import PriorShape
from sescid.estimation.solvers.options import PriorChoice
from sescid.estimation.solvers.solve import Solution, marginal_x
from sescid.estimation.sums.pooled import check_pooled_prior
from sescid.estimation.sums.system import System
from sescid.kinds import BALANCE, COP, TORQUE
from sescid.robot import Robot


@dataclass(frozen=True)
class Prior:
    """The prior precision over θ = [vec(r); nuisance] for a scale τ: on vec(r), 1/τ² I
    ("sesc": every SESC component ±τ m) or Σ₀⁻¹/τ² ("bodies": each body's mass ±τ (relative)
    and first moment ±τ·ℓ per unit mass, mapped to r; Σ₀ = K D Kᵀ), and 1/s² on each nuisance
    parameter (effectively flat)."""

    n_x: int
    nuisance_scales: np.ndarray  #: (K,) prior std of each nuisance parameter
    x_precision: np.ndarray | None = None  #: Σ₀⁻¹ (3N, 3N); None: the identity
    x_logdet: float = 0.0  #: log det Σ₀⁻¹
    kind: PriorShape = "sesc"

    def matrix(self, tau: float) -> np.ndarray:
        """(P, P) prior precision for scale τ."""
        size = self.n_x + self.nuisance_scales.size
        out = np.zeros((size, size))
        if self.x_precision is None:
            out[: self.n_x, : self.n_x] = np.eye(self.n_x) / tau**2
        else:
            out[: self.n_x, : self.n_x] = self.x_precision / tau**2
        k = np.arange(self.n_x, size)
        out[k, k] = 1.0 / self.nuisance_scales**2
        return out

    def logdet(self, tau: float) -> float:
        """Log det of ``matrix(tau)``."""
        x = self.x_logdet - 2 * self.n_x * math.log(tau)
        return x - 2 * float(np.sum(np.log(self.nuisance_scales)))


#: the "bodies" prior: a body's first moment per unit relative mass std, m (τ = 0.1 → ±5 mm)
BODY_COM_SCALE = 0.05


def _carrying(robot: Robot) -> np.ndarray:
    """(N,) 1 for a body that can carry mass, 0 for a frame-only one (``Body.frame_only``: a
    frame between two hinges of one MJCF body, which the model file cannot give mass): the
    prior gives it no mass, so the fit's SESC vectors stay reachable by masses the file holds."""
    return np.array([0.0 if b.frame_only else 1.0 for b in robot.model.bodies])


def _precision(cov: np.ndarray) -> tuple[np.ndarray, float]:
    """(Σ₀⁻¹, log det Σ₀⁻¹) of a symmetric prior covariance, its eigenvalues held at least
    1e-12 of the largest (a direction the prior holds at zero stays all but fixed)."""
    lam, vecs = np.linalg.eigh(cov)
    lam = np.maximum(lam, 1e-12 * lam.max())
    return (vecs / lam) @ vecs.T, float(-np.sum(np.log(lam)))


def mass_covariance(m_bar: np.ndarray, fixed_total: bool) -> np.ndarray:
    """(N, N) prior covariance of the mass fractions m/M per unit τ²: each ±m̄ independently,
    conditioned on their sum staying 1 when ``fixed_total`` (Σ − Σ1 1ᵀΣ / 1ᵀΣ1). The SESC
    vectors are first moments per unit of the total mass, so a common growth of every body's
    fraction is no robot at all: it would scale every SESC vector, moving the CoM along its
    own position (its height too) by the prior's shape alone."""
    var = m_bar**2
    cov = np.diag(var)
    if fixed_total:
        cov -= np.outer(var, var) / var.sum()
    return cov


def body_prior(
    robot: Robot, n_x: int, nuisance_scales: np.ndarray, fixed_total: bool = True
) -> Prior:
    """The per-body prior (``Prior`` "bodies"): body masses m̄_j = m_j + M/(10 N) ± τ m̄_j
    (their sum held at the total mass when ``fixed_total``: ``mass_covariance``) and first
    moments ± τ·``BODY_COM_SCALE``·m̄_j per axis, independent, mapped to vec(r); a frame-only
    body ± 0 (``_carrying``)."""
    from sescid.estimation.solvers.consistent import H_UNIT, sesc_map

    k = sesc_map(robot)  # vec(r) = K [m/M, vec(h)/(M ℓ)]
    masses = robot.masses
    big_m = float(masses.sum())
    m_bar = _carrying(robot) * (masses + big_m / (10 * masses.size)) / big_m
    nb = masses.size
    k_m, k_h = k[:, :nb], k[:, nb:]
    d_h = np.repeat((BODY_COM_SCALE * m_bar / H_UNIT) ** 2, 3)
    sigma0 = k_m @ mass_covariance(m_bar, fixed_total) @ k_m.T + (k_h * d_h) @ k_h.T
    return Prior(n_x, nuisance_scales, *_precision((sigma0 + sigma0.T) / 2), "bodies")


#: relative prior variance below which a direction of vec(r) is out of the prior's reach
OUT_OF_REACH = 1e-9


def decoupled(prior: Prior, seen: np.ndarray) -> Prior:
    """The prior with no correlation between the directions of vec(r) the data see (``seen``,
    (n_x, p) orthonormal) and the rest: Σ₀ → PΣ₀P + QΣ₀Q (P the projector on ``seen``,
    Q = I − P). A per-body prior correlates them, so a CoP along one direction would move its
    unseen partners (the CoM height a level CoP cannot see) by the prior's shape alone (on
    TALOS, one shoulder moving: the CoM worse than CAD's in 5 of 10 draws, 0 of 10 decoupled);
    decoupled, what the data cannot see keeps the prior's value and uncertainty. Fits of CoP
    (and balance) data only: a joint torque's unseen directions — a held body's mass — follow
    from the seen ones by the total mass, a correlation the prior must keep (TALOS in a gantry:
    8.51 mm decoupled against 6.03 mm, ``tools/defaults_study.py``)."""
    n, p = prior.n_x, seen.shape[1]
    if prior.x_precision is None or p in (0, n):
        return prior
    w, v = np.linalg.eigh((prior.x_precision + prior.x_precision.T) / 2)
    cov = (v / w) @ v.T
    proj = seen @ seen.T
    comp = np.eye(n) - proj
    split = proj @ cov @ proj + comp @ cov @ comp
    # kept inside Σ₀'s range: a direction the prior holds at zero (the SESC part of a frame-only
    # body, which no mass of the file can give) stays at zero when split
    reach = v[:, 1.0 / w > OUT_OF_REACH * (1.0 / w).max()]
    cov = reach @ (reach.T @ split @ reach) @ reach.T
    precision, logdet = _precision((cov + cov.T) / 2)
    return dataclasses.replace(prior, x_precision=precision, x_logdet=logdet)


def pooled_body_prior(robot: Robot, nuisance_scales: np.ndarray, fixed_total: bool = True) -> Prior:
    """The per-body prior (``body_prior``) over a pooled system's body parameters x
    (``pooled``): each body's mass ±τ m̄ (their sum held when ``fixed_total``:
    ``mass_covariance``) and first moment ±τ·``BODY_COM_SCALE``·m̄ per axis, independent,
    m̄ = (m + M/(10 N)) / M."""
    from sescid.estimation.sums.pooled import PARAM_UNIT

    masses = robot.masses
    big_m = float(masses.sum())
    m_bar = (masses + big_m / (10 * masses.size)) / big_m
    m_bar = np.where(_carrying(robot) > 0, m_bar, 1e-6 * m_bar)
    nb = masses.size
    cov = np.zeros((4 * nb, 4 * nb))
    cov[:nb, :nb] = mass_covariance(m_bar, fixed_total)
    cov[nb:, nb:] = np.diag(np.repeat((BODY_COM_SCALE * m_bar / PARAM_UNIT) ** 2, 3))
    return Prior(cov.shape[0], nuisance_scales, *_precision(cov), "bodies")


def system_prior(
    robot: Robot, system: System, prior: PriorChoice, ls: Solution, rtol: float
) -> Prior:
    """The prior of a MAP fit of ``system`` (least squares' solution ``ls``): per body for
    "bodies" or "auto" (it serves the CoP and the torques best, docs/defaults.md) or a pooled
    system, else per SESC component; decoupled from what the data do not see for CoP and
    balance data. The SESC vectors are per unit of the total mass: the mass fractions sum to 1,
    unless torques without a weighed mass leave the model's mass as their scale (the data see
    it)."""
    n_x = system.n_x
    scales = np.array([n.prior_scale for n in system.nuisance], dtype=float)
    if prior == "auto":
        prior = "bodies"
    fixed_total = system.mass_given or TORQUE not in system.kinds
    if system.space == "bodies":
        check_pooled_prior(prior)
        pri = pooled_body_prior(robot, scales, fixed_total)
    elif prior == "bodies":
        pri = body_prior(robot, n_x, scales, fixed_total)
    else:
        pri = Prior(n_x, scales)
    if set(system.kinds) <= {COP, BALANCE}:  # what a CoP cannot see stays the prior's
        _, seen, p = marginal_x(ls, n_x, rtol)
        pri = decoupled(pri, seen[:, :p])
    return pri
