"""One entry point, ``identify``, for every measurement kind and every estimation method.

``identify(robot, data, method="ls" | "map" | "consistent", options=IdentifyOptions(…))``: ``data``
is a ``Measurements`` (arrays: joint angles and a CoP and/or joint torques), a list of them
(pooled data sets, e.g. two files), or chunks of one data set (a file read once); joint angles
with ``cop=`` are accepted too. All kinds feed one system (``system``); least squares weighs them
by their own noise (``solve``); MAP adds a CAD prior (``map``); "consistent" turns the fit into
physical masses and CoMs (``consistent``); ``robust`` wraps any of them in Huber IRLS. The typed
options are the API's and the CLI's defaults alike (a test compares them).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sescid.base.threads import one_blas_thread
from sescid.errors import DataError, OptionError
from sescid.estimation.checks import check_total_mass, fit_warnings
from sescid.estimation.consistent import COM_SCALE, FIT_TOL, consistent_from_fit
from sescid.estimation.consistent_prior import evidence_prior_std, least_squares_view
from sescid.estimation.fit import METHODS, Fit
from sescid.estimation.identifiability import DEFAULT_RTOL, check_rtol
from sescid.estimation.least_squares import fit_least_squares, with_residuals
from sescid.estimation.map import fit_map
from sescid.estimation.measurements import COP, TORQUE, Measurements
from sescid.estimation.robust import HUBER_K
from sescid.estimation.sources import Source, StreamSource, as_sources, in_memory
from sescid.estimation.system import RowOptions, System, accumulate_sources
from sescid.estimation.validation import folds as split_folds
from sescid.robot import Robot
from sescid.sesc import STANDARD_GRAVITY


@dataclass(frozen=True)
class MapOptions:
    """MAP parameters: prior scale τ and noise σ (m; None = chosen by the data), how τ is
    chosen ("evidence" or "cv" with ``folds``), and whether a constant CoP offset is fitted."""

    prior_scale: float | None = None
    noise: float | None = None
    select: str = "evidence"
    folds: int = 5
    bias: bool = False


@dataclass(frozen=True)
class ConsistentOptions:
    """Consistent-mass parameters (see ``consistent_from_fit``): total mass kg (None: the
    identify options', else the model's), mass floor kg, left/right symmetry, CoM-box margin m,
    CAD prior (relative std), closest-to-CAD tuning (m), and per-body boxes {body: (lo, hi)} m.

    ``via``: "prior" — one QP, data + a CAD prior on masses/CoMs whose scale the data choose
    (evidence), CAD masses as the target so a weighed total goes where the data put it
    (controller-ready masses); "fit" — reproduce the fit first, then closest to CAD (follows the
    noise of a least-squares fit); "auto" (default) — "fit" for a MAP fit (it already weighs
    data against CAD), "prior" otherwise. With ``prior_std`` given, that scale is used."""

    total_mass: float | None = None
    mass_floor: float = 0.0
    symmetric: bool = False
    box_margin: float | None = None
    prior_std: float | None = None
    com_scale: float = COM_SCALE
    fit_tol: float = FIT_TOL
    boxes: dict[str, tuple] | None = None
    via: str = "auto"

    def kwargs(self) -> dict:
        """Keyword arguments of ``consistent_from_fit``."""
        out = dataclasses.asdict(self)
        del out["via"]
        return out

    def check(self) -> None:
        """OptionError for a value outside its range."""
        if self.via not in ("auto", "prior", "fit"):
            raise OptionError("via", f"must be 'auto', 'prior' or 'fit', got {self.via!r}")

    def path_for(self, fit: Fit) -> str:
        """The path, "prior" or "fit", that ``via`` means for this source fit."""
        if self.via != "auto":
            return self.via
        return "fit" if fit.method == "map" else "prior"

    def resolved(self, fit: Fit) -> tuple[Fit, dict]:
        """The fit and ``consistent_from_fit`` keywords this choice means for ``fit``."""
        kw = self.kwargs()
        if self.path_for(fit) == "prior" and self.prior_std is None:
            ls = least_squares_view(fit)
            tau, com_std = evidence_prior_std(ls, self.total_mass, self.com_scale)
            kw["prior_std"], kw["com_scale"] = tau, com_std / tau
            kw["spread"] = "data"
            return ls, kw
        return fit, kw


@dataclass(frozen=True)
class IdentifyOptions:
    """Everything ``identify`` can be told, with the defaults the CLI shows.

    ``rtol``: rank tolerance; ``weighted``: weigh rows by the data's standard-error columns;
    ``cop_noise`` [m] / ``tau_noise`` [N·m]: known noise of a kind (None: estimated);
    ``total_mass`` [kg]: weighed mass, the scale of torque rows (None: the model's, with a
    warning when torques are fitted) and of the consistent masses; ``gravity_accel`` [m/s²]:
    |g| behind torque rows; ``allow_exact``: fit even with no residual degrees of freedom (σ̂
    and every standard error are then "not determined"); ``robust``: Huber IRLS ("auto": on for
    torques without an approach side, whose static friction acts as bounded errors);
    ``huber_k``: its threshold in σ; ``seed``: for cross-validation folds and Monte Carlo;
    ``cv``: also score the method by k-fold cross-validation (``fit.cv``); ``joint_noise``
    [rad]: also propagate joint-angle errors of this std by ``mc_draws`` refits
    (``fit.joint_noise``); ``online_step``: fit recursively, this many poses per update
    (``fit.online`` keeps the convergence history; ls, or map with prior scale and noise);
    ``r_prior`` (N, 3) [m]: SESC vectors that fill what the data do not determine and centre
    the MAP prior (None: the model's).
    """

    rtol: float = DEFAULT_RTOL
    weighted: bool = False
    cop_noise: float | None = None
    tau_noise: float | None = None
    total_mass: float | None = None
    gravity_accel: float = STANDARD_GRAVITY
    allow_exact: bool = False
    robust: bool | str = False
    huber_k: float = HUBER_K
    seed: int = 0
    cv: int | None = None
    joint_noise: float | None = None
    mc_draws: int = 30
    online_step: int | None = None
    r_prior: np.ndarray | None = None
    map: MapOptions = field(default_factory=MapOptions)
    consistent: ConsistentOptions = field(default_factory=ConsistentOptions)

    def check(self, method: str) -> None:
        """OptionError for a value out of range or an option another method owns."""
        if method not in METHODS:
            raise OptionError("method", f"must be one of {', '.join(METHODS)}, got {method!r}")
        check_rtol(self.rtol)
        self.consistent.check()
        for name, value in (("cop_noise", self.cop_noise), ("tau_noise", self.tau_noise)):
            if value is not None and not (math.isfinite(value) and value > 0):
                raise OptionError(name, f"must be a positive noise level, got {value}")
        if not (math.isfinite(self.gravity_accel) and 1.0 <= self.gravity_accel <= 30.0):
            raise OptionError(
                "gravity_accel", f"must be |g| in m/s² (1–30), got {self.gravity_accel}"
            )
        if self.robust not in (True, False, "auto"):
            raise OptionError("robust", f"must be True, False or 'auto', got {self.robust!r}")
        if not (math.isfinite(self.huber_k) and self.huber_k > 0):
            raise OptionError("huber_k", f"must be > 0, got {self.huber_k}")
        if self.cv is not None and self.cv < 2:
            raise OptionError("cv", f"needs at least 2 folds, got {self.cv}")
        if self.joint_noise is not None and not (
            math.isfinite(self.joint_noise) and 0 < self.joint_noise <= math.pi / 2
        ):
            raise OptionError(
                "joint_noise", f"must be an angle in (0, π/2] rad, got {self.joint_noise}"
            )
        if self.mc_draws < 2:
            raise OptionError(
                "mc_draws", f"Monte Carlo needs at least 2 draws, got {self.mc_draws}"
            )
        if self.online_step is not None:
            self._check_online(method)
        if method != "map" and self.map != MapOptions():
            raise OptionError("map_options", f"apply to method 'map' only, not {method!r}")
        if method != "consistent" and self.consistent != ConsistentOptions():
            raise OptionError(
                "consistent_options", f"apply to method 'consistent' only, not {method!r}"
            )

    def _check_online(self, method: str) -> None:
        if self.online_step < 1:  # type: ignore[operator]
            raise OptionError("online_step", f"must be ≥ 1 pose, got {self.online_step}")
        if method not in ("ls", "map"):
            raise OptionError("online", f"the recursive fit supports ls or map, not {method}")
        if self.robust is True or self.map.bias:
            raise OptionError("online", "the recursive fit cannot be robust or fit a bias")
        if method == "map" and (self.map.prior_scale is None or self.map.noise is None):
            raise OptionError(
                "online",
                "a recursive MAP fit needs --prior-scale and --noise (m): its prior and noise",
            )

    def rows(self) -> RowOptions:
        """How rows are made from the data."""
        return RowOptions(
            weighted=self.weighted,
            total_mass=self.total_mass,
            cop_offset=self.map.bias,
            gravity_accel=self.gravity_accel,
        )

    def noise(self) -> dict[str, float]:
        """The kinds' given noise levels."""
        out = {}
        if self.cop_noise is not None:
            out[COP] = self.cop_noise
        if self.tau_noise is not None:
            out[TORQUE] = self.tau_noise
        return out


#: a (list of) Measurements → Fit function: one method with fixed options (cv, Monte Carlo)
Fitter = Callable[[list[Measurements]], Fit]


def make_fitter(robot: Robot, method: str, options: IdentifyOptions) -> Fitter:
    """The function data → Fit that ``identify`` runs for ``method`` (robust excluded)."""
    options.check(method)

    def fitter(data: list[Measurements]) -> Fit:
        return _fit(robot, method, options, [_Held(robot, m) for m in data], data)

    return fitter


class _Held:
    """Validated measurements as a source (no second validation)."""

    def __init__(self, robot: Robot, m: Measurements):
        self.data, self.name = m, m.source

    def chunks(self):
        """The data, as one chunk."""
        yield self.data

    def close(self) -> None:
        """Nothing to release."""


def _fit(robot, method, options, sources, memory: list[Measurements] | None, progress=None) -> Fit:
    """One method over sources (the system accumulated once), residuals on a second pass;
    ``progress(done, total)`` while accumulating (total None for data read once)."""
    check_total_mass(robot, options.total_mass)
    total = None
    if all(not isinstance(s, StreamSource) for s in sources):
        total = sum(m.n for s in sources for m in s.chunks())
    report = None if progress is None else (lambda d: progress(d, total))
    system = accumulate_sources(robot, [s.chunks() for s in sources], options.rows(), report)
    if options.map.bias and COP not in system.kinds:
        raise OptionError("bias", "a CoP offset needs CoP data (cop_x, cop_y)")
    if method == "ls" or method == "consistent":
        fit = fit_least_squares(
            robot, system, rtol=options.rtol, noise=options.noise(), r_prior=options.r_prior,
            allow_exact=options.allow_exact,
        )  # fmt: skip
    else:
        m = options.map
        cv = None
        if m.select == "cv" and m.prior_scale is None:
            if m.bias:
                raise OptionError("bias", "choosing the prior scale by cv does not fit a bias")
            if memory is None:
                raise OptionError("select", "cross-validation needs the data in memory")
            cv = _fold_systems(robot, memory, m.folds, options)
        elif m.select not in ("evidence", "cv"):
            raise OptionError("select", f"must be 'evidence' or 'cv', got {m.select!r}")
        fit = fit_map(
            robot, system, prior_scale=m.prior_scale, noise=m.noise, rtol=options.rtol,
            cv_folds=cv, kind_noise=options.noise(), r_prior=options.r_prior,
        )  # fmt: skip
    fit = with_residuals(fit, sources=[s.chunks() for s in sources])
    if method == "consistent":
        copts = options.consistent
        if copts.total_mass is None and options.total_mass is not None:
            copts = dataclasses.replace(copts, total_mass=options.total_mass)
        src, kw = copts.resolved(fit)
        fit = with_residuals(consistent_from_fit(src, **kw), sources=[s.chunks() for s in sources])
        dof = fit.n_rows - fit.rank
        if len(fit.kinds) == 1 and not fit.kinds[0].weighted:
            sig = math.sqrt(fit.rms**2 * fit.n_rows / dof) if dof > 0 else math.nan
            fit = dataclasses.replace(fit, sigma_hat=sig)
    return fit


def _fold_systems(robot, memory: list[Measurements], k: int, options) -> list[System]:
    """The systems of k folds of the poses (pooled sources split alike)."""
    if len(memory) != 1:
        raise OptionError("select", "cross-validation takes one data set, not pooled ones")
    m = memory[0]
    out = []
    for f in split_folds(m.n, k, options.seed):
        part = m.take(f)
        out.append(accumulate_sources(robot, [[part]], options.rows()))
    return out


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


@one_blas_thread()
def identify(
    robot: Robot,
    data: Any,
    cop: Any = None,
    *,
    method: str = "ls",
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
    ``method``: "ls" (least squares), "map" (Gaussian CAD prior) or "consistent" (physical
    masses/CoMs). ``options``: ``IdentifyOptions``; keyword ``overrides`` replace its fields
    (``rtol=``, ``robust=``, ``map_options=``, ``consistent_options=`` …).
    ``progress(poses_done, total)`` is called while the normal equations are accumulated
    (total None for data read once). Data-quality warnings are stored in ``fit.warnings``.
    """
    opts = options or IdentifyOptions()
    renamed = {"map_options": "map", "consistent_options": "consistent"}
    changes = {renamed.get(k, k): v for k, v in overrides.items() if v is not None}
    unknown = set(changes) - {f.name for f in dataclasses.fields(IdentifyOptions)}
    if unknown:
        raise OptionError(sorted(unknown)[0], "is not an option of identify")
    if sigma is not None:
        changes["weighted"] = True
    opts = dataclasses.replace(opts, **changes)
    opts.check(method)
    sources = as_sources(robot, _normalise(data, cop, sigma, gravity))
    try:
        robust = opts.robust
        if robust == "auto":  # torques without an approach side: from each source's first chunk
            heads = [s.first() for s in sources]
            robust = any(m is not None and m.tau is not None and m.approach is None for m in heads)
        needs_memory = (
            robust is not False
            or (method == "map" and opts.map.select == "cv")
            or opts.cv is not None
            or opts.joint_noise is not None
            or opts.online_step is not None
        )
        memory = in_memory(robot, sources) if needs_memory else None
        if opts.online_step is not None:
            assert memory is not None
            fit = _online(robot, method, opts, memory)
        elif robust:
            from sescid.estimation.robust import huber

            assert memory is not None

            def run(data: list[Measurements], weighted: bool) -> Fit:
                o = dataclasses.replace(opts, robust=False, weighted=weighted)
                return _fit(robot, method, o, [_Held(robot, m) for m in data], data)

            fit = huber(run, memory, weighted=opts.weighted, k=opts.huber_k)
        else:
            fit = _fit(robot, method, opts, sources, memory, progress)
        fit = _extras(robot, method, opts, fit, memory)
    finally:
        for s in sources:
            s.close()
    return dataclasses.replace(fit, warnings=_warnings(fit, opts))


def _extras(robot, method, opts: IdentifyOptions, fit: Fit, memory) -> Fit:
    """Cross-validation and the joint-noise Monte Carlo of the fitted method."""
    if opts.cv is None and opts.joint_noise is None:
        return fit
    if memory is None or len(memory) != 1:
        raise OptionError("cv", "cross-validation and the Monte Carlo take one data set")
    from sescid.estimation.robust import huber, joint_noise_mc
    from sescid.estimation.validation import cross_validate

    plain = dataclasses.replace(opts, robust=False, cv=None, joint_noise=None)

    def fitter(data: list[Measurements]) -> Fit:
        if opts.robust is not True:
            return _fit(robot, method, plain, [_Held(robot, m) for m in data], data)

        def run(d: list[Measurements], weighted: bool) -> Fit:
            o = dataclasses.replace(plain, weighted=weighted)
            return _fit(robot, method, o, [_Held(robot, m) for m in d], d)

        return huber(run, data, weighted=opts.weighted, k=opts.huber_k)

    changes: dict[str, Any] = {}
    if opts.cv is not None:
        changes["cv"] = cross_validate(fitter, memory[0], opts.cv, opts.seed)
    if opts.joint_noise is not None:
        changes["joint_noise"] = joint_noise_mc(
            fitter, fit, memory[0], opts.joint_noise, draws=opts.mc_draws, seed=opts.seed
        )
    return dataclasses.replace(fit, **changes)


def _online(robot, method, opts: IdentifyOptions, memory: list[Measurements]) -> Fit:
    """The recursive estimator over the poses in order, ``online_step`` per update."""
    from sescid.estimation.online import OnlineEstimator

    if len(memory) != 1 or memory[0].kinds != (COP,):
        raise OptionError("online", "the recursive fit takes one CoP data set")
    m = memory[0]
    if m.gravity is not None:
        raise OptionError("online", "the recursive fit does not use gravity columns")
    prior = opts.map.prior_scale if method == "map" else None
    noise = opts.map.noise if method == "map" else None
    est = OnlineEstimator(
        robot, prior_scale=prior, noise=noise, rtol=opts.rtol, r_prior=opts.r_prior
    )
    step = opts.online_step or 1
    for s in range(0, m.n, step):
        part = m.take(slice(s, s + step))
        est.update(part.q, part.cop, part.cop_se if opts.weighted else None)
    return with_residuals(est.fit(), [m])


def _warnings(fit: Fit, opts: IdentifyOptions) -> tuple[str, ...]:
    out = list(fit.warnings)
    out += [w for w in fit_warnings(fit) if w not in out]
    if fit.kind(TORQUE) is not None and not fit.mass_given:
        out.append(
            f"torques measure M·r: the total mass was not given, so the model's "
            f"{fit.robot.total_mass:.4g} kg sets the scale of the CoM (weigh the robot: "
            "total_mass / --total-mass)"
        )
    del opts
    return tuple(out)


@one_blas_thread()
def to_consistent(fit: Fit, options: ConsistentOptions | None = None) -> Fit:
    """Masses/CoMs for a fit (``consistent_from_fit``): by default (``via="auto"``) a MAP fit's
    SESC vectors are reproduced, any other fit is weighed against an evidence-chosen CAD prior
    on the masses and CoMs (``ConsistentOptions.via``)."""
    opts = options or ConsistentOptions()
    opts.check()
    src, kw = opts.resolved(fit)
    return consistent_from_fit(src, **kw)


Sources = list[Source]
