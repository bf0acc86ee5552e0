"""The estimation behind ``sescid.identify``: ``fit_measurements`` runs one method over
measurements in memory or streamed, for every measurement kind.

``fit_measurements(robot, data, method=…, options=IdentifyOptions(…))``: ``data`` is a
``Measurements`` (arrays: joint angles and a CoP and/or joint torques), a list of them (pooled
data sets, e.g. two files), or chunks of one data set (a file read once). ``method`` is a name
("auto", the default, "ls", "map", "consistent") or a method's options object
(``options.method_options``, the one dispatch). All kinds feed one system (``system``); least
squares weighs them by their own noise (``solve``); MAP adds a CAD prior (``map``); "auto"
chooses between them (``runs.fit_auto``); "consistent" turns the fit into physical masses and
CoMs (``consistent``); ``robust`` wraps any of them in Huber IRLS. ``sescid.identify`` (files
and arrays too) is the public entry; ``to_consistent`` makes masses for an existing fit.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from sescid.base.threads import one_blas_thread
from sescid.errors import OptionError
from sescid.estimation.data.measurements import Measurements
from sescid.estimation.data.sources import HeldSource, as_sources, in_memory
from sescid.estimation.result.fit import Fit, MethodName
from sescid.estimation.result.records import JointNoise
from sescid.estimation.solvers.consistent import consistent_from_fit
from sescid.estimation.solvers.options import (
    AutoOptions,
    ConsistentOptions,
    IdentifyOptions,
    MapOptions,
    MethodOptions,
    map_settings,
    method_options,
)
from sescid.estimation.solvers.runs import (
    WORSE_THAN_CAD,
    fit_online,
    fit_with_gains,
    run_method,
    warnings_of,
    with_extras,
)
from sescid.estimation.solvers.torque_noise import with_records
from sescid.kinds import TORQUE
from sescid.robot import Robot


def _unsided(fit: Fit) -> bool:
    """A fit of joint torques without approach sides (no friction columns): their static
    friction, unseparated, may leave outliers (``_outlying``) for ``robust="auto"``."""
    has_tau = fit.kind(TORQUE) is not None
    return has_tau and not any(e.kind == TORQUE and e.what == "friction" for e in fit.nuisance)


#: ``robust="auto"``: a torque residual beyond this many of its expected size is an outlier
#: (a Gaussian reading is one with probability 2·10⁻⁹; a static-friction band — a bounded
#: error — never: its largest is 1.6 of its mean's scale)
OUTLIER_Z = 6.0
#: the expected size is at least this share of the joint's median |r| (a fitted size near 0 at
#: no load would make any reading there an outlier)
OUTLIER_FLOOR = 0.25
#: … and a joint's readings show outliers when more than this share (and at least two) are
OUTLIER_SHARE = 0.01
#: rows of the data that judge it (every k-th row beyond this many)
OUTLIER_ROWS = 20000
_ROOT_HALF_PI = math.sqrt(math.pi / 2)  # Gaussian: σ = √(π/2) · E|r|


def _outlying(fit: Fit, sources) -> bool:
    """Whether a plain fit's torque residuals show outliers (``OUTLIER_Z``, ``OUTLIER_SHARE``).
    Each joint's expected residual size is its own and grows with the load — a + b·|τ̂|, a, b ≥ 0,
    fitted to |r| without its largest tenth, then without the outliers found — so noise that grows
    with the torque is not taken for outliers: down-weighting every loaded pose would make the
    fit, and its rank, follow the noise draw."""
    import scipy.optimize

    from sescid.estimation.solvers.least_squares import residuals

    stride = max(fit.n_poses // OUTLIER_ROWS, 1)
    res_rows, load_rows, start = [], [], 0
    for s in sources:
        for m in s.chunks():
            if m.tau is not None:
                part = m.take(np.arange((-start) % stride, m.n, stride))
                res = residuals(fit, part).get(TORQUE)
                if res is not None:
                    res_rows.append(np.abs(res))
                    load_rows.append(np.abs(part.tau - res))
            start += m.n
    if not res_rows:
        return False
    r, load = np.vstack(res_rows), np.vstack(load_rows)
    for j in range(r.shape[1]):
        ok = np.isfinite(r[:, j]) & np.isfinite(load[:, j])
        rj, x = r[ok, j], np.column_stack([np.ones(int(ok.sum())), load[ok, j]])
        if rj.size < 3:
            continue
        keep = rj <= np.quantile(rj, 0.9)  # the size fitted without the largest tenth first
        floor = OUTLIER_FLOOR * float(np.median(rj))
        for _ in range(2):
            if keep.sum() < 3:
                break
            coef = scipy.optimize.nnls(x[keep], rj[keep])[0]  # a, b ≥ 0
            size = np.maximum(x @ coef, floor) * _ROOT_HALF_PI
            keep = rj <= OUTLIER_Z * size
        n_out = int(rj.size - keep.sum())
        if n_out >= 2 and n_out > OUTLIER_SHARE * rj.size:
            return True
    return False


def _held(robot: Robot, sources, memory: list[Measurements] | None) -> list[Any]:
    """The data as sources: in memory where they are held there, else the sources themselves
    (re-read on each pass)."""
    return sources if memory is None else [HeldSource(m) for m in memory]


def _huber(
    robot: Robot,
    method: MethodOptions,
    opts: IdentifyOptions,
    sources,
    memory: list[Measurements] | None,
) -> Fit:
    """Huber IRLS around ``method``: over the sources, re-read each step (flat memory), or on
    the data in memory where the method needs them there (cross-validation)."""
    from sescid.estimation.solvers.robust import huber, huber_sources

    def run_sources(srcs: list[Any], weighted: bool, data=None) -> Fit:
        o = dataclasses.replace(opts, robust=False, weighted=weighted)
        return run_method(robot, method, o, srcs, data, compare=False)

    kw: dict[str, Any] = {"weighted": opts.weighted, "k": opts.huber_k,
                          "tau_weighted": opts.tau_weighted}  # fmt: skip
    if memory is not None:
        fit = huber(lambda d, w: run_sources([HeldSource(m) for m in d], w, d), memory, **kw)
    else:
        fit = huber_sources(run_sources, sources, **kw)
    if method.method != "ls":
        return fit
    plain = dataclasses.replace(opts, robust=False)  # least squares judged once, unweighted
    first = run_method(robot, method, plain, _held(robot, sources, memory), memory)
    extra = tuple(w for w in first.warnings if w.startswith(WORSE_THAN_CAD))
    return dataclasses.replace(fit, warnings=fit.warnings + extra)


def _per_joint(opts: IdentifyOptions) -> bool:
    """Whether the torque rows' noise is estimated per joint (``torque_noise``): the default,
    unless one level is given or the fit is recursive or estimates gains."""
    return (
        opts.tau_noise_model == "joint"
        and opts.tau_noise is None
        and opts.online_step is None
        and not opts.tau_gains
        and opts.tau_weighted is None
    )


def _joint_noise(
    robot: Robot, method: MethodOptions, opts: IdentifyOptions, sources, memory, first: Fit
):
    """Feasible GLS of the torque rows (``torque_noise.per_joint_noise``) from a plain fit
    ``first``: the sources (and the data in memory) with each joint's σ_j as its rows'
    standard errors, the options that weigh them, the records and the last plain fit."""
    from sescid.estimation.solvers.torque_noise import JointScaled, per_joint_noise

    plain = dataclasses.replace(opts, robust=False, tau_weighted=True)

    def run(srcs: list[Any], weighted: bool) -> Fit:
        del weighted  # the torque rows carry σ_j; the CoP rows stay as asked
        held = None if memory is None else [x for s in srcs for x in s.chunks()]
        return run_method(robot, method, plain, srcs, held)

    wrapped, records, last, unit = per_joint_noise(run, list(sources), opts.weighted, first)
    if wrapped is None:
        return sources, memory, opts, (), first, None
    if memory is not None:
        sigma = {r.joint: r.sigma for r in records}
        memory = [next(JointScaled(HeldSource(x), sigma, opts.weighted).chunks()) for x in memory]
        wrapped = [HeldSource(x) for x in memory]
    return wrapped, memory, dataclasses.replace(opts, tau_weighted=True), records, last, unit


def _final_records(fit: Fit, sources, used: tuple[JointNoise, ...], unit):
    """The σ_j the final fit weighed each joint's rows by (``used``), with the residual RMS,
    degrees of freedom and share of the parameters under that fit (the sources carry σ_j as
    their errors: the RMS back in units of the original errors; ``unit``: the Gram sums at
    scale 1 of the passes that found σ_j, scaled by it)."""
    from sescid.estimation.solvers.torque_noise import joint_noise, joint_stats

    joints = tuple(r.joint for r in used)
    # the sources carry σ_j in their errors: Gram sums made from them are at the fit's weights
    scale = {r.joint: r.sigma for r in used} if unit is not None else dict.fromkeys(joints, 1.0)
    st = joint_stats(fit, sources, joints, True, scale, unit)
    new = joint_noise(st, fit, joints)
    return tuple(
        dataclasses.replace(u, rms=r.rms * u.sigma, dof=r.dof, params=r.params)
        for u, r in zip(used, new, strict=True)
    )


def check_method(method: MethodOptions, opts: IdentifyOptions) -> None:
    """OptionError for a shared option the method cannot run with (each object has checked its
    own values): the recursive fit and the torque gains run least squares or MAP only."""
    settings = map_settings(method)
    if opts.online_step is not None:
        if method.method == "consistent":
            raise OptionError("online", "the recursive fit supports ls or map, not consistent")
        if opts.robust is True or (settings is not None and settings.bias):
            raise OptionError("online", "the recursive fit cannot be robust or fit a bias")
        if isinstance(method, MapOptions) and (method.prior_scale is None or method.noise is None):
            raise OptionError(
                "online",
                "a recursive MAP fit needs --prior-scale and --noise (m): its prior and noise",
            )
    if opts.tau_gains and (opts.robust is True or method.method == "consistent"):
        raise OptionError("tau_gains", "torque gains go with ls or map, not robust or consistent")


@one_blas_thread(preload=("scipy.linalg",))  # the MAP of the default method uses scipy's
def fit_measurements(
    robot: Robot,
    data: Any,
    *,
    method: MethodName | MethodOptions = "auto",
    options: IdentifyOptions | None = None,
    progress: Callable[[int, int | None], None] | None = None,
) -> Fit:
    """Identify the SESC vectors (and sensor offsets) from static poses and what was measured.

    ``data``: a ``Measurements`` (q (n, nq) rad with a CoP (n, 2) m and/or joint torques (n, J)
    N·m), a list of them (pooled data sets) or chunks of one data set. ``method``: "auto" (the
    default: MAP with the CAD prior when the data leave directions weakly determined, least
    squares when they determine every direction well; ``fit.choice`` says which and why), "ls"
    (least squares, the paper's), "map" (Gaussian CAD prior) or "consistent" (physical
    masses/CoMs), or that method's options object (``MapOptions(…)``, ``AutoOptions(…)``,
    ``ConsistentOptions(…)``). ``options``: what every method shares (``IdentifyOptions``).
    ``progress(poses_done, total)`` is called while the normal equations are accumulated
    (total None for data read once). Data-quality warnings are stored in ``fit.warnings``.
    """
    m = method_options(method)
    opts = options or IdentifyOptions()
    check_method(m, opts)
    weighted = opts.weighted
    sources = opened = as_sources(robot, data, opts.kinds)
    try:
        robust = opts.robust
        settings = map_settings(m)
        needs_memory = (
            (settings is not None and settings.select == "cv")
            or opts.cv is not None
            or opts.joint_noise is not None
            or opts.online_step is not None
            or opts.tau_gains
        )
        memory = in_memory(robot, sources) if needs_memory else None
        if robust == "auto" and memory is not None:
            unsided = any(x.tau is not None and x.approach is None for x in memory)
            if unsided:
                plain = dataclasses.replace(opts, robust=False, cv=None, joint_noise=None,
                                            tau_gains=False)  # fmt: skip
                first = run_method(robot, m, plain, _held(robot, sources, memory), memory)
                unsided = _unsided(first) and _outlying(first, _held(robot, sources, memory))
            robust = unsided
        choice = None
        plain_fit: Fit | None = None  # a plain fit of the data as they are (when made)
        records: tuple[JointNoise, ...] = ()
        unit = None  # the torque rows' Gram sums at scale 1 (torque_noise.joint_stats)
        if _per_joint(opts):
            plain = dataclasses.replace(opts, robust=False)
            plain_fit = run_method(robot, m, plain, _held(robot, sources, memory), memory,
                                   progress)  # fmt: skip
            if plain_fit.kind(TORQUE) is not None:
                sources, memory, opts, records, plain_fit, unit = _joint_noise(
                    robot, m, opts, sources, memory, plain_fit
                )
        if isinstance(m, AutoOptions) and opts.online_step is not None:
            # a recursive MAP fit needs its prior scale and noise given
            known = m.map.prior_scale is not None and m.map.noise is not None
            m = m.resolved("map" if known else "ls")
        elif isinstance(m, AutoOptions) and (opts.tau_gains or robust is True):
            plain = dataclasses.replace(opts, robust=False, tau_gains=False)  # a plain pass decides
            choice = run_method(robot, m, plain, _held(robot, sources, memory),
                                memory).choice  # fmt: skip
            m = m.resolved(choice.chosen if choice is not None else "map")
        if opts.online_step is not None:
            assert memory is not None
            fit = fit_online(robot, m, opts, memory)
        elif opts.tau_gains:
            assert memory is not None
            fit = fit_with_gains(robot, m, opts, memory)
        elif robust is True:
            fit = _huber(robot, m, opts, sources, memory)
        else:
            fit = plain_fit or run_method(robot, m, opts, sources, memory, progress)
            if (
                robust == "auto" and _unsided(fit) and _outlying(fit, _held(robot, sources, memory))
            ):  # torques without sides whose residuals show outliers: known after a pass
                choice = fit.choice
                if isinstance(m, AutoOptions) and choice is not None:
                    m = m.resolved(choice.chosen)
                fit = _huber(robot, m, opts, sources, memory)
        if choice is not None:
            fit = dataclasses.replace(fit, choice=choice)
        fit = with_extras(robot, m, opts, fit, memory)
        if records:
            fit = with_records(fit, _final_records(fit, sources, records, unit), weighted)
    finally:
        for s in opened:
            s.close()
    return dataclasses.replace(fit, warnings=warnings_of(fit, opts))


@one_blas_thread()
def to_consistent(fit: Fit, options: ConsistentOptions | None = None) -> Fit:
    """Masses/CoMs for a fit (``consistent_from_fit``): by default (``via="auto"``) a MAP fit's
    SESC vectors are reproduced, any other fit is weighed against an evidence-chosen CAD prior
    on the masses and CoMs (``ConsistentOptions.via``)."""
    opts = options or ConsistentOptions()
    src, kw = opts.resolved(fit)
    return consistent_from_fit(src, **kw)
