"""Robust fits (Huber IRLS) and Monte-Carlo propagation of joint-angle errors.

Huber: each pose's 2-D CoP residual ``e_i`` is standardised by a robust noise scale
``s = median‖e‖ / √(2 ln 2)`` (the median of a 2-D Gaussian residual's norm is σ√(2 ln 2)) and by
its own standard error when given; poses with ``u_i = ‖e_i‖/s > k`` get weight ``k/u_i``
(default ``k = 2.45``, the 95 % point of a 2-D Gaussian norm), the others weight 1. The fit is
repeated with those weights (as per-pose standard errors ``s/√w``) until the weights settle.

Joint-angle errors (encoder resolution, backlash): the regressor is evaluated at the measured
angles, the CoP comes from the true ones. ``joint_noise_mc`` refits with the measured angles
perturbed again by the stated error and reports the spread of the parameters and of the CoP
predictions, beside the spread due to the CoP noise (``fit.cov``). Two caveats: the residual
σ̂ behind ``fit.cov`` already absorbs the CoP scatter that the angle errors cause, so the
"CoP-noise" share includes part of their effect; and the refit spread does not measure the small
errors-in-variables bias (attenuation) that angle errors add — only their random part.
"""

from __future__ import annotations

import math

import numpy as np

from sescid.errors import SescidError
from sescid.estimation.fit import Fit, JointNoiseEffect, RobustInfo
from sescid.estimation.validation import Fitter
from sescid.kinematics import as_poses
from sescid.simulation import random_poses

#: Huber threshold on the standardised 2-D residual norm: √χ²₂(0.95)
HUBER_K = 2.4477
_MEDIAN_NORM = math.sqrt(2 * math.log(2))  # median of ‖N(0, I₂)‖


def _per_pose_sigma(sigma, n: int) -> np.ndarray:
    if sigma is None:
        return np.ones((n, 2))
    s = np.asarray(sigma, dtype=float)
    return np.repeat(s[:, None], 2, axis=1) if s.ndim == 1 else s


def huber(
    fitter: Fitter,
    q,
    cop,
    sigma=None,
    *,
    k: float = HUBER_K,
    max_iter: int = 50,
    tol: float = 1e-4,
    gravity=None,
) -> Fit:
    """Huber IRLS around any fitting method; names the down-weighted poses in ``fit.robust``.

    ``fit.robust`` (``RobustInfo``): ``k``, ``scale`` (robust noise scale, m; dimensionless with
    given standard errors), ``iterations``, ``downweighted`` = [(pose index, weight), …] sorted
    by weight. ``fit.sigma_hat`` is reported in metres (unit-weight noise) unless errors were
    given.
    """
    if not k > 0:
        raise SescidError(f"Huber threshold k must be > 0, got {k}")
    q = np.asarray(q, dtype=float)
    cop = np.asarray(cop, dtype=float)
    base = _per_pose_sigma(sigma, q.shape[0])

    def run(s):
        return fitter(q, cop, s) if gravity is None else fitter(q, cop, s, gravity)

    fit = run(sigma)
    w = np.ones(q.shape[0])
    scale, iterations = math.nan, 0
    for iterations in range(1, max_iter + 1):  # noqa: B007 (reported after the loop)
        e = (cop - fit.predict_cop(q, gravity) - fit.cop_bias) / base
        u = np.linalg.norm(e, axis=1)
        scale = float(np.median(u)) / _MEDIAN_NORM
        if scale <= 0:
            break
        u = u / scale
        w_new = np.where(u <= k, 1.0, k / np.maximum(u, 1e-300))
        done = np.max(np.abs(w_new - w)) < tol
        w = w_new
        fit = run(base * scale / np.sqrt(w)[:, None])
        if done:
            break
    if math.isfinite(fit.sigma_hat) and math.isfinite(scale):
        fit.sigma_hat *= scale  # whitened units → metres (or σ-units with given errors)
    fit.weighted = sigma is not None  # the IRLS weights are internal: σ̂ is in metres again
    order = np.argsort(w, kind="stable")
    low = [(int(i), float(w[i])) for i in order if w[i] < 1.0]
    fit.robust = RobustInfo(
        k=k, scale=scale, iterations=iterations, downweighted=low, weighted_input=sigma is not None
    )
    return fit


def joint_noise_mc(
    fitter: Fitter,
    fit: Fit,
    q,
    cop,
    joint_noise: float,
    *,
    sigma=None,
    draws: int = 30,
    seed: int = 0,
    reference_poses=None,
    progress=None,
) -> JointNoiseEffect:
    """Propagate joint-angle errors N(0, joint_noise²) [rad] to r and CoP predictions.

    ``fit`` is the fit of the unperturbed data (its ``cov`` gives the CoP-noise share);
    ``reference_poses`` (default 500 random ±30° poses) are where predictions are compared;
    ``progress(i, draws)`` is called after each draw.
    """
    if not (math.isfinite(joint_noise) and joint_noise > 0):
        raise SescidError(f"joint noise must be a positive angle, got {joint_noise} rad")
    if draws < 2:
        raise SescidError(f"Monte Carlo needs at least 2 draws, got {draws}")
    robot = fit.robot
    q = as_poses(q, robot.nq)
    rng = np.random.default_rng(seed)
    q_ref = random_poses(robot, 500, 30.0, seed + 1) if reference_poses is None else reference_poses
    rs, preds = [], []
    for i in range(draws):
        f = fitter(q + rng.normal(0.0, joint_noise, q.shape), cop, sigma)
        rs.append(f.r)
        preds.append(f.predict_cop(q_ref))
        if progress:
            progress(i + 1, draws)
    r_draws, p_draws = np.array(rs), np.array(preds)
    var_j = float(np.mean(np.var(p_draws, axis=0, ddof=1)))
    var_c = float(np.mean(fit.predict_std(q_ref, rows=(0, 1)) ** 2))
    return JointNoiseEffect(
        joint_noise_rad=joint_noise,
        draws=draws,
        r_std_joint=np.std(r_draws, axis=0, ddof=1),
        cop_std_joint=math.sqrt(var_j),
        cop_std_noise=math.sqrt(var_c),
        share_joint=var_j / (var_j + var_c) if var_j + var_c > 0 else math.nan,
    )
