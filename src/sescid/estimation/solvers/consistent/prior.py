"""Controller-ready masses: the CAD prior on masses/CoMs with its scale chosen by the data.

``consistent_from_fit(…, prior_std=τ)`` solves one QP, data fit + CAD deviation, with a Gaussian
prior of relative std τ on each body's mass (CoM std ``com_scale·τ``). Here τ is not guessed:
it maximises the evidence (marginal likelihood) of the fit's data under that linear-Gaussian
model, ignoring the inequality constraints. With ``x`` the QP's scaled parameters
(``sesc_map``: vec(r) = K x), the fit's least-squares estimate r̂, its identifiable basis V and
singular values S, the data's sufficient statistic ``u = S Vᵀ (r̂ − K x_cad)`` is

    u ~ N(0, σ² I + τ² S Vᵀ K W⁻² Kᵀ V S)

(σ the fit's residual scale, W the QP's CAD weights), so log p(u | τ) is a 1-D function of τ.
The CAD target keeps the model's masses (``spread="data"``): a weighed total mass that differs
from the model's goes where the data term puts it (the prior spreads only what the data leave
free, in proportion to each body's prior variance), not uniformly over all bodies.

A MAP fit is first turned back into its least-squares estimate on the identifiable subspace
(``x_ls = x0 + V (I + λ S⁻²) Vᵀ (x_map − x0)``, λ = σ²/τ_map²) so the CAD prior is not
counted twice.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sescid.errors import SescidError
from sescid.estimation.result.fit import Fit
from sescid.estimation.solvers.consistent.qp import COM_SCALE, H_UNIT, sesc_map
from sescid.estimation.solvers.consistent.record import model_coms

#: search range of the relative CAD prior std
PRIOR_STD_RANGE = (1e-3, 10.0)
#: search range of the CoM prior std, m
COM_STD_RANGE = (1e-4, 0.1)


def least_squares_view(fit: Fit) -> Fit:
    """The fit as least squares: a MAP fit's estimate un-shrunk on its identifiable subspace."""
    if fit.map is None or fit.cop_offset is not None:
        return fit
    p = fit.rank
    vp, sv = fit.basis[:, :p], fit.singular_values[:p]
    lam = (fit.map.noise / fit.map.prior_scale) ** 2
    x0 = fit.r_prior.reshape(-1)
    d = vp.T @ (fit.r.reshape(-1) - x0)
    x = x0 + vp @ ((1.0 + lam / sv**2) * d)
    # the least-squares residual scale, recovered from the stored log evidence:
    # zᵀz − bᵀM⁻¹b = RSS_map + λ‖x_map − x0‖², RSS_ls = RSS_map − ‖S Vᵀ(x_map − x_ls)‖²
    s2, n_par, m = fit.map.noise**2, x0.size, fit.n_rows
    logdet = float(np.sum(np.log(sv**2 + lam))) + (n_par - p) * math.log(lam)
    quad = (
        -2 * fit.map.log_evidence - m * math.log(2 * math.pi * s2) - logdet + n_par * math.log(lam)
    )
    xm = fit.r.reshape(-1)
    rss_map = quad * s2 - lam * float((xm - x0) @ (xm - x0))
    rss = rss_map - float(np.sum((sv * (vp.T @ (xm - x))) ** 2))
    sigma = math.sqrt(rss / (m - p)) if m > p and rss > 0 else fit.map.noise
    cov = (vp / sv**2) @ vp.T * sigma**2
    return dataclasses.replace(fit, r=x.reshape(-1, 3), cov=cov, sigma_hat=sigma)


def evidence_prior_std(
    fit: Fit, total_mass: float | None = None, com_scale: float = COM_SCALE
) -> tuple[float, float]:
    """(τ, CoM std m) maximising the evidence of ``fit``'s data (module doc): the relative
    mass std τ and the CoM std (the QP's ``com_scale`` is their ratio). ``com_scale`` is the
    starting CoM std per unit τ."""
    ls = least_squares_view(fit)
    robot = ls.robot
    big_m = robot.total_mass if total_mass is None else float(total_mass)
    m_cad = robot.masses
    nb = len(m_cad)
    m_bar = np.maximum(m_cad, big_m / (10 * nb)) / big_m
    x_cad = np.concatenate([m_cad / big_m, (m_cad[:, None] * model_coms(robot)).ravel()])
    x_cad[nb:] /= big_m * H_UNIT
    p = ls.rank
    vp, sv = ls.basis[:, :p], ls.singular_values[:p]
    kmat = sesc_map(robot)
    u0 = sv * (vp.T @ (ls.r.reshape(-1) - kmat @ x_cad))
    b = sv[:, None] * (vp.T @ kmat)
    # prior std of x: masses τ m̄ (relative), first moments m̄ σ_c / ℓ (σ_c the CoM std, m)
    bm = b[:, :nb] * m_bar
    bh = b[:, nb:] * np.repeat(m_bar / H_UNIT, 3)
    gm, gh = bm @ bm.T, bh @ bh.T
    s2 = ls.sigma_hat**2
    if not (math.isfinite(s2) and s2 > 0):
        raise SescidError("the fit has no residual scale to weigh the CAD prior against")

    import scipy.linalg  # lazy: scipy's import is ~0.3 s of every command
    import scipy.optimize

    def neg(v) -> float:
        c = s2 * np.eye(p) + math.exp(2 * v[0]) * gm + math.exp(2 * v[1]) * gh
        try:
            cf = scipy.linalg.cho_factor(c, check_finite=False)
        except np.linalg.LinAlgError:
            return 1e300
        quad = u0 @ scipy.linalg.cho_solve(cf, u0, check_finite=False)
        return float(np.sum(np.log(np.diag(cf[0]))) + 0.5 * quad)

    lo, hi = (math.log(v) for v in PRIOR_STD_RANGE)
    clo, chi = (math.log(v) for v in COM_STD_RANGE)
    grid = [(a, c) for a in np.linspace(lo, hi, 13) for c in np.linspace(clo, chi, 9)]
    start = min(grid, key=neg)
    res = scipy.optimize.minimize(
        neg, np.array(start), method="L-BFGS-B", bounds=[(lo, hi), (clo, chi)]
    )
    best = res.x if res.fun <= neg(start) else np.array(start)
    return math.exp(best[0]), math.exp(best[1])
