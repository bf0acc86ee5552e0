"""``calibrate_sensors``: the gains, offsets and SESC vectors with per-session noise levels.

One Gaussian least-squares problem with priors (the CAD SESC vectors with scale τ chosen by the
evidence as in ``estimation.map``; gains ``N(1, gain_prior²)``; offsets ``N(0,
offset_prior²)``), whitened by each session's noise levels on its force and moment rows,
which are estimated by iterating ``σ² = RSS / (rows − leverage)`` alternately with τ.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from sescid.base import G0
from sescid.errors import DataError, OptionError
from sescid.estimation.data.checks import check_total_mass
from sescid.estimation.result.fit import Fit
from sescid.estimation.solvers.least_squares import cop_system
from sescid.estimation.solvers.map import TAU_RANGE, fit_map
from sescid.estimation.solvers.options import MapOptions
from sescid.estimation.sums.normal_equations import NormalEquations
from sescid.robot import Robot
from sescid.sensors.calibration.directions import Problem, parameters, unseen_directions
from sescid.sensors.calibration.model import (
    NOISE_FLOOR_COP,
    NOISE_FLOOR_FORCE,
    SCALE,
    START_NOISE_COP,
    START_NOISE_FORCE,
    CalibrationOptions,
    KnownSensors,
    PadSession,
    SensorCalibration,
    SensorDirection,
    SessionContribution,
)
from sescid.sensors.calibration.rows import Rows, build_rows, check_sessions, sensor_columns


def spd_inverse(mat: np.ndarray) -> np.ndarray:
    """Inverse of a symmetric positive (semi)definite matrix: Cholesky, else eigen (clipped)."""
    import scipy.linalg  # lazy: scipy's import is ~0.3 s of every command

    try:
        cf = scipy.linalg.cho_factor(mat, check_finite=False)
        return scipy.linalg.cho_solve(cf, np.eye(mat.shape[0]), check_finite=False)
    except np.linalg.LinAlgError:
        lam, vec = np.linalg.eigh(0.5 * (mat + mat.T))
        lam = np.maximum(lam, lam.max() * 1e-15)
        return (vec / lam) @ vec.T


def _log_evidence(a: np.ndarray, z: np.ndarray, prec: np.ndarray) -> float:
    """Log p(z | priors) of whitened rows a θ ≈ z, θ ~ N(0, diag(1/prec)) (constants dropped)."""
    import scipy.linalg

    mat = a.T @ a + np.diag(prec)
    try:
        cf = scipy.linalg.cho_factor(mat, check_finite=False)
    except np.linalg.LinAlgError:
        return -math.inf
    b = a.T @ z
    quad = z @ z - b @ scipy.linalg.cho_solve(cf, b, check_finite=False)
    return -0.5 * (2 * np.sum(np.log(np.diag(cf[0]))) - np.sum(np.log(prec)) + quad)


def _problem(robot: Robot, sessions, rows: Rows, cols, index, opt, known) -> Problem:
    """Prior means and scales, and the parameters held fixed (``known``)."""
    p_x = 3 * len(robot.body_names)
    p = rows.a.shape[1]
    theta0 = np.concatenate([robot.sesc_vectors().reshape(-1), np.zeros(len(cols))])
    prior_sd = np.ones(p)
    for j, c in enumerate(cols):
        theta0[p_x + j] = 1.0 if c.kind == "gain" else 0.0
        prior_sd[p_x + j] = opt.gain_prior if c.kind == "gain" else opt.offset_prior
    # fixed (known) parameters: gains, and offsets as β = g·o
    fixed = np.zeros(p, dtype=bool)
    for (owner, foot), vals in known.gains.items():
        key = ("gain", owner, foot)
        if key not in index:
            raise OptionError("known", f"no gains of sensor set '{owner}', foot '{foot}'")
        fixed[index[key]] = True
        theta0[index[key]] = np.asarray(vals, dtype=float)
    sens_of = {s.name: s.sensors for s in sessions}
    for (owner, foot), vals in known.offsets.items():
        key = ("offset", owner, foot)
        gkey = ("gain", sens_of.get(owner, ""), foot)
        if key not in index or gkey not in index or not fixed[index[gkey]].all():
            raise OptionError("known", f"offsets of {owner}/{foot} need that foot's gains known")
        fixed[index[key]] = True
        theta0[index[key]] = np.asarray(vals, dtype=float) * theta0[index[gkey]]
    return Problem(rows, cols, p_x, theta0, prior_sd, fixed, sens_of, opt.rtol)


@dataclass(frozen=True)
class _Solution:
    """The last iteration: whitening, posterior, residuals, noise levels."""

    sw: np.ndarray  #: (rows,) 1/σ of each row
    aw: np.ndarray  #: whitened free columns
    zw: np.ndarray  #: whitened residual at the prior mean
    minv: np.ndarray  #: posterior covariance of the free parameters
    delta: np.ndarray  #: free parameters − prior mean
    resid: np.ndarray  #: (rows,) residuals
    lev: np.ndarray  #: (rows,) leverages
    var_f: np.ndarray  #: (sessions,) force-row variances, N²
    var_c: np.ndarray  #: (sessions,) moment-row variances, m²
    tau: float
    iterations: int
    converged: bool


def _evidence_tau(aw, zw, n_x: int, sens_prec) -> float:
    """τ maximising the evidence (grid over ``TAU_RANGE``, then a bounded 1-D search)."""
    import scipy.optimize

    def neg(lt: float) -> float:
        prec = np.concatenate([np.full(n_x, math.exp(-2 * lt)), sens_prec])
        val = -_log_evidence(aw, zw, prec)
        return val if math.isfinite(val) else 1e300

    grid = np.linspace(math.log(TAU_RANGE[0]), math.log(TAU_RANGE[1]), 13)
    evid = [neg(t) for t in grid]
    kk = int(np.argmin(evid))
    res = scipy.optimize.minimize_scalar(
        neg, bounds=(grid[max(kk - 1, 0)], grid[min(kk + 1, 12)]), method="bounded"
    )
    return math.exp(float(res.x) if res.fun <= evid[kk] else float(grid[kk]))


def _iterate(pb: Problem, sessions: list[PadSession], opt: CalibrationOptions) -> _Solution:
    """Alternate the posterior, τ (unless given) and the per-session noise levels."""
    rows, free = pb.rows, ~pb.fixed
    z_all = rows.y - rows.a @ pb.theta0  # residual at the prior mean (fixed parts exact)
    a_free = rows.a[:, free]
    var_f = np.array([START_NOISE_FORCE**2 if s.noise_force is None else s.noise_force**2
                      for s in sessions])  # fmt: skip
    var_c = np.array([START_NOISE_COP**2 if s.noise_cop is None else s.noise_cop**2
                      for s in sessions])  # fmt: skip
    n_x = int(free[: pb.p_x].sum())
    sens_prec = 1.0 / pb.prior_sd[pb.p_x :][free[pb.p_x :]] ** 2
    tau = opt.prior_scale if opt.prior_scale is not None else 1e-3
    converged, iterations = False, 0
    for iterations in range(1, opt.max_iter + 1):  # noqa: B007 (the count is returned)
        sw = 1.0 / np.sqrt(np.where(rows.moment, var_c[rows.session], var_f[rows.session]))
        aw, zw = a_free * sw[:, None], z_all * sw
        if opt.prior_scale is None:
            tau = _evidence_tau(aw, zw, n_x, sens_prec)
        prec = np.concatenate([np.full(n_x, tau**-2), sens_prec])
        minv = spd_inverse(aw.T @ aw + np.diag(prec))
        delta = minv @ (aw.T @ zw)
        resid = z_all - a_free @ delta
        lev = np.einsum("ij,jk,ik->i", aw, minv, aw)
        new_f, new_c = _noise_levels(rows, sessions, resid, lev, (var_f, var_c))
        change = max(np.max(np.abs(np.log(new_f / var_f))), np.max(np.abs(np.log(new_c / var_c))))
        var_f, var_c = new_f, new_c
        if change < opt.tol:
            converged = True
            break
    return _Solution(sw, aw, zw, minv, delta, resid, lev, var_f, var_c, tau, iterations, converged)


def _noise_levels(rows: Rows, sessions, resid, lev, old) -> tuple[np.ndarray, np.ndarray]:
    """Per session σ² = RSS / (rows − leverage) of its force and moment rows (or as given)."""
    new_f, new_c = old[0].copy(), old[1].copy()
    for si, s in enumerate(sessions):
        for is_m, given, new in ((False, s.noise_force, new_f), (True, s.noise_cop, new_c)):
            sel = (rows.session == si) & (rows.moment == is_m)
            if given is not None or not sel.any():
                continue
            dof = max(sel.sum() - lev[sel].sum(), 1.0)
            floor = NOISE_FLOOR_COP if is_m else NOISE_FLOOR_FORCE
            new[si] = max(float(resid[sel] @ resid[sel]) / dof, floor**2)
    return new_f, new_c


def _mass_fit(robot: Robot, pb: Problem, sol: _Solution, theta: np.ndarray, tau_given: bool) -> Fit:
    """A MAP ``Fit`` of vec(r) from the whitened rows with the free sensor columns marginalised."""
    free, p_x = ~pb.fixed, pb.p_x
    nx = int(free[:p_x].sum())
    if nx != p_x:
        raise OptionError("known", "the SESC vectors cannot be held fixed here")
    aw, zw = sol.aw, sol.zw
    ax, as_ = aw[:, :nx], aw[:, nx:]
    if as_.shape[1]:
        sens_prec = 1.0 / pb.prior_sd[p_x:][free[p_x:]] ** 2
        minv = spd_inverse(as_.T @ as_ + np.diag(sens_prec))
        cross = ax.T @ as_
        bs = as_.T @ zw
        ata = ax.T @ ax - cross @ minv @ cross.T
        b = ax.T @ zw - cross @ (minv @ bs)
        ztz = float(zw @ zw - bs @ minv @ bs)
    else:
        ata, b, ztz = ax.T @ ax, ax.T @ zw, float(zw @ zw)
    ata = 0.5 * (ata + ata.T)
    x0 = pb.theta0[:p_x]
    atb = b + ata @ x0
    yty = ztz + 2 * x0 @ atb - x0 @ ata @ x0
    ne = NormalEquations(ata, atb, float(yty), int(aw.shape[0]), pb.rows.n_poses)
    fit = fit_map(
        robot,
        cop_system(robot, ne, weighted=True),
        MapOptions(prior_scale=sol.tau, noise=1.0),
        rtol=pb.rtol,
    )
    cop_rows = pb.rows.moment
    info = fit.map
    if info is not None:
        info = dataclasses.replace(
            info,
            prior_scale_by="given" if tau_given else "evidence",
            noise_by="per-session estimate",
        )
    cov = np.zeros((p_x, p_x))  # the x block of the joint posterior (sensors marginalised)
    cov[np.ix_(free[:p_x], free[:p_x])] = sol.minv[:nx, :nx]
    return dataclasses.replace(
        fit,
        r=theta[:p_x].reshape(-1, 3),
        cov=cov,
        rms=float(np.sqrt(np.mean(sol.resid[cop_rows] ** 2))),
        mae=float(np.mean(np.abs(sol.resid[cop_rows]))),
        map=info,
    )


def _contributions(pb: Problem, sessions, sol: _Solution) -> list[SessionContribution]:
    """What each session brought: poses, noise levels, share of the leverage, residuals."""
    rows, out = pb.rows, []
    total_lev = float(sol.lev.sum()) or 1.0
    for si, s in enumerate(sessions):
        sel = rows.session == si
        fr, mr = sel & ~rows.moment, sel & rows.moment
        given = s.noise_force is not None and s.noise_cop is not None
        out.append(
            SessionContribution(
                name=s.name,
                sensors=s.sensors,
                poses=rows.used[si],
                loaded_feet=[f.name for f in s.feet if f.loaded.any()],
                double_support_poses=rows.double[si],
                noise_force=math.sqrt(sol.var_f[si]),
                noise_cop=math.sqrt(sol.var_c[si]),
                noise_by="given" if given else "estimated",
                share=float(sol.lev[sel].sum()) / total_lev,
                rms_force=_rms(sol.resid[fr]),
                rms_cop=_rms(sol.resid[mr]),
            )
        )
    return out


def _rms(v: np.ndarray) -> float:
    return float(np.sqrt(np.mean(v**2))) if v.size else math.nan


def calibrate_sensors(
    robot: Robot,
    sessions: list[PadSession],
    options: CalibrationOptions | None = None,
    known: KnownSensors | None = None,
    **overrides,
) -> SensorCalibration:
    """Estimate the SESC vectors with every pad's gain and each session's offsets (package doc).

    ``options``: priors, the weighed mass and the iteration (``CalibrationOptions``; keyword
    ``overrides`` set single fields, e.g. ``total_mass=3.2``). ``known``: sensor values held
    fixed (e.g. a perfectly calibrated bench).
    """
    opt = dataclasses.replace(options or CalibrationOptions(), **overrides)
    opt.check()
    if opt.total_mass is not None:
        check_total_mass(robot, opt.total_mass)
    check_sessions(robot, sessions)
    mass = robot.total_mass if opt.total_mass is None else float(opt.total_mass)
    cols = sensor_columns(sessions)
    rows, index = build_rows(robot, sessions, cols, mass * G0)
    if rows.n_poses == 0:
        raise DataError("no pose of any session has a loaded foot")
    pb = _problem(robot, sessions, rows, cols, index, opt, known or KnownSensors())
    sol = _iterate(pb, sessions, opt)
    free, p = ~pb.fixed, rows.a.shape[1]
    theta = pb.theta0.copy()
    theta[free] += sol.delta
    cov = np.zeros((p, p))
    cov[np.ix_(free, free)] = sol.minv
    fit = _mass_fit(robot, pb, sol, theta, opt.prior_scale is not None)
    params = parameters(pb, theta, cov, sol.sw)
    unseen = unseen_directions(robot, sessions, pb, sol.sw)
    if opt.total_mass is None:
        unseen.append(
            SensorDirection(
                [(q.label, 1.0) for q in params if q.kind == "gain" and not q.known],
                SCALE,
                f"no weighed mass: the gains' common scale rests on the model's mass "
                f"{mass:.4f} kg (weigh the robot and give it)",
            )
        )
    return SensorCalibration(
        fit=fit,
        gains=[q for q in params if q.kind == "gain"],
        offsets=[q for q in params if q.kind == "offset"],
        sessions=_contributions(pb, sessions, sol),
        unidentifiable=unseen,
        total_mass=mass,
        total_mass_by="model" if opt.total_mass is None else "given",
        prior_scale=sol.tau,
        prior_scale_by="given" if opt.prior_scale is not None else "evidence",
        gain_prior=opt.gain_prior,
        offset_prior=opt.offset_prior,
        iterations=sol.iterations,
        converged=sol.converged,
    )
