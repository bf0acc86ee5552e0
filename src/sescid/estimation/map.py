"""Maximum a posteriori identification with a Gaussian CAD prior on the SESC vectors.

Model: ``y = Φ x + e``, ``e ~ N(0, σ² W⁻¹)`` (W = 1 unless per-pose standard errors are given) and
a prior ``x ~ N(x0, τ² I)`` centred on the model's own SESC vectors ``x0 = vec(r_prior)`` (the
manufacturer / CAD values), ``τ`` the prior scale in metres. The posterior is Gaussian:

    x̂ = x0 + M⁻¹ (Φᵀy − A x0),   cov = σ² M⁻¹,   M = A + (σ²/τ²) I,   A = ΦᵀWΦ.

It fills the directions the data cannot see (there x̂ = x0 with the prior's uncertainty τ) and
shrinks the poorly determined ones toward CAD. ``τ`` and ``σ`` are chosen, unless given, by
maximising the marginal likelihood (evidence) of the data,

    log p(y | σ, τ) = −½ [m log 2πσ² + log det M − Σ log(σ²/τᵢ²) + (zᵀz − bᵀM⁻¹b)/σ²],

with ``z = y − Φ x0``, ``b = Φᵀz`` — computed from the accumulated normal equations only, so the
same code serves streamed data and the online estimator (``sescid.online``).

Optionally two constant CoP offsets (sensor bias ``b_x, b_y``, m) are estimated jointly
(``bias=True``). For one support foot they are confounded with the support body's own x/y SESC
components, whose effect on the CoP is constant too: least squares cannot separate them. The prior
on the support body's r (scale τ) is what separates them here, so the bias is known to ± ≈ τ only
— a bias is identifiable from the data alone only with data from a second support foot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.errors import SescidError
from sescid.estimation.fit import CopOffset, Fit, MapInfo
from sescid.estimation.identifiability import DEFAULT_RTOL, combination_vector
from sescid.estimation.least_squares import residual_stats, solve
from sescid.estimation.normal_equations import NormalEquations, accumulate, check_cop, row_weights
from sescid.estimation.validation import folds as split
from sescid.kinematics import as_poses
from sescid.robot import Robot

#: prior standard deviation of a CoP offset when ``bias=True``: effectively flat, m
BIAS_PRIOR_SCALE = 1.0
#: search range of the prior scale τ and the noise σ for evidence maximisation, m
TAU_RANGE = (1e-6, 1.0)
#: search range of σ: m, or the dimensionless scale on given standard errors; its upper end is
#: widened to ``SIGMA_HEADROOM`` × the RMS residual of the prior model (a weighted scale may be ≫ 1)
SIGMA_RANGE = (1e-7, 1.0)
SIGMA_HEADROOM = 10.0


@dataclass
class Posterior:
    """Gaussian posterior of the parameters for given σ and τ (all in metres)."""

    x: np.ndarray  #: (P,) posterior mean
    cov: np.ndarray  #: (P, P) posterior covariance, m²
    noise: float  #: σ, CoP noise standard deviation (or scale on given standard errors)
    prior_scale: float  #: τ, prior standard deviation of each SESC component
    log_evidence: float
    edf: float  #: effective number of parameters tr(A M⁻¹)


def bias_columns(n: int) -> np.ndarray:
    """(2n, 2) regressor columns of constant CoP offsets (b_x on x rows, b_y on y rows)."""
    return np.tile(np.eye(2), (n, 1))


def _prior_precision(n_params: int, prior_scale: float, n_bias: int) -> np.ndarray:
    d = np.full(n_params + n_bias, 1.0 / prior_scale**2)
    d[n_params:] = 1.0 / BIAS_PRIOR_SCALE**2
    return d


def _terms(ne: NormalEquations, x0: np.ndarray):
    b = ne.atb - ne.ata @ x0
    ztz = ne.yty - 2 * x0 @ ne.atb + x0 @ ne.ata @ x0
    return b, max(ztz, 0.0)


def log_evidence(ne: NormalEquations, x0: np.ndarray, prec: np.ndarray, noise: float) -> float:
    """Log p(y | σ, prior) for prior precisions ``prec`` (P,) [m⁻²] and noise σ [m]."""
    import scipy.linalg  # lazy: scipy's import is ~0.3 s of every command

    s2 = noise**2
    b, ztz = _terms(ne, x0)
    try:
        cf = scipy.linalg.cho_factor(ne.ata + np.diag(s2 * prec), check_finite=False)
    except np.linalg.LinAlgError:
        return -math.inf
    logdet = 2 * np.sum(np.log(np.diag(cf[0])))
    quad = (ztz - b @ scipy.linalg.cho_solve(cf, b, check_finite=False)) / s2
    m = ne.n_rows
    return -0.5 * (
        m * math.log(2 * math.pi * s2) + logdet - np.sum(np.log(s2 * prec)) + max(quad, 0.0)
    )


def posterior(
    ne: NormalEquations, x0: np.ndarray, prior_scale: float, noise: float, n_bias: int = 0
) -> Posterior:
    """Posterior mean and covariance for a prior N(x0, τ²I) (+ flat-ish bias) and noise σ."""
    import scipy.linalg

    p = ne.ata.shape[0]
    prec = _prior_precision(p - n_bias, prior_scale, n_bias)
    mat = ne.ata + np.diag(noise**2 * prec)
    cf = scipy.linalg.cho_factor(mat, check_finite=False)
    b, _ = _terms(ne, x0)
    x = x0 + scipy.linalg.cho_solve(cf, b, check_finite=False)
    minv = scipy.linalg.cho_solve(cf, np.eye(p), check_finite=False)
    return Posterior(
        x=x,
        cov=noise**2 * minv,
        noise=noise,
        prior_scale=prior_scale,
        log_evidence=log_evidence(ne, x0, prec, noise),
        edf=float(np.sum(minv * ne.ata)),
    )


def maximise_evidence(
    ne: NormalEquations,
    x0: np.ndarray,
    *,
    prior_scale: float | None = None,
    noise: float | None = None,
    n_bias: int = 0,
) -> tuple[float, float]:
    """(τ, σ) in m maximising the evidence; a given value is held fixed.

    A grid over log τ (25 points in ``TAU_RANGE``) with σ optimised at each, then Brent
    refinement around the best grid point; σ alone is a bounded 1-D search.
    """
    import scipy.optimize

    p = ne.ata.shape[0] - n_bias

    def neg(log_tau: float, log_sigma: float) -> float:
        prec = _prior_precision(p, math.exp(log_tau), n_bias)
        val = -log_evidence(ne, x0, prec, math.exp(log_sigma))
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


#: largest prior scale or noise accepted, m (1 m on a SESC component is already a flat prior)
MAX_SCALE = 100.0


def _check_positive(value, what: str) -> None:
    if value is not None and not (math.isfinite(value) and 0 < value <= MAX_SCALE):
        raise SescidError(
            f"{what} must be a positive number of metres ≤ {MAX_SCALE:g}, got {value}"
        )


def identify_map(
    robot: Robot,
    q,
    cop,
    *,
    sigma=None,
    prior_scale: float | None = None,
    noise: float | None = None,
    r_prior: np.ndarray | None = None,
    bias: bool = False,
    rtol: float = DEFAULT_RTOL,
    select: str = "evidence",
    folds: int = 5,
    seed: int = 0,
    gravity=None,
) -> Fit:
    """MAP fit of the SESC vectors with a Gaussian prior centred on ``r_prior`` (default: CAD).

    q (n, nq) rad, cop (n, 2) m, ``sigma`` optional per-pose CoP standard errors (m).
    ``prior_scale`` τ and ``noise`` σ in metres; when τ is None it is chosen by ``select``:
    ``"evidence"`` (marginal likelihood, jointly with σ when σ is None) or ``"cv"`` (the ratio
    σ²/τ² minimising the ``folds``-fold cross-validated CoP error, then σ by maximum
    likelihood at that ratio). With per-pose ``sigma``, σ is a dimensionless scale on them.
    ``bias=True`` adds two constant CoP offsets (m), reported in ``fit.cop_offset`` and not
    part of predictions. ``gravity``: per-pose gravity directions (n, 3), support frame.
    """
    _check_positive(prior_scale, "prior scale")
    _check_positive(noise, "noise")
    if select not in ("evidence", "cv"):
        raise SescidError(f"prior scale selection must be 'evidence' or 'cv', got {select!r}")
    q = as_poses(q, robot.nq)
    cop = check_cop(cop, q.shape[0])
    ne = accumulate(robot, [(q, cop, sigma, gravity)])
    by_cv = select == "cv" and prior_scale is None
    if by_cv:
        if bias:
            raise SescidError("choosing the prior scale by cross-validation does not support bias")
        r0 = robot.sesc_vectors() if r_prior is None else np.asarray(r_prior, dtype=float)
        ridge, curve = cv_ridge(robot, q, cop, sigma, r0.reshape(-1), folds, seed, gravity)
        if noise is None:
            noise = profiled_noise(ne, r0.reshape(-1), ridge)
        prior_scale = noise / math.sqrt(ridge)
    fit = fit_from_normal_equations(
        robot,
        ne,
        prior_scale=prior_scale,
        noise=noise,
        r_prior=r_prior,
        bias=bias,
        rtol=rtol,
        bias_data=(q, cop, sigma, gravity),
    )
    fit.weighted = sigma is not None
    if by_cv and fit.map is not None:
        fit.map.prior_scale_by = f"{folds}-fold cv"
        fit.map.cv_curve = curve
    residual_stats(fit, q, cop, gravity)
    return fit


def profiled_noise(ne: NormalEquations, x0: np.ndarray, ridge: float) -> float:
    """Maximum-likelihood σ (m) for a fixed ratio ``ridge`` = σ²/τ²: √((zᵀz − bᵀM⁻¹b)/m)."""
    import scipy.linalg

    b, ztz = _terms(ne, x0)
    mat = ne.ata + ridge * np.eye(x0.size)
    quad = b @ scipy.linalg.solve(mat, b, assume_a="pos")
    return math.sqrt(max(ztz - quad, 0.0) / ne.n_rows) or SIGMA_RANGE[0]


def cv_ridge(robot: Robot, q, cop, sigma, x0, k: int = 5, seed: int = 0, gravity=None):
    """Ratio σ²/τ² minimising the k-fold held-out CoP error; also the curve [[τ/σ, rmse], …].

    Fold normal equations make each candidate cost one Cholesky per fold: the held-out sum of
    squares is ``yᵀy − 2xᵀΦᵀy + xᵀΦᵀΦx`` from the test fold's sums.
    """
    import scipy.linalg

    def sub(v, f):
        return None if v is None else np.asarray(v)[f]

    parts = [accumulate(robot, [(q[f], cop[f], sub(sigma, f), sub(gravity, f))]) for f in
             split(q.shape[0], k, seed)]  # fmt: skip
    total_a = sum(p.ata for p in parts)
    total_b = sum(p.atb for p in parts)
    ratios = np.logspace(-4, 2, 31)  # τ/σ (τ = 100σ is practically no prior)
    curve = []
    for t in ratios:
        sq = 0.0
        for p in parts:
            a, b = total_a - p.ata, total_b - p.atb
            x = x0 + scipy.linalg.solve(a + np.eye(x0.size) / t**2, b - a @ x0, assume_a="pos")
            sq += p.yty - 2 * x @ p.atb + x @ p.ata @ x
        curve.append([float(t), math.sqrt(max(sq, 0.0) / (2 * q.shape[0]))])
    best = min(range(len(curve)), key=lambda i: curve[i][1])
    return 1.0 / ratios[best] ** 2, curve


def _with_bias(robot: Robot, q, cop, sigma, gravity=None) -> NormalEquations:
    """Normal equations of [vec(r); b] from the data (bias columns appended)."""
    n = q.shape[0]
    if gravity is None:
        phi_r, d = robot.regressor(q, (0, 1)), robot.d[:2]
    else:
        phi_r, d = robot.regressor_tilted(q, gravity), robot.d_tilted(gravity, n)
    phi = np.hstack([phi_r.reshape(2 * n, -1), bias_columns(n)])
    y = (cop - d).reshape(-1)
    w = row_weights(sigma, n)
    if w is not None:
        phi, y = phi * np.sqrt(w)[:, None], y * np.sqrt(w)
    return NormalEquations(phi.T @ phi, phi.T @ y, float(y @ y), 2 * n, n)


def fit_from_normal_equations(
    robot: Robot,
    ne: NormalEquations,
    *,
    prior_scale: float | None = None,
    noise: float | None = None,
    r_prior: np.ndarray | None = None,
    bias: bool = False,
    rtol: float = DEFAULT_RTOL,
    bias_data: tuple | None = None,
) -> Fit:
    """MAP ``Fit`` from accumulated normal equations (see ``identify_map``)."""
    if ne.n_poses == 0:
        raise SescidError("no poses to identify from")
    r0 = robot.sesc_vectors() if r_prior is None else np.asarray(r_prior, dtype=float)
    x0 = r0.reshape(-1)
    base = solve(robot, ne, rtol=rtol, r_prior=r0)  # rank, basis, named combinations
    n_par = x0.size
    work, n_bias, x0w = ne, 0, x0
    if bias:
        if bias_data is None:
            raise SescidError("a bias fit needs the data, not only normal equations")
        work, n_bias = _with_bias(robot, *bias_data), 2
        x0w = np.concatenate([x0, np.zeros(2)])
    chosen = "given" if prior_scale is not None else "evidence"
    tau, sig = maximise_evidence(work, x0w, prior_scale=prior_scale, noise=noise, n_bias=n_bias)
    post = posterior(work, x0w, tau, sig, n_bias)
    return _map_fit(base, post, n_par, n_bias, chosen, noise is not None)


def _map_fit(base: Fit, post: Posterior, n_par: int, n_bias: int, chosen, noise_given) -> Fit:
    fit = base
    x, cov = post.x[:n_par], post.cov[:n_par, :n_par]
    fit.r = x.reshape(-1, 3)
    fit.cov = cov
    fit.method = "map"
    fit.sigma_hat = post.noise
    for c in fit.base:
        g = combination_vector(fit.robot, c.terms)
        c.value = float(g @ x)
        c.std = float(np.sqrt(max(g @ cov @ g, 0.0)))
    fit.sigma_dof = math.inf if noise_given else max(fit.n_rows - post.edf, 1.0)
    fit.map = MapInfo(
        prior_scale=post.prior_scale,
        prior_scale_by=chosen,
        noise=post.noise,
        noise_by="given" if noise_given else "evidence",
        log_evidence=float(post.log_evidence),
        effective_parameters=post.edf,
        at_lower_bound=chosen == "evidence" and post.prior_scale <= 1.01 * TAU_RANGE[0],
    )
    if n_bias:
        fit.cop_offset = CopOffset(
            value=np.asarray(post.x[n_par:], dtype=float).copy(),
            std=np.sqrt(np.diag(post.cov)[n_par:]),
        )
    return fit
