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

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from sescid.errors import SescidError
from sescid.estimation.fit import Fit, JointNoiseEffect, RobustInfo
from sescid.estimation.least_squares import residuals
from sescid.estimation.measurements import COP, TORQUE, Measurements
from sescid.kinematics import as_poses
from sescid.simulation import random_poses

#: Huber threshold on the standardised 2-D residual norm: √χ²₂(0.95)
HUBER_K = 2.4477
_MEDIAN_NORM = math.sqrt(2 * math.log(2))  # median of ‖N(0, I₂)‖


#: median of |N(0, 1)| (a torque row's standardised residual)
_MEDIAN_ABS = 0.6744897501960817


def _standardised(fit: Fit, m: Measurements, base: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Per kind, the residual size in units of the given errors: a CoP pose's 2-D norm (n,),
    a torque row's absolute value (n, J)."""
    res = residuals(fit, m)
    out = {}
    if COP in res:  # a coordinate not measured (nan) does not count
        out[COP] = np.sqrt(np.nansum((res[COP] / base[COP]) ** 2, axis=1))
    if TORQUE in res:
        out[TORQUE] = np.abs(res[TORQUE] / base[TORQUE])
    return out


def _base_errors(m: Measurements, weighted: bool) -> dict[str, np.ndarray]:
    out = {}
    if m.cop is not None:
        out[COP] = m.cop_se if (weighted and m.cop_se is not None) else np.ones((m.n, 2))
    if m.tau is not None:
        se = m.tau_se if (weighted and m.tau_se is not None) else None
        out[TORQUE] = se if se is not None else np.ones(m.tau.shape)
    return out


def huber(
    run: Callable[[list[Measurements], bool], Fit],
    data: list[Measurements],
    *,
    weighted: bool = False,
    k: float = HUBER_K,
    max_iter: int = 50,
    tol: float = 1e-4,
) -> Fit:
    """Huber IRLS around a fitting method ``run(data, weighted)``; names the down-weighted poses.

    Each kind's residuals are standardised by a robust scale (median of a CoP pose's 2-D norm
    over √(2 ln 2), of a torque row's |e| over 0.6745) and by the given errors when
    ``weighted``; rows beyond ``k`` get weight k/u. ``fit.robust`` lists the poses whose weight
    fell (the lowest weight of their rows), lowest first; σ̂ and each kind's σ are in the data's
    units again (or a scale on the given errors when ``weighted``).
    """
    if not k > 0:
        raise SescidError(f"Huber threshold k must be > 0, got {k}")
    bases = [_base_errors(m, weighted) for m in data]
    fit = run(data, weighted)
    weights = [{kd: np.ones(b.shape[0] if kd == COP else b.shape) for kd, b in base.items()}
               for base in bases]  # fmt: skip
    scale: dict[str, float] = {}
    iterations = 0
    for iterations in range(1, max_iter + 1):  # noqa: B007 (reported after the loop)
        sizes = [_standardised(fit, m, base) for m, base in zip(data, bases, strict=True)]
        scale = {}
        for kd in sizes[0]:
            pooled = np.concatenate([s[kd].reshape(-1) for s in sizes])
            scale[kd] = float(np.median(pooled)) / (_MEDIAN_NORM if kd == COP else _MEDIAN_ABS)
        if any(v <= 0 for v in scale.values()):
            break
        change = 0.0
        for w, size in zip(weights, sizes, strict=True):
            for kd, u in size.items():
                new = np.where(u / scale[kd] <= k, 1.0, k / np.maximum(u / scale[kd], 1e-300))
                change = max(change, float(np.max(np.abs(new - w[kd]))))
                w[kd] = new
        reweighted = [
            _with_errors(m, base, w, scale) for m, base, w in zip(data, bases, weights, strict=True)
        ]
        fit = run(reweighted, True)
        if change < tol:
            break
    return _robust_fit(fit, data, weights, scale, k, iterations, weighted)


def _with_errors(m: Measurements, base, w, scale) -> Measurements:
    changes = {}
    if COP in base:
        changes["cop_se"] = base[COP] * scale[COP] / np.sqrt(w[COP])[:, None]
    if TORQUE in base:
        changes["tau_se"] = base[TORQUE] * scale[TORQUE] / np.sqrt(w[TORQUE])
    return dataclasses.replace(m, **changes)


def _robust_fit(fit: Fit, data, weights, scale, k, iterations, weighted) -> Fit:
    """The last IRLS fit in the data's units, with the down-weighted poses named."""
    low = []
    start = 0
    for m, w in zip(data, weights, strict=True):
        pose_w = np.ones(m.n)
        for kd, wk in w.items():
            pose_w = np.minimum(pose_w, wk if kd == COP else wk.min(axis=1))
        low += [(start + int(i), float(pose_w[i])) for i in np.flatnonzero(pose_w < 1.0)]
        start += m.n
    low.sort(key=lambda t: (t[1], t[0]))
    kinds = tuple(
        dataclasses.replace(
            kf,
            sigma=kf.sigma * scale.get(kf.kind, math.nan),
            weighted=weighted,
        )
        for kf in fit.kinds
    )
    sigma_hat = fit.sigma_hat
    if len(kinds) == 1 and math.isfinite(sigma_hat):
        sigma_hat *= scale.get(kinds[0].kind, math.nan)
    main = COP if COP in scale else TORQUE
    return dataclasses.replace(
        fit,
        kinds=kinds,
        sigma_hat=sigma_hat,
        weighted=weighted if len(kinds) == 1 else True,
        robust=RobustInfo(
            k=k,
            scale=scale.get(main, math.nan),
            iterations=iterations,
            downweighted=low,
            weighted_input=weighted,
            scales=dict(scale),
        ),
    )


def joint_noise_mc(
    fitter: Callable[[list[Measurements]], Fit],
    fit: Fit,
    data: Measurements,
    joint_noise: float,
    *,
    draws: int = 30,
    seed: int = 0,
    reference_poses=None,
) -> JointNoiseEffect:
    """Propagate joint-angle errors N(0, joint_noise²) [rad] to r and CoP predictions.

    ``fitter`` refits perturbed copies of ``data``; ``fit`` is the fit of the unperturbed data
    (its ``cov`` gives the CoP-noise share);
    ``reference_poses`` (default 500 random ±30° poses) are where predictions are compared.
    """
    if not (math.isfinite(joint_noise) and joint_noise > 0):
        raise SescidError(f"joint noise must be a positive angle, got {joint_noise} rad")
    if draws < 2:
        raise SescidError(f"Monte Carlo needs at least 2 draws, got {draws}")
    robot = fit.robot
    q = as_poses(data.q, robot.nq)
    rng = np.random.default_rng(seed)
    q_ref = random_poses(robot, 500, 30.0, seed + 1) if reference_poses is None else reference_poses
    rs, preds = [], []
    for _ in range(draws):
        f = fitter([dataclasses.replace(data, q=q + rng.normal(0.0, joint_noise, q.shape))])
        rs.append(f.r)
        preds.append(f.predict_cop(q_ref))
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
