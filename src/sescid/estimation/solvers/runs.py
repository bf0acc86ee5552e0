"""How ``identify`` runs a method over its sources: the system accumulated once, least squares or
MAP, the consistent step, residuals on a second pass; and the variants that revisit the data in
memory (robust reweighting, torque gains, the recursive estimator, cross-validation and the
joint-noise Monte Carlo)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from sescid.errors import OptionError
from sescid.estimation.data.checks import check_total_mass, fit_warnings
from sescid.estimation.data.measurements import Measurements
from sescid.estimation.data.sources import HeldSource, StreamSource
from sescid.estimation.result.fit import Fit
from sescid.estimation.result.validation import folds as split_folds
from sescid.estimation.solvers.consistent import consistent_from_fit
from sescid.estimation.solvers.least_squares import (
    fit_least_squares,
    refit_nuisance,
    with_residuals,
)
from sescid.estimation.solvers.map import fit_map
from sescid.estimation.solvers.options import (
    AutoOptions,
    ConsistentOptions,
    IdentifyOptions,
    MapOptions,
    MethodOptions,
)
from sescid.estimation.sums.pooled import accumulate_sources
from sescid.estimation.sums.system import RowOptions, System
from sescid.kinds import COP, TORQUE
from sescid.robot import Robot

#: a (list of) Measurements → Fit function: one method with fixed options (cv, Monte Carlo)
Fitter = Callable[[list[Measurements]], Fit]


def make_fitter(robot: Robot, method: MethodOptions, options: IdentifyOptions) -> Fitter:
    """The function data → Fit that ``identify`` runs for ``method`` (robust excluded)."""

    def fitter(data: list[Measurements]) -> Fit:
        return run_method(robot, method, options, [HeldSource(m) for m in data], data)

    return fitter


def run_method(
    robot: Robot,
    method: MethodOptions,
    options: IdentifyOptions,
    sources,
    memory: list[Measurements] | None,
    progress=None,
    compare: bool = True,
) -> Fit:
    """One method over sources (the system accumulated once), residuals on a second pass;
    ``progress(done, total)`` while accumulating (total None for data read once);
    ``compare``: judge least squares against the CAD model (``_against_cad``; off inside a
    refit loop)."""
    check_total_mass(robot, options.total_mass)
    total = None
    if all(not isinstance(s, StreamSource) for s in sources):
        total = sum(m.n for s in sources for m in s.chunks())
    report = None if progress is None else (lambda d: progress(d, total))
    rows = options.rows(method)
    system = accumulate_sources(robot, [s.chunks() for s in sources], rows, report)
    if rows.cop_offset and COP not in system.kinds:
        raise OptionError("bias", "a CoP offset needs CoP data (cop_x, cop_y)")
    system, r_prior, scale = _anchor(robot, system, options)
    if isinstance(method, AutoOptions):
        fit = fit_auto(robot, system, options, method.map, r_prior)
    elif isinstance(method, MapOptions):
        cv = None
        if method.select == "cv" and method.prior_scale is None:
            if memory is None:
                raise OptionError("select", "cross-validation needs the data in memory")
            cv = fold_systems(robot, memory, method.folds, options.seed, rows)
        fit = fit_map(
            robot, system, method, rtol=options.rtol, cv_folds=cv, kind_noise=options.noise(),
            r_prior=r_prior,
        )  # fmt: skip
    else:
        fit = fit_least_squares(
            robot, system, rtol=options.rtol, noise=options.noise(), r_prior=r_prior,
            allow_exact=options.allow_exact,
        )  # fmt: skip
        if method.method == "ls" and compare:
            fit = _against_cad(robot, system, options, r_prior, fit)
    if scale is not None:
        fit = with_scale(fit, scale)
    fit = with_residuals(fit, sources=[s.chunks() for s in sources])
    if isinstance(method, ConsistentOptions):
        copts = method
        if copts.total_mass is None and options.total_mass is not None:
            copts = dataclasses.replace(copts, total_mass=options.total_mass)
        src, kw = copts.resolved(fit)
        masses = refit_nuisance(consistent_from_fit(src, **kw), system)
        fit = with_residuals(masses, sources=[s.chunks() for s in sources])
        dof = fit.n_rows - fit.rank
        if len(fit.kinds) == 1 and not fit.kinds[0].weighted:
            sig = math.sqrt(fit.rms**2 * fit.n_rows / dof) if dof > 0 else math.nan
            fit = dataclasses.replace(fit, sigma_hat=sig)
    return fit


#: method "auto" takes least squares when the prior holds less than this share of the
#: information in every direction the data see (MAP and least squares then agree)
AUTO_LS_SHARE = 0.01
#: method "auto" departs from the CAD model only when the data's evidence for a prior scale
#: above none is at least e^this (a Bayes factor of 7.4: over 120 draws of the physics bench's
#: OP2, 38 poses, it took the share of draws worse than CAD from 12.5 % to 2.5 %, the mean CoP
#: error from 1.33 to 1.40 mm, the CAD model's 2.22 mm)
AUTO_EVIDENCE = 2.0
#: … and never when the evidence's best scale lies at this share of the top of its range
#: (``map.TAU_RANGE``): an evidence still growing there has no maximum, it runs away
AUTO_EDGE = 0.99


def fit_auto(
    robot: Robot, system: System, options: IdentifyOptions, settings: MapOptions, r_prior
) -> Fit:
    """Method "auto": MAP with the CAD prior (``settings``: per body, its scale chosen by
    evidence unless given), or least squares when the data determine every direction they see
    well (``AUTO_LS_SHARE``)."""
    from sescid.estimation.result.records import MethodChoice

    # least squares first: the answer when the data determine enough; data without residual
    # degrees of freedom (fewer poses than ``poses_needed``) it cannot fit, MAP can (its noise
    # and intervals then rest on the evidence, and the fit says so)
    fit = fit_least_squares(
        robot, system, rtol=options.rtol, noise=options.noise(), r_prior=r_prior,
        allow_exact=True,
    )  # fmt: skip
    exact = fit.n_rows - fit.rank - sum(e.determined for e in fit.nuisance) <= 0
    mapped = fit_map(
        robot, system, settings, rtol=options.rtol, kind_noise=options.noise(), r_prior=r_prior
    )
    assert mapped.map is not None
    share = mapped.map.prior_share
    if settings.bias:
        why = "a constant CoP offset is separated from the support body's r by the prior only"
        return dataclasses.replace(mapped, choice=MethodChoice("map", why))
    if share < AUTO_LS_SHARE and not (exact and not options.allow_exact):
        why = (
            f"the data determine every direction they see (the prior would hold at most "
            f"{share:.2%} of the information in any)"
        )
        return dataclasses.replace(fit, choice=MethodChoice("ls", why))
    seen = mapped.rank
    from sescid.estimation.result.records import REPEATED
    from sescid.estimation.solvers.map import repeated_poses

    if mapped.map.prior_scale_by == REPEATED:
        why = repeated_poses(system, fit.rank + sum(e.determined for e in fit.nuisance))
        why = f"{why}: the model is kept, its prior holding every direction"
        return dataclasses.replace(mapped, choice=MethodChoice("map", why))
    if settings.prior_scale is None and mapped.map.prior_scale_by == "evidence":
        # the CAD model stays unless the data show it is off: the evidence of the best prior
        # scale against (almost) none, a Bayes factor of at least e^AUTO_EVIDENCE
        from sescid.estimation.solvers.map import TAU_RANGE

        pinned = dataclasses.replace(settings, prior_scale=TAU_RANGE[0])
        cad = fit_map(
            robot, system, pinned, rtol=options.rtol, kind_noise=options.noise(),
            r_prior=r_prior,
        )  # fmt: skip
        assert cad.map is not None
        gain = mapped.map.log_evidence - cad.map.log_evidence
        if mapped.map.prior_scale >= AUTO_EDGE * TAU_RANGE[1]:
            why = (
                f"the evidence grows up to the widest prior scale searched "
                f"({mapped.map.prior_scale:.3g}): the data would take any deviation from the "
                "CAD model, which no error of a robot's masses explains — an error the model "
                "lacks (a sensor's bias, repeated or nearly repeated poses) fitted as mass; "
                "the model is kept, its prior holding every direction"
            )
            return dataclasses.replace(cad, choice=MethodChoice("map", why))
        if gain < AUTO_EVIDENCE:
            why = (
                f"the data do not show the CAD model to be off (the evidence of the best prior "
                f"scale exceeds that of the model as it is by a factor e^{gain:.2f} < "
                f"e^{AUTO_EVIDENCE:g}): the model is kept, its prior holding every direction"
            )
            return dataclasses.replace(cad, choice=MethodChoice("map", why))
    why = (
        f"the data leave directions weakly determined (the prior holds up to {share:.0%} of the "
        f"information in one of the {seen} they see): the CAD prior, per body, its scale chosen "
        "by the data, keeps what the data show and not their noise"
    )
    return dataclasses.replace(mapped, choice=MethodChoice("map", why))


#: the start of the warning of a least-squares fit expected to be worse than the CAD model
WORSE_THAN_CAD = (
    "least squares is expected to predict the CoM worse than the CAD model it would replace"
)
#: the poses over which that expectation is taken: this many, uniform within ±``JUDGE_RANGE``
#: (rad) of the zero pose and the joint limits, from a fixed seed
JUDGE_POSES, JUDGE_RANGE = 200, math.radians(30)


def com_information(robot: Robot) -> np.ndarray:
    """(3N, 3N) the mean over ``JUDGE_POSES`` poses of Φ_comᵀΦ_com: ``δᵀ S δ`` is the mean
    squared 3-D CoM error (m²) of SESC vectors off by δ."""
    from sescid.simulation import random_poses

    q = random_poses(robot, JUDGE_POSES, math.degrees(JUDGE_RANGE), 0, clip=True)
    phi = robot.regressor(q, (0, 1, 2)).reshape(-1, 3 * len(robot.body_names))
    return phi.T @ phi / JUDGE_POSES


def expected_row_errors(ls: Fit, mapped: Fit) -> tuple[float, float]:
    """(least squares, CAD) expected RMS 3-D CoM error [m] over ``JUDGE_POSES`` poses
    (``com_information``, S), along the directions the data see (both take the others from the
    CAD model), judged by a MAP fit: least squares' own variance tr(S C_ls), the CAD model's
    distance from the MAP estimate and its variance, δᵀSδ + tr(S C_map), with S projected on
    the seen subspace (``Fit.basis``) and δ = r_map − r_cad."""
    basis = ls.basis
    s = basis @ (basis.T @ com_information(ls.robot) @ basis) @ basis.T
    delta = (mapped.r - mapped.r_prior).reshape(-1)
    ls_var = float(np.sum(s * ls.cov))
    cad = float(delta @ s @ delta) + float(np.sum(s * mapped.cov))
    return math.sqrt(max(ls_var, 0.0)), math.sqrt(max(cad, 0.0))


def _against_cad(robot: Robot, system: System, options: IdentifyOptions, r_prior, ls: Fit) -> Fit:
    """Least squares with a warning when it is expected to predict the CoM worse than the CAD
    model it would replace (``expected_row_errors``, judged by a MAP fit of the same data)."""
    if not np.all(np.isfinite(ls.cov)) or ls.rank == 0:
        return ls
    mapped = fit_map(
        robot, system, MapOptions(), rtol=options.rtol, kind_noise=options.noise(),
        r_prior=r_prior,
    )  # fmt: skip
    ls_err, cad_err = expected_row_errors(ls, mapped)
    if not ls_err > cad_err:
        return ls
    warning = (
        f"{WORSE_THAN_CAD} (its 3-D CoM error over random poses ≈ {ls_err * 1e3:.2f} mm against "
        f"{cad_err * 1e3:.2f} mm for the CAD model, judged with the CAD prior): the data are "
        "too few or too noisy for it; the default method (auto) or --method map keeps what they "
        "show without their noise"
    )
    return dataclasses.replace(ls, warnings=(*ls.warnings, warning))


def _anchor(robot: Robot, system: System, options: IdentifyOptions):
    """Homogeneous data (``anchor``): the system pinned to the prior's scale — or to a known
    CoM height (``options.com_height``), for which the prior model is scaled first — with the
    prior SESC vectors used and the scale's source; the data as they are otherwise."""
    from sescid.estimation.data import anchor
    from sescid.estimation.data.checks import check_com_height
    from sescid.estimation.solvers.least_squares import prior_theta

    r0 = robot.sesc_vectors() if options.r_prior is None else np.asarray(options.r_prior)
    theta0 = prior_theta(robot, system, options.r_prior)
    if not anchor.homogeneous(robot, system, theta0):
        if options.com_height is not None:
            raise OptionError(
                "com_height", "a known CoM height anchors balance data only; these data carry "
                "their own scale"
            )  # fmt: skip
        return system, options.r_prior, None
    prior_distance = anchor.com_distance(robot, r0)
    by = "prior"
    if system.space == "bodies":  # pooled stances: the prior's scale, on the shared parameters
        from sescid.estimation.sums.pooled import stance_map

        if options.com_height is not None:
            raise OptionError("com_height", "a known CoM height anchors one stance's data")
        lmap = stance_map(robot, robot.support)
        a_r = anchor.scale_functional(robot, lmap.shape[0], r0)
        a = np.zeros(system.size)
        a[: system.n_x] = lmap.T @ a_r
        return anchor.anchored(system, a, theta0), None, (by, prior_distance, None)
    if options.com_height is not None:
        check_com_height(robot, options.com_height, r0)
        lam = anchor.rescale(robot, r0, options.com_height)
        r_c = anchor.collapse_point(robot, system)[: system.n_x].reshape(-1, 3)
        r0 = r_c + lam * (r0 - r_c)
        theta0[: system.n_x] = r0.reshape(-1)
        by = "com_height"
    a = anchor.scale_functional(robot, system.size, r0)
    return anchor.anchored(system, a, theta0), r0, (by, prior_distance, options.com_height)


def with_scale(fit: Fit, scale: tuple) -> Fit:
    """The fit of anchored data with its ``ScaleAnchor`` record; scaled about the collapse
    point to the known CoM height exactly (the anchor held it along one direction)."""
    from sescid.estimation.data import anchor
    from sescid.estimation.result.identifiability import combination_vector
    from sescid.estimation.result.records import ScaleAnchor

    by, prior_distance, height = scale
    robot = fit.robot
    if height is not None:
        lam = anchor.rescale(robot, fit.r, height)
        r_c = np.zeros_like(fit.r)
        r_c[0] = -robot.tree.root_r.T @ robot.d
        r = r_c + lam * (fit.r - r_c)
        base = tuple(
            dataclasses.replace(
                c, value=float(combination_vector(robot, c.terms) @ r.reshape(-1)),
                std=c.std * lam,
            )
            for c in fit.base
        )  # fmt: skip
        fit = dataclasses.replace(fit, r=r, cov=fit.cov * lam**2, base=base)
    record = ScaleAnchor(by, anchor.com_distance(robot, fit.r), prior_distance)
    return dataclasses.replace(fit, scale=record)


def fold_systems(
    robot: Robot, memory: list[Measurements], k: int, seed: int, rows: RowOptions
) -> list[System]:
    """The systems of k folds of the poses (pooled sources split alike)."""
    if len(memory) != 1:
        raise OptionError("select", "cross-validation takes one data set, not pooled ones")
    m = memory[0]
    out = []
    for f in split_folds(m.n, k, seed):
        part = m.take(f)
        out.append(accumulate_sources(robot, [[part]], rows))
    return out


def with_extras(
    robot: Robot, method: MethodOptions, opts: IdentifyOptions, fit: Fit, memory
) -> Fit:
    """Cross-validation and the joint-noise Monte Carlo of the fitted method."""
    if opts.cv is None and opts.joint_noise is None:
        return fit
    if memory is None or len(memory) != 1:
        raise OptionError("cv", "cross-validation and the Monte Carlo take one data set")
    from sescid.estimation.result.validation import cross_validate
    from sescid.estimation.solvers.robust import huber, joint_noise_mc

    plain = dataclasses.replace(opts, robust=False, cv=None, joint_noise=None)

    def fitter(data: list[Measurements]) -> Fit:
        if opts.robust is not True:
            return make_fitter(robot, method, plain)(data)
        return huber(
            lambda d, w: make_fitter(robot, method, dataclasses.replace(plain, weighted=w))(d),
            data, weighted=opts.weighted, k=opts.huber_k,
        )  # fmt: skip

    changes: dict[str, Any] = {}
    if opts.cv is not None:
        changes["cv"] = cross_validate(fitter, memory[0], opts.cv, opts.seed)
    if opts.joint_noise is not None:
        changes["joint_noise"] = joint_noise_mc(
            fitter, fit, memory[0], opts.joint_noise, draws=opts.mc_draws, seed=opts.seed
        )
    return dataclasses.replace(fit, **changes)


def fit_with_gains(robot: Robot, method: MethodOptions, opts: IdentifyOptions, memory) -> Fit:
    """The fit with a gain per torque sensor (``gains.with_gains``, Gauss–Newton)."""
    from sescid.estimation.solvers.gains import with_gains

    if not any(m.tau is not None for m in memory):
        raise OptionError("tau_gains", "torque gains need torque data (tau_<joint> columns)")
    plain = dataclasses.replace(opts, robust=False, tau_gains=False)
    start = run_method(robot, method, plain, [HeldSource(m) for m in memory], memory)

    def solve(system: System) -> Fit:
        if isinstance(method, MapOptions):
            return fit_map(
                robot, system, method, rtol=opts.rtol, kind_noise=opts.noise(),
                r_prior=opts.r_prior,
            )  # fmt: skip
        return fit_least_squares(
            robot, system, rtol=opts.rtol, noise=opts.noise(), r_prior=opts.r_prior,
            allow_exact=opts.allow_exact,
        )  # fmt: skip

    fit = with_gains(solve, robot, memory, plain, start, plain.rows(method))
    return with_residuals(fit, sources=[[m] for m in memory])


def fit_online(
    robot: Robot, method: MethodOptions, opts: IdentifyOptions, memory: list[Measurements]
) -> Fit:
    """The recursive estimator over the poses in order, ``online_step`` per update."""
    from sescid.estimation.solvers.online import OnlineEstimator

    if len(memory) != 1 or memory[0].kinds != (COP,):
        raise OptionError("online", "the recursive fit takes one CoP data set")
    m = memory[0]
    if m.gravity is not None:
        raise OptionError("online", "the recursive fit does not use gravity columns")
    prior = method.prior_scale if isinstance(method, MapOptions) else None
    noise = method.noise if isinstance(method, MapOptions) else None
    est = OnlineEstimator(
        robot, prior_scale=prior, noise=noise, rtol=opts.rtol, r_prior=opts.r_prior
    )
    step = opts.online_step or 1
    for s in range(0, m.n, step):
        part = m.take(slice(s, s + step))
        est.update(part.q, part.cop, part.cop_se if opts.weighted else None)
    return with_residuals(est.fit(), [m])


def warnings_of(fit: Fit, opts: IdentifyOptions) -> tuple[str, ...]:
    """The fit's data-quality warnings, and one for torques scaled by the model's mass."""
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
