"""One entry point, ``identify``, for every measurement kind and every estimation method.

``identify(robot, data, method="auto" | "ls" | "map" | "consistent", options=…)``: ``data``
is a ``Measurements`` (arrays: joint angles and a CoP and/or joint torques), a list of them
(pooled data sets, e.g. two files), or chunks of one data set (a file read once); joint angles
with ``cop=`` are accepted too. All kinds feed one system (``system``); least squares weighs them
by their own noise (``solve``); MAP adds a CAD prior (``map``); "consistent" turns the fit into
physical masses and CoMs (``consistent``); ``robust`` wraps any of them in Huber IRLS. The typed
options are the API's and the CLI's defaults alike (a test compares them).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from sescid.base.threads import one_blas_thread
from sescid.errors import DataError, OptionError
from sescid.estimation.consistent import consistent_from_fit
from sescid.estimation.fit import Fit
from sescid.estimation.measurements import TORQUE, Measurements
from sescid.estimation.options import ConsistentOptions, IdentifyOptions
from sescid.estimation.runs import (
    WORSE_THAN_CAD,
    HeldSource,
    fit_online,
    fit_with_gains,
    run_method,
    warnings_of,
    with_extras,
)
from sescid.estimation.sources import as_sources, in_memory
from sescid.robot import Robot


def _unsided(fit: Fit) -> bool:
    """A fit of joint torques without approach sides (no friction columns): their static
    friction acts as bounded errors, for the robust loss of ``robust="auto"``."""
    has_tau = fit.kind(TORQUE) is not None
    return has_tau and not any(e.kind == TORQUE and e.what == "friction" for e in fit.nuisance)


def _held(robot, sources, memory: list[Measurements] | None) -> list[Any]:
    """The data as sources: in memory where they are held there, else the sources themselves
    (re-read on each pass)."""
    return sources if memory is None else [HeldSource(robot, m) for m in memory]


def _huber(robot, method, opts, sources, memory: list[Measurements] | None) -> Fit:
    """Huber IRLS around ``method``: over the sources, re-read each step (flat memory), or on
    the data in memory where the method needs them there (cross-validation)."""
    from sescid.estimation.robust import huber, huber_sources

    def run(data: list[Measurements], weighted: bool) -> Fit:
        o = dataclasses.replace(opts, robust=False, weighted=weighted)
        return run_method(robot, method, o, [HeldSource(robot, m) for m in data], data,
                          compare=False)  # fmt: skip

    def run_sources(srcs: list[Any], weighted: bool) -> Fit:
        o = dataclasses.replace(opts, robust=False, weighted=weighted)
        return run_method(robot, method, o, srcs, None, compare=False)

    if memory is not None:
        fit = huber(run, memory, weighted=opts.weighted, k=opts.huber_k)
    else:
        fit = huber_sources(run_sources, sources, weighted=opts.weighted, k=opts.huber_k)
    if method != "ls":
        return fit
    plain = dataclasses.replace(opts, robust=False)  # least squares judged once, unweighted
    first = run_method(robot, method, plain, _held(robot, sources, memory), memory)
    extra = tuple(w for w in first.warnings if w.startswith(WORSE_THAN_CAD))
    return dataclasses.replace(fit, warnings=fit.warnings + extra)


def _normalise(data, cop, sigma, gravity) -> Any:
    """``identify``'s data as Measurements (or a list / stream of them)."""
    if cop is None:
        if sigma is not None or gravity is not None:
            raise OptionError("sigma", "sigma= and gravity= go with joint angles and cop=")
        return data
    if isinstance(data, Measurements):
        raise OptionError("cop", "give cop= with joint angles, not with Measurements")
    return Measurements(
        q=np.asarray(data, dtype=float),
        cop=np.asarray(cop, dtype=float),
        cop_se=None if sigma is None else _se(sigma, np.shape(data)[0]),
        gravity=None if gravity is None else np.asarray(gravity, dtype=float),
        source="data",
    )


def _se(sigma, n: int) -> np.ndarray:
    s = np.asarray(sigma, dtype=float)
    if s.ndim == 1:
        if s.shape != (n,):
            raise DataError(f"sigma: expected shape ({n},) or ({n}, 2) in metres, got {s.shape}")
        s = np.repeat(s[:, None], 2, axis=1)
    return s


@one_blas_thread(preload=("scipy.linalg",))  # the MAP of the default method uses scipy's
def identify(
    robot: Robot,
    data: Any,
    cop: Any = None,
    *,
    method: str = "auto",
    options: IdentifyOptions | None = None,
    sigma: Any = None,
    gravity: Any = None,
    progress: Callable[[int, int | None], None] | None = None,
    **overrides: Any,
) -> Fit:
    """Identify the SESC vectors (and sensor offsets) from static poses and what was measured.

    ``data``: a ``Measurements`` (q (n, nq) rad with a CoP (n, 2) m and/or joint torques (n, J)
    N·m), a list of them (pooled data sets) or chunks of one data set; or joint angles with
    ``cop=`` (n, 2) m, optional ``sigma=`` per-pose CoP standard errors (n,) or (n, 2) m
    (a weighted fit) and ``gravity=`` per-pose gravity directions (n, 3) in the support frame.
    ``method``: "auto" (the default: MAP with the CAD prior when the data leave directions
    weakly determined, least squares when they determine every direction well; ``fit.choice``
    says which and why), "ls" (least squares, the paper's), "map" (Gaussian CAD prior) or
    "consistent" (physical masses/CoMs). ``options``: ``IdentifyOptions``; keyword
    ``overrides`` replace its fields (``rtol=``, ``robust=``, ``map_options=`` …).
    ``progress(poses_done, total)`` is called while the normal equations are accumulated
    (total None for data read once). Data-quality warnings are stored in ``fit.warnings``.
    """
    opts = (options or IdentifyOptions()).with_overrides(**overrides)
    if sigma is not None:
        opts = dataclasses.replace(opts, weighted=True)
    opts.check(method)
    sources = as_sources(robot, _normalise(data, cop, sigma, gravity), opts.kinds)
    try:
        robust = opts.robust
        needs_memory = (
            (method in ("map", "auto") and opts.map.select == "cv")
            or opts.cv is not None
            or opts.joint_noise is not None
            or opts.online_step is not None
            or opts.tau_gains
        )
        memory = in_memory(robot, sources) if needs_memory else None
        if robust == "auto" and memory is not None:
            robust = any(m.tau is not None and m.approach is None for m in memory)
        choice = None
        if method == "auto" and opts.online_step is not None:  # MAP online needs τ and σ given
            known = opts.map.prior_scale is not None and opts.map.noise is not None
            method = "map" if known else "ls"
        elif method == "auto" and (opts.tau_gains or robust is True):  # a plain pass decides
            plain = dataclasses.replace(opts, robust=False, tau_gains=False)
            choice = run_method(robot, "auto", plain, _held(robot, sources, memory),
                                memory).choice  # fmt: skip
            method = choice.chosen if choice is not None else "map"
        if opts.online_step is not None:
            assert memory is not None
            fit = fit_online(robot, method, opts, memory)
        elif opts.tau_gains:
            assert memory is not None
            fit = fit_with_gains(robot, method, opts, memory, opts.robust is True)
        elif robust is True:
            fit = _huber(robot, method, opts, sources, memory)
        else:
            fit = run_method(robot, method, opts, sources, memory, progress)
            if robust == "auto" and _unsided(fit):  # torques without sides: known after a pass
                choice = fit.choice
                method = choice.chosen if choice is not None else method
                fit = _huber(robot, method, opts, sources, memory)
        if choice is not None:
            fit = dataclasses.replace(fit, choice=choice)
        fit = with_extras(robot, method, opts, fit, memory)
    finally:
        for s in sources:
            s.close()
    return dataclasses.replace(fit, warnings=warnings_of(fit, opts))


@one_blas_thread()
def to_consistent(fit: Fit, options: ConsistentOptions | None = None) -> Fit:
    """Masses/CoMs for a fit (``consistent_from_fit``): by default (``via="auto"``) a MAP fit's
    SESC vectors are reproduced, any other fit is weighed against an evidence-chosen CAD prior
    on the masses and CoMs (``ConsistentOptions.via``)."""
    opts = options or ConsistentOptions()
    opts.check()
    src, kw = opts.resolved(fit)
    return consistent_from_fit(src, **kw)
