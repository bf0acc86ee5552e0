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
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from sescid.base.spill import Spill, median
from sescid.errors import SescidError
from sescid.estimation.data.measurements import Measurements
from sescid.estimation.data.sources import HeldSource
from sescid.estimation.result.fit import Fit
from sescid.estimation.result.records import JointNoiseEffect, RobustInfo
from sescid.estimation.solvers.least_squares import residuals
from sescid.kinds import COP, TORQUE
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
    out: dict[str, np.ndarray] = {}
    if COP in res:  # a coordinate not measured (nan) does not count
        out[COP] = np.sqrt(np.nansum((res[COP] / base[COP]) ** 2, axis=1))
    if TORQUE in res:
        out[TORQUE] = np.abs(res[TORQUE] / base[TORQUE])
    return out


def _base_errors(
    m: Measurements, weighted: bool, tau_weighted: bool | None = None
) -> dict[str, np.ndarray]:
    """Each kind's given errors (ones when not weighted; the torques' by ``tau_weighted``,
    None: as ``weighted``)."""
    out: dict[str, np.ndarray] = {}
    tau_w = weighted if tau_weighted is None else tau_weighted
    if m.cop is not None:
        out[COP] = m.cop_se if (weighted and m.cop_se is not None) else np.ones((m.n, 2))
    if m.tau is not None:
        se = m.tau_se if (tau_w and m.tau_se is not None) else None
        out[TORQUE] = se if se is not None else np.ones(m.tau.shape)
    return out


def _weights(u: np.ndarray, scale: float, k: float) -> np.ndarray:
    """Huber weights of standardised sizes ``u`` at robust scale ``scale``: 1 within k, k/u̅
    beyond."""
    return np.where(u / scale <= k, 1.0, k / np.maximum(u / scale, 1e-300))


class _Sources(Protocol):
    def chunks(self) -> Iterable[Measurements]: ...


#: sizes of one IRLS step: per source, per kind, the chunks' standardised sizes (spilled)
_Sizes = list[dict[str, Spill]]


@dataclass(frozen=True)
class _Huber:
    """The IRLS's settings: the threshold k, rows weighted by their given errors, the torques'
    by theirs (None: as ``weighted``)."""

    k: float
    weighted: bool
    tau_weighted: bool | None = None


class _Reweighted:
    """A source's chunks with the IRLS step's errors (``base · scale / √w``) as their standard
    errors: computed chunk by chunk from the spilled sizes, never held for the whole source."""

    def __init__(self, source: _Sources, sizes: dict[str, Spill], scale, huber: _Huber):
        self.source, self.sizes, self.scale, self.k = source, sizes, scale, huber.k
        self.weighted, self.tau_w = huber.weighted, huber.tau_weighted
        self.name = getattr(source, "name", "data")

    def chunks(self) -> Iterator[Measurements]:
        """The reweighted chunks, in the source's order."""
        per_kind = {kd: iter(sp) for kd, sp in self.sizes.items()}
        for m in self.source.chunks():
            base = _base_errors(m, self.weighted, self.tau_w)
            w = {kd: _weights(next(per_kind[kd]), self.scale[kd], self.k) for kd in base}
            yield _with_errors(m, base, w, self.scale)

    def close(self) -> None:
        """The source is its caller's to close."""


def _spill_sizes(
    fit: Fit, sources: Sequence[_Sources], weighted: bool, tau_w: bool | None = None
) -> _Sizes:
    """One pass: every chunk's standardised sizes under ``fit``, spilled per source and kind."""
    out: _Sizes = []
    for src in sources:
        spills: dict[str, Spill] = {}
        for m in src.chunks():
            for kd, u in _standardised(fit, m, _base_errors(m, weighted, tau_w)).items():
                spills.setdefault(kd, Spill()).write(u)
        out.append(spills)
    return out


def _close(sizes: _Sizes | None) -> None:
    for spills in sizes or []:
        for sp in spills.values():
            sp.close()


def _change(new: _Sizes, scale, old: _Sizes | None, old_scale, k: float) -> float:
    """Largest change of a row's weight between two IRLS steps (the first from weights 1)."""
    change = 0.0
    for i, spills in enumerate(new):
        for kd, sp in spills.items():
            before = None if old is None else iter(old[i][kd])
            for u in sp:
                w = _weights(u, scale[kd], k)
                w0 = 1.0 if before is None else _weights(next(before), old_scale[kd], k)
                change = max(change, float(np.max(np.abs(w - w0), initial=0.0)))
    return change


def huber_sources(
    run: Callable[[list[Any], bool], Fit],
    sources: Sequence[_Sources],
    *,
    weighted: bool = False,
    k: float = HUBER_K,
    max_iter: int = 50,
    tol: float = 1e-4,
    tau_weighted: bool | None = None,
) -> Fit:
    """Huber IRLS around a fitting method ``run(sources, weighted)`` over data sources that can
    be read more than once (each ``.chunks()`` gives its chunks again, in the same order):
    flat memory for any number of poses.

    Each step reads the data twice (the sizes under the current fit, spilled to a temporary
    file; then ``run`` on the data reweighted chunk by chunk) plus a few sequential reads of
    the spilled sizes (the exact median, ``base.spill.median``): the result is the in-memory
    IRLS's, bit for bit. Each kind's residuals are standardised by a robust scale (median of a
    CoP pose's 2-D norm over √(2 ln 2), of a torque row's |e| over 0.6745) and by the given
    errors when ``weighted`` (the torques' when ``tau_weighted``, None: as ``weighted``); rows
    beyond ``k`` get weight k/u. ``fit.robust`` lists the poses
    whose weight fell (the lowest weight of their rows), lowest first; σ̂ and each kind's σ are
    in the data's units again (or a scale on the given errors when ``weighted``).
    """
    if not k > 0:
        raise SescidError(f"Huber threshold k must be > 0, got {k}")
    huber = _Huber(k, weighted, tau_weighted)
    fit = run(list(sources), weighted)
    used: _Sizes | None = None  # the sizes behind the weights of the current fit
    used_scale: dict[str, float] = {}
    scale: dict[str, float] = {}
    iterations = 0
    try:
        for iterations in range(1, max_iter + 1):  # noqa: B007 (reported after the loop)
            sizes = _spill_sizes(fit, sources, weighted, tau_weighted)
            kinds = list(dict.fromkeys(kd for spills in sizes for kd in spills))
            scale = {}
            for kd in kinds:
                pooled = [spills[kd] for spills in sizes if kd in spills]
                scale[kd] = median(pooled) / (_MEDIAN_NORM if kd == COP else _MEDIAN_ABS)
            if any(v <= 0 for v in scale.values()):
                _close(sizes)
                break
            change = _change(sizes, scale, used, used_scale, k)
            _close(used)
            used, used_scale = sizes, scale
            reweighted = [
                _Reweighted(src, spills, scale, huber)
                for src, spills in zip(sources, sizes, strict=True)
            ]
            fit = run(reweighted, True)
            if change < tol:
                break
        return _robust_fit(fit, used, used_scale, scale, iterations, huber)
    finally:
        _close(used)


def huber(
    run: Callable[[list[Measurements], bool], Fit], data: list[Measurements], **options
) -> Fit:
    """Huber IRLS around a fitting method ``run(data, weighted)`` on data in memory
    (``huber_sources`` with its keyword ``options``, each data set one chunk)."""

    def run_held(sources: list[Any], w: bool) -> Fit:
        return run([m for src in sources for m in src.chunks()], w)

    return huber_sources(run_held, [HeldSource(m) for m in data], **options)


def _with_errors(m: Measurements, base, w, scale) -> Measurements:
    changes = {}
    if COP in base:
        changes["cop_se"] = base[COP] * scale[COP] / np.sqrt(w[COP])[:, None]
    if TORQUE in base:
        changes["tau_se"] = base[TORQUE] * scale[TORQUE] / np.sqrt(w[TORQUE])
    return dataclasses.replace(m, **changes)


def _robust_fit(
    fit: Fit, used: _Sizes | None, used_scale, scale, iterations: int, huber: _Huber
) -> Fit:
    """The last IRLS fit in the data's units, with the down-weighted poses named (from the
    spilled sizes behind its weights; none when no step reweighted)."""
    k, weighted, tau_w = huber.k, huber.weighted, huber.tau_weighted
    low = []
    start = 0
    for spills in used or []:
        for chunk in zip(*spills.values(), strict=True):
            pose_w = np.ones(chunk[0].shape[0])
            for kd, u in zip(spills, chunk, strict=True):
                wk = _weights(u, used_scale[kd], k)
                pose_w = np.minimum(pose_w, wk if kd == COP else wk.min(axis=1))
            low += [(start + int(j), float(pose_w[j])) for j in np.flatnonzero(pose_w < 1.0)]
            start += pose_w.shape[0]
    low.sort(key=lambda t: (t[1], t[0]))
    kinds = tuple(
        dataclasses.replace(
            kf,
            sigma=kf.sigma * scale.get(kf.kind, math.nan),
            weighted=bool(tau_w) if (kf.kind == TORQUE and tau_w is not None) else weighted,
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
        weighted=kinds[0].weighted if len(kinds) == 1 else True,
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
