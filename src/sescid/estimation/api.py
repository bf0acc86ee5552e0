"""One entry point for every estimation method, with typed options shared by API and CLI.

``identify(robot, q, cop, method="ls"|"map"|"consistent", …)`` dispatches to
``identify_ls`` / ``identify_map`` / ``identify_consistent``; ``robust=True`` wraps the method in
Huber IRLS. ``MapOptions`` and ``ConsistentOptions`` carry each method's parameters (their
defaults are the API's, which the CLI shows). ``make_fitter`` gives the (q, cop, sigma) → Fit
function that cross-validation and the Monte Carlo re-run.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from sescid.base.threads import one_blas_thread
from sescid.errors import OptionError
from sescid.estimation.checks import fit_warnings
from sescid.estimation.consistent import (
    COM_SCALE,
    FIT_TOL,
    consistent_from_fit,
    identify_consistent,
)
from sescid.estimation.consistent_prior import evidence_prior_std, least_squares_view
from sescid.estimation.fit import METHODS, Fit
from sescid.estimation.identifiability import DEFAULT_RTOL, check_rtol
from sescid.estimation.least_squares import identify_ls, residual_stats
from sescid.estimation.map import identify_map
from sescid.estimation.robust import HUBER_K, huber
from sescid.estimation.validation import Fitter
from sescid.kinematics import as_poses
from sescid.robot import Robot


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
    model's), mass floor kg, left/right symmetry, CoM-box margin m, CAD prior (relative std),
    closest-to-CAD tuning (m), and per-body boxes {body: (lo, hi)} in m."""

    total_mass: float | None = None
    mass_floor: float = 0.0
    symmetric: bool = False
    box_margin: float | None = None
    prior_std: float | None = None
    com_scale: float = COM_SCALE
    fit_tol: float = FIT_TOL
    boxes: dict[str, tuple] | None = None
    #: "prior": one QP, data + a CAD prior on masses/CoMs whose scale the data choose
    #: (evidence, ``consistent_prior``), CAD masses as the target so a weighed total goes
    #: where the data put it — controller-ready masses; "fit": reproduce the fit first, then
    #: closest to CAD (follows the noise of a least-squares fit). "auto" (default): "fit" for a
    #: MAP fit (it already weighs the data against CAD with a scale the data chose, and the
    #: masses then reproduce its CoP), "prior" otherwise. With ``prior_std`` given, that scale
    #: is used (CAD masses scaled uniformly to the total, as before).
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


def _map(robot, q, cop, sigma, rtol, opts: MapOptions, seed: int, gravity=None) -> Fit:
    return identify_map(
        robot,
        q,
        cop,
        sigma=sigma,
        prior_scale=opts.prior_scale,
        noise=opts.noise,
        bias=opts.bias,
        rtol=rtol,
        select=opts.select,
        folds=opts.folds,
        seed=seed,
        gravity=gravity,
    )


def make_fitter(
    robot: Robot,
    method: str = "ls",
    *,
    rtol: float = DEFAULT_RTOL,
    map_options: MapOptions | None = None,
    consistent_options: ConsistentOptions | None = None,
    seed: int = 0,
) -> Fitter:
    """A function (q, cop, sigma[, gravity]) → Fit that runs ``method`` with these options."""
    if method not in METHODS:
        raise OptionError("method", f"must be one of {', '.join(METHODS)}, got {method!r}")
    check_rtol(rtol)
    mopts = map_options or MapOptions()
    copts = consistent_options or ConsistentOptions()
    copts.check()
    if method != "map" and map_options is not None and map_options != MapOptions():
        raise OptionError("map_options", f"apply to method 'map' only, not {method!r}")
    if method != "consistent" and consistent_options is not None:
        if consistent_options != ConsistentOptions():
            raise OptionError(
                "consistent_options", f"apply to method 'consistent' only, not {method!r}"
            )

    def fitter(q: np.ndarray, cop: np.ndarray, sigma: np.ndarray | None, gravity=None) -> Fit:
        if method == "ls":
            return identify_ls(robot, q, cop, sigma=sigma, rtol=rtol, gravity=gravity)
        if method == "map":
            return _map(robot, q, cop, sigma, rtol, mopts, seed, gravity)
        if copts.via in ("auto", "prior") and copts.prior_std is None:
            base = identify_ls(robot, q, cop, sigma=sigma, rtol=rtol, gravity=gravity)
            src, kw = copts.resolved(base)
            fit = consistent_from_fit(src, **kw)
            residual_stats(fit, q, cop, gravity)
            return fit
        return identify_consistent(
            robot, q, cop, sigma=sigma, rtol=rtol, gravity=gravity, **copts.kwargs()
        )

    return fitter


@one_blas_thread()
def identify(
    robot: Robot,
    q: ArrayLike,
    cop: ArrayLike,
    *,
    method: str = "ls",
    sigma: ArrayLike | None = None,
    rtol: float = DEFAULT_RTOL,
    map_options: MapOptions | None = None,
    consistent_options: ConsistentOptions | None = None,
    robust: bool = False,
    huber_k: float = HUBER_K,
    seed: int = 0,
    gravity: ArrayLike | None = None,
) -> Fit:
    """Identify the SESC vectors from poses q (n, nq) [rad] and CoPs (n, 2) [m].

    ``method``: "ls" (least squares), "map" (Gaussian CAD prior) or "consistent" (physical
    masses/CoMs). ``sigma``: per-pose CoP standard errors (n,) or (n, 2) m → weighted fit.
    ``robust``: Huber IRLS around the method (threshold ``huber_k`` σ). ``gravity``: per-pose
    gravity directions (n, 3) in the support frame (None: along −z, a level sole).
    Data-quality warnings (an unexcited subspace, σ̂ = 0) are stored in ``fit.warnings``.
    """
    fitter = make_fitter(
        robot,
        method,
        rtol=rtol,
        map_options=map_options,
        consistent_options=consistent_options,
        seed=seed,
    )
    qq = as_poses(q, robot.nq)
    cc = np.asarray(cop, dtype=float)
    ss = None if sigma is None else np.asarray(sigma, dtype=float)
    gg = None if gravity is None else np.asarray(gravity, dtype=float)
    fit = huber(fitter, qq, cc, ss, k=huber_k, gravity=gg) if robust else fitter(qq, cc, ss, gg)
    fit.warnings += [w for w in fit_warnings(fit) if w not in fit.warnings]
    return fit


@one_blas_thread()
def to_consistent(fit: Fit, options: ConsistentOptions | None = None) -> Fit:
    """Masses/CoMs for a fit (``consistent_from_fit``): by default (``via="auto"``) a MAP fit's
    SESC vectors are reproduced, any other fit is weighed against an evidence-chosen CAD prior
    on the masses and CoMs (``ConsistentOptions.via``)."""
    opts = options or ConsistentOptions()
    opts.check()
    src, kw = opts.resolved(fit)
    return consistent_from_fit(src, **kw)
