"""Maximum a posteriori identification with a Gaussian CAD prior on the SESC vectors.

Model: ``y = Φ x + e``, ``e ~ N(0, σ² W⁻¹)`` (W = 1 unless per-pose standard errors are given) and
a prior ``x ~ N(x0, τ² I)`` centred on the model's own SESC vectors ``x0 = vec(r_prior)`` (the
manufacturer / CAD values), ``τ`` the prior scale in metres. The posterior is Gaussian:

    x̂ = x0 + M⁻¹ (Φᵀy − A x0),   cov = σ² M⁻¹,   M = A + (σ²/τ²) I,   A = ΦᵀWΦ.

It fills the directions the data cannot see (for CoP data x̂ = x0 there, with the prior's
uncertainty: a per-body prior is decoupled between them and the seen ones,
``map_prior.decoupled``, so a CoP never moves what it cannot see — the CoM height of a level
sole — by the prior's shape alone; torques keep the correlations) and shrinks the poorly
determined ones toward CAD. The per-body prior holds the mass fractions' sum at 1
(``map_prior.mass_covariance``). Data whose distinct poses leave no degrees of freedom (a pose
repeated, ``repeated_poses``) keep the CAD model: the scatter of repeats cannot weigh them
against it. ``τ`` and ``σ`` are chosen,
unless given, by maximising the marginal likelihood (evidence) of the data,

    log p(y | σ, τ) = −½ [m log 2πσ² + log det M − Σ log(σ²/τᵢ²) + (zᵀz − bᵀM⁻¹b)/σ²],

with ``z = y − Φ x0``, ``b = Φᵀz`` — computed from the accumulated normal equations only, so the
same code serves streamed data and the online estimator (``sescid.online``).

Several measurement kinds (CoP and joint torques) enter as one system whose rows are scaled by
each kind's noise as the least-squares fit estimated it (``solve``): σ is then a common scale on
those noises (≈ 1), and the prior weighs against all kinds at once. Nuisance parameters (torque
sensor offsets and friction bands; optionally two constant CoP offsets) get effectively flat
priors (``system.Nuisance.prior_scale``). A CoP offset on one support foot is confounded with the
support body's own x/y SESC components, whose effect on the CoP is constant too: least squares
cannot separate them; the prior on the support body's r (scale τ) is what separates them here, so
the offset is known to ± ≈ τ only — it is identifiable from the data alone only with data from a
second support foot (or torques, which do not see the support body at all).

A MAP fit says which directions its prior, not its data, decided: those the data do not see
(``fit.unidentifiable``) and those where the prior outweighs the data (``MapInfo.prior_decided``:
the data carry less than half of the posterior information along them).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from sescid.errors import SescidError
from sescid.estimation.result.fit import Fit
from sescid.estimation.result.identifiability import DEFAULT_RTOL, combination_vector
from sescid.estimation.result.records import REPEATED, CopOffset, MapInfo, NuisanceEstimate
from sescid.estimation.solvers.least_squares import (
    fit_from_solution,
    marginal_x,
    named,
    nuisance_estimates,
    prior_theta,
    reference_view,
    weak_directions,
)
from sescid.estimation.solvers.map_prior import BODY_COM_SCALE, Prior, system_prior
from sescid.estimation.solvers.options import MapOptions
from sescid.estimation.solvers.solve import Solution, solve_system, weighted_sums
from sescid.estimation.sums.distinct import SAME_POSE
from sescid.estimation.sums.normal_equations import NormalEquations
from sescid.estimation.sums.pooled import body_fit, stance_map
from sescid.estimation.sums.system import System
from sescid.kinds import Kind
from sescid.robot import Robot

#: search range of the prior scale τ and the noise σ for evidence maximisation, m
TAU_RANGE = (1e-6, 1.0)
#: search range of σ: m, or the dimensionless scale on given standard errors; its upper end is
#: widened to ``SIGMA_HEADROOM`` × the RMS residual of the prior model (a weighted scale may be ≫ 1)
SIGMA_RANGE = (1e-7, 1.0)
SIGMA_HEADROOM = 10.0
#: a direction is "decided by the prior" when the data carry less than this share of its
#: posterior information
PRIOR_DECIDED = 0.5


@dataclass
class Posterior:
    """Gaussian posterior of the parameters for given σ and τ (all in metres)."""

    x: np.ndarray  #: (P,) posterior mean
    cov: np.ndarray  #: (P, P) posterior covariance, m²
    noise: float  #: σ, CoP noise standard deviation (or scale on given standard errors)
    prior_scale: float  #: τ, prior standard deviation of each SESC component
    log_evidence: float
    edf: float  #: effective number of parameters tr(A M⁻¹)


WEAK_REASON_MAP = (
    "barely excited by these poses (its information is below 10⁻⁷ of the largest): the prior "
    "decides it"
)


def _terms(ne: NormalEquations, x0: np.ndarray):
    b = ne.atb - ne.ata @ x0
    return b, max(ne.rss(x0), 0.0)


def log_evidence(ne: NormalEquations, x0: np.ndarray, prior: Prior, tau: float, noise: float):
    """Log p(y | σ, prior) for the prior at scale τ and noise σ."""
    return Evidence(ne, x0, prior)(tau, noise)


class Evidence:
    """``log_evidence`` of one problem at many (τ, σ): the terms that depend on neither made
    once, the prior's matrix once per τ, LAPACK's Cholesky called directly (the same routines
    as ``scipy.linalg.cho_factor``/``cho_solve``, so the same bits, without their checks: the
    search evaluates it ~650 times a fit, which was most of a MAP fit's fixed cost)."""

    def __init__(self, ne: NormalEquations, x0: np.ndarray, prior: Prior):
        from scipy.linalg import lapack  # lazy: scipy's import is ~0.3 s of every command

        self.ata, self.rows, self.n, self.prior = ne.ata, ne.n_rows, x0.size, prior
        self.b, self.ztz = _terms(ne, x0)
        self._potrf, self._potrs = lapack.dpotrf, lapack.dpotrs
        self._tau, self._matrix = math.nan, np.empty(0)

    def __call__(self, tau: float, noise: float) -> float:
        """Log p(y | σ, prior) at scale τ and noise σ (``log_evidence``)."""
        if tau != self._tau:
            self._tau, self._matrix = tau, self.prior.matrix(tau)
        s2 = noise**2
        c, info = self._potrf(self.ata + s2 * self._matrix, lower=False, clean=False)
        if info != 0:  # not positive definite (cho_factor's LinAlgError), or a NaN
            return -math.inf
        logdet = 2 * np.sum(np.log(np.diag(c)))
        sol, _ = self._potrs(c, self.b, lower=False)
        quad = (self.ztz - self.b @ sol) / s2
        prior_logdet = self.n * math.log(s2) + self.prior.logdet(tau)
        return -0.5 * (
            self.rows * math.log(2 * math.pi * s2) + logdet - prior_logdet + max(quad, 0.0)
        )


def _inverse(m: np.ndarray) -> np.ndarray:
    """The inverse of a symmetric positive definite matrix (Cholesky; when round-off makes it
    lose definiteness — a tiny noise next to unseen directions — its eigen-decomposition with
    the eigenvalues held above round-off)."""
    import scipy.linalg

    try:
        cf = scipy.linalg.cho_factor(m, check_finite=False)
        return scipy.linalg.cho_solve(cf, np.eye(m.shape[0]), check_finite=False)
    except np.linalg.LinAlgError:
        w, v = np.linalg.eigh((m + m.T) / 2)
        w = np.maximum(w, 1e-14 * max(float(w.max()), 1e-300))
        return (v / w) @ v.T


def posterior(ne: NormalEquations, x0: np.ndarray, prior: Prior, tau: float, noise: float):
    """Posterior mean and covariance for the prior at scale τ and noise σ."""
    minv = _inverse(ne.ata + noise**2 * prior.matrix(tau))
    b, _ = _terms(ne, x0)
    x = x0 + minv @ b
    return Posterior(
        x=x,
        cov=noise**2 * minv,
        noise=noise,
        prior_scale=tau,
        log_evidence=log_evidence(ne, x0, prior, tau, noise),
        edf=float(np.sum(minv * ne.ata)),
    )


def maximise_evidence(
    ne: NormalEquations,
    x0: np.ndarray,
    prior: Prior,
    *,
    prior_scale: float | None = None,
    noise: float | None = None,
) -> tuple[float, float]:
    """(τ, σ) maximising the evidence; a given value is held fixed.

    A grid over log τ (25 points in ``TAU_RANGE``) with σ optimised at each, then Brent
    refinement around the best grid point; σ alone is a bounded 1-D search.
    """
    import scipy.optimize

    evidence = Evidence(ne, x0, prior)

    def neg(log_tau: float, log_sigma: float) -> float:
        val = -evidence(math.exp(log_tau), math.exp(log_sigma))
        return val if math.isfinite(val) else 1e300  # singular M: finite for Brent's steps

    s_lo, s_hi = (math.log(v) for v in sigma_range(ne, x0))

    def best_sigma(log_tau: float) -> tuple[float, float]:
        if noise is not None:
            return math.log(noise), neg(log_tau, math.log(noise))
        res = scipy.optimize.minimize_scalar(
            lambda s: neg(log_tau, s), bounds=(s_lo, s_hi), method="bounded"
        )
        return float(res.x), float(res.fun)

    if prior_scale is not None:
        ls, _ = best_sigma(math.log(prior_scale))
        return prior_scale, math.exp(ls)
    grid = np.linspace(math.log(TAU_RANGE[0]), math.log(TAU_RANGE[1]), 25)
    vals = [best_sigma(t)[1] for t in grid]
    k = int(np.argmin(vals))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    res = scipy.optimize.minimize_scalar(
        lambda t: best_sigma(t)[1], bounds=(lo, hi), method="bounded"
    )
    t = float(res.x) if res.fun <= vals[k] else float(grid[k])
    return math.exp(t), math.exp(best_sigma(t)[0])


def sigma_range(ne: NormalEquations, x0: np.ndarray) -> tuple[float, float]:
    """Search range of σ: ``SIGMA_RANGE`` widened to ``SIGMA_HEADROOM`` × the prior's RMS
    residual √(zᵀz/m), so a weighted fit's scale is never capped at 1."""
    _, ztz = _terms(ne, x0)
    rms0 = math.sqrt(ztz / max(ne.n_rows, 1))
    return SIGMA_RANGE[0], max(SIGMA_RANGE[1], SIGMA_HEADROOM * rms0)


def profiled_noise(ne: NormalEquations, x0: np.ndarray, prec: np.ndarray) -> float:
    """Maximum-likelihood σ for a fixed ridge σ²·P, ``prec`` = σ²P (P, P): √((zᵀz − bᵀM⁻¹b)/m)."""
    import scipy.linalg

    b, ztz = _terms(ne, x0)
    quad = b @ scipy.linalg.solve(ne.ata + prec, b, assume_a="pos")
    return math.sqrt(max(ztz - quad, 0.0) / ne.n_rows) or SIGMA_RANGE[0]


def cv_ridge(parts: list[NormalEquations], x0: np.ndarray, unit: np.ndarray, n_poses: int):
    """Ratio σ²/τ² minimising the held-out error of k folds (each fold's weighted sums in
    ``parts``); also the curve [[τ/σ, rmse], …]. ``unit`` (P, P): the prior precision at τ = 1
    (no nuisance part: flat). Each candidate costs one solve per fold."""
    import scipy.linalg

    total_a = sum(p.ata for p in parts)
    total_b = sum(p.atb for p in parts)
    ratios = np.logspace(-4, 2, 31)  # τ/σ (τ = 100σ is practically no prior)
    curve = []
    rows = sum(p.n_rows for p in parts)
    for t in ratios:
        sq = 0.0
        for p in parts:
            a, b = total_a - p.ata, total_b - p.atb
            x = x0 + scipy.linalg.solve(a + unit / t**2, b - a @ x0, assume_a="pos")
            sq += p.rss(x)
        curve.append([float(t), math.sqrt(max(sq, 0.0) / max(rows, 1))])
    best = min(range(len(curve)), key=lambda i: curve[i][1])
    del n_poses
    return 1.0 / ratios[best] ** 2, curve


def fit_map(
    robot: Robot,
    system: System,
    options: MapOptions | None = None,
    *,
    r_prior: np.ndarray | None = None,
    rtol: float = DEFAULT_RTOL,
    cv_folds: list[System] | None = None,
    kind_noise: dict[Kind, float] | None = None,
) -> Fit:
    """MAP ``Fit`` of a pooled system (module docstring). ``options.prior_scale`` τ [m] and
    ``options.noise`` σ (the kinds' common noise scale; m for one unweighted CoP kind) are chosen
    by evidence when None; ``cv_folds``: the systems of k folds of the data, to choose σ²/τ² by
    cross-validation instead; ``kind_noise``: given noise of some kinds (the others from least
    squares); ``options.prior``: "sesc", "bodies" (``Prior``; τ is then relative) or "auto"
    ("bodies" with torque rows, else "sesc")."""
    options = options or MapOptions()
    prior_scale, noise, prior = options.prior_scale, options.noise, options.prior
    if system.n_poses == 0:
        raise SescidError("no poses to identify from")
    theta0 = prior_theta(robot, system, r_prior)
    ls = solve_system(system, theta0, rtol=rtol, noise=kind_noise, allow_exact=True)
    base = fit_from_solution(robot, *reference_view(robot, system, ls, rtol), rtol=rtol)
    weak = weak_directions(ls, system, rtol)
    if weak.shape[1] and system.space != "bodies":
        base = dataclasses.replace(base, weak=named(robot, weak, WEAK_REASON_MAP))
    ratios = _noise_ratios(system, ls)
    ne = weighted_sums(system, ratios)
    n_x = system.n_x
    scales = np.array([n.prior_scale for n in system.nuisance], dtype=float)
    pri = system_prior(robot, system, prior, ls, rtol)

    chosen = "given" if prior_scale is not None else "evidence"
    if prior_scale is None and repeated_poses(system, ls.rank) is not None:
        prior_scale, chosen = TAU_RANGE[0], REPEATED
    curve = None
    if cv_folds is not None and prior_scale is None:
        folds = [weighted_sums(f.embedded(system.nuisance), ratios) for f in cv_folds]
        unit = pri.matrix(1.0)
        unit[n_x:, n_x:] = 1e-12 * np.eye(len(scales))  # the nuisance: flat
        ridge, curve = cv_ridge(folds, theta0, unit, system.n_poses)
        if noise is None:
            noise = profiled_noise(ne, theta0, ridge * unit)
        prior_scale = noise / math.sqrt(ridge)
        chosen = f"{len(cv_folds)}-fold cv"
    tau, sig = maximise_evidence(ne, theta0, pri, prior_scale=prior_scale, noise=noise)
    post = posterior(ne, theta0, pri, tau, sig)
    fit = _map_fit(base, system, post, ls, _Choice(chosen, noise is not None, curve), pri)
    if system.space == "bodies":
        bodies = body_fit(robot, system, ls, post.x[:n_x], post.cov[:n_x, :n_x], rtol)
        fit = dataclasses.replace(fit, bodies=bodies)
    return fit


def repeated_poses(system: System, rank: int) -> str | None:
    """Why the data's distinct poses cannot show the CAD model to be off, or None: repeated
    poses (``distinct.SAME_POSE``) whose distinct ones give no more equations than the ``rank``
    combinations the data determine. An error tied to a pose (a CoP sensor's bias there, the
    foot's compliance) repeats with it: the scatter of repeats measures the noise of a
    reading, not how far a pose's reading is from the truth, so it cannot weigh the data
    against the CAD model (the evidence would take every repeat as new information)."""
    distinct, n = system.distinct_poses, system.n_poses
    if distinct is None or distinct >= n or n == 0:
        return None
    rows = sum(p.ne.n_rows for p in system.parts.values())
    equations = distinct * rows / n
    if equations > rank:
        return None
    return (
        f"the {n} poses are {distinct} distinct one(s) (joints within "
        f"{math.degrees(SAME_POSE):.2g}° counted once), whose ≈{equations:.0f} equations "
        f"leave no degrees of freedom for the {rank} combinations the data determine: an error "
        "tied to a pose (a sensor's bias there, the foot's compliance) repeats with it and "
        "cannot be told from the mass distribution, so these data cannot show the CAD model "
        "to be off; measure more distinct poses"
    )


def _prior_decided(
    ls: Solution, n_x: int, rtol: float, prior_info: np.ndarray
) -> tuple[int, float]:
    """Directions of vec(r) the prior decided: unseen by the data, or where the data carry less
    than ``PRIOR_DECIDED`` of the posterior information (generalised eigenvalues of the data's
    marginal information against the prior's); and the largest share of the information the
    prior holds in a direction the data see (0 when they see none)."""
    lam, vecs, p = marginal_x(ls, n_x, rtol)
    data = (vecs[:, :p] * lam[:p]) @ vecs[:, :p].T
    pri = prior_info[:n_x, :n_x]
    # the data's information relative to the prior's, μ = eig(L⁻¹ D L⁻ᵀ) with pri = L Lᵀ: a
    # direction is the prior's where μ/(1 + μ) < PRIOR_DECIDED. The prior precision is positive
    # definite by construction; its eigen-decomposition (clipped) stands in for the Cholesky
    # factor, so a prior of very different scales (or bodies with zero SESC vectors) is no error.
    w, v = np.linalg.eigh((pri + pri.T) / 2)
    w = np.maximum(w, 1e-300 + 1e-15 * max(float(w.max()), 0.0))
    half = v / np.sqrt(w)
    mu = np.linalg.eigvalsh(half.T @ data @ half)[::-1]  # descending
    threshold = PRIOR_DECIDED / (1 - PRIOR_DECIDED)
    share = float(1.0 / (1.0 + max(mu[p - 1], 0.0))) if p else 0.0
    return int(np.sum(mu < threshold)), share


def _noise_ratios(system: System, ls: Solution) -> dict[Kind, float]:
    """Each kind's noise relative to the others, from least squares (1 for a single kind)."""
    if len(system.kinds) == 1:
        return {system.kinds[0]: 1.0}
    return {k: (v if math.isfinite(v) and v > 0 else 1.0) for k, v in ls.noise.items()}


@dataclass(frozen=True)
class _Choice:
    """How τ and σ were chosen: τ's rule ("given", "evidence", "k-fold cv"), σ given or not,
    and the cross-validation curve (None without cv)."""

    prior_scale_by: str
    noise_given: bool
    cv_curve: list | None


def _map_fit(
    base: Fit, system: System, post: Posterior, ls: Solution, choice: _Choice, pri: Prior
) -> Fit:
    n_x = system.n_x
    x, cov = post.x[:n_x], post.cov[:n_x, :n_x]
    robot = base.robot
    if system.space == "bodies":  # reported for the robot's support: r = L_ref x
        lmap = stance_map(robot, robot.support)
        x, cov = lmap @ x, lmap @ cov @ lmap.T
    combos = tuple(
        dataclasses.replace(c, value=float(g @ x), std=float(np.sqrt(max(g @ cov @ g, 0.0))))
        for c in base.base
        for g in [combination_vector(robot, c.terms)]
    )
    decided, share = _prior_decided(
        ls, n_x, base.rtol, post.noise**2 * pri.matrix(post.prior_scale)
    )
    info = MapInfo(
        prior_scale=post.prior_scale,
        prior_scale_by=choice.prior_scale_by,
        noise=post.noise,
        noise_by="given" if choice.noise_given else "evidence",
        log_evidence=float(post.log_evidence),
        effective_parameters=post.edf,
        cv_curve=choice.cv_curve,
        at_lower_bound=choice.prior_scale_by == "evidence"
        and post.prior_scale <= 1.01 * TAU_RANGE[0],
        prior_decided=decided,
        prior=pri.kind,
        prior_com_std=post.prior_scale * BODY_COM_SCALE if pri.kind == "bodies" else None,
        prior_share=share,
    )
    mapped = dataclasses.replace(
        ls,
        theta=post.x,
        cov=post.cov,
        rank=post.x.size,
        vecs=np.eye(post.x.size),
        lam=np.ones(post.x.size),
    )  # every direction determined (by data or prior)
    nuisance = _by_prior(nuisance_estimates(system, mapped), nuisance_estimates(system, ls))
    offset = None
    cop = [e for e in nuisance if e.kind == "cop"]
    if cop:
        offset = CopOffset(
            value=np.array([e.value for e in cop]), std=np.array([e.std for e in cop])
        )
    return dataclasses.replace(
        base,
        r=x.reshape(-1, 3),
        cov=cov,
        method="map",
        sigma_hat=post.noise,
        base=combos,
        sigma_dof=math.inf if choice.noise_given else max(base.n_rows - post.edf, 1.0),
        map=info,
        cop_offset=offset,
        nuisance=nuisance,
    )


def _by_prior(
    estimates: tuple[NuisanceEstimate, ...], by_data: tuple[NuisanceEstimate, ...]
) -> tuple[NuisanceEstimate, ...]:
    """MAP's nuisance ``estimates`` (each determined, by the data or the prior), each that the
    data alone (``by_data``: least squares' estimates) do not determine with its reason
    prefixed "decided by the prior" (a torque offset and friction band of a joint approached
    from one side only: the data see their sum)."""
    return tuple(
        e if d.determined or not e.determined
        else dataclasses.replace(e, reason=f"decided by the prior: {d.reason}")
        for e, d in zip(estimates, by_data, strict=True)
    )  # fmt: skip
