"""Least-squares fits: a ``Fit`` from the pooled system's solution, and its residuals.

``fit_from_solution`` turns a ``solve.Solution`` over θ = [vec(r); nuisance] into a Fit: the SESC
part r with its covariance (nuisance marginalised: the x-block of the pseudo-inverse), the
identifiable subspace of r (the range of the Schur complement A_xx − A_xn A_nn⁺ A_nx, equal to
A's own when there is no nuisance), its named base combinations and the named directions no data
of these kinds could see; the nuisance parameters (sensor offsets, friction bands) with their
standard errors, or "not determined" with the reason; one ``KindFit`` per measurement kind.
``with_residuals`` adds each kind's residual MAE and RMS (and the error against a simulation's
noise-free CoP) from one more pass over the data (``residual_sums``: the MAE needs each row's
residual at the final estimate).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable

import numpy as np

from sescid.errors import DataError
from sescid.estimation.data.measurements import Measurements
from sescid.estimation.result.fit import Combination, Fit, Method
from sescid.estimation.result.identifiability import (
    DEFAULT_RTOL,
    NOT_EXCITED,
    base_combinations,
    label_columns,
    sparse_terms,
    structural_count,
    unidentifiable,
)
from sescid.estimation.result.records import KindFit, NuisanceEstimate
from sescid.estimation.solvers.solve import UNITS, Solution, marginal_x, solve_system
from sescid.estimation.sums.normal_equations import NormalEquations
from sescid.estimation.sums.pooled import body_fit, prior_x, stance_map, view, x_labels
from sescid.estimation.sums.residual_sums import residual_sums
from sescid.estimation.sums.system import KindSums, System, pinned_system
from sescid.kinds import BALANCE, COP, TORQUE, Kind
from sescid.robot import Robot

#: a nuisance direction is determined when this much of it lies in the identifiable subspace
DETERMINED = 1 - 1e-6


def prior_theta(robot: Robot, system: System, r_prior: np.ndarray | None) -> np.ndarray:
    """θ0 = [vec(r_prior); 0]: the model's SESC vectors (or ``r_prior``), no sensor errors; for
    a pooled system (``pooled``) the model's body parameters x."""
    if system.space == "bodies":
        if r_prior is not None:
            raise DataError("r_prior is one stance's: a pooled fit's prior is the model file's")
        return np.concatenate([prior_x(robot), np.zeros(len(system.nuisance))])
    r0 = robot.sesc_vectors() if r_prior is None else np.asarray(r_prior, dtype=float)
    return np.concatenate([r0.reshape(-1), np.zeros(len(system.nuisance))])


def reference_view(robot: Robot, system: System, sol: Solution, rtol: float):
    """(system, solution) over [vec(r); nuisance] of the robot's support: a pooled system's
    x-space solution seen through r = L_ref x (``pooled.view``); a one-stance system as it is."""
    if system.space != "bodies":
        return system, sol
    lmap = stance_map(robot, robot.support)
    return dataclasses.replace(system, n_x=lmap.shape[0]), view(sol, lmap, system.n_x, rtol)


def nuisance_estimates(system: System, sol: Solution) -> tuple[NuisanceEstimate, ...]:
    """Each nuisance parameter's value and standard error, or nan with the reason."""
    out = []
    n_x, basis = system.n_x, sol.basis
    for j, par in enumerate(system.nuisance):
        col = n_x + j
        seen = float(np.linalg.norm(basis[col])) if basis.size else 0.0
        determined = seen**2 > DETERMINED
        reason = ""
        if not determined:
            reason = _confounded(system, sol, col)
        std = math.sqrt(max(sol.cov[col, col], 0.0)) if determined else math.nan
        out.append(
            NuisanceEstimate(
                kind=par.kind,
                what=par.what,
                name=par.name,
                unit=par.unit,
                value=float(sol.theta[col]) if determined else math.nan,
                std=std,
                determined=determined,
                reason=reason,
            )
        )
    return tuple(out)


def _confounded(system: System, sol: Solution, col: int) -> str:
    """Why a nuisance column is not determined: the other parameters it trades with."""
    null = sol.vecs[:, sol.rank :]
    if null.size == 0:
        return "not excited by these data"
    v = null @ (null.T[:, col])  # the null-space direction closest to this column
    v /= np.linalg.norm(v) or 1.0
    labels = [f"r[{b}].{a}" for b, a in _xlabels(system)] + system.labels()
    big = [labels[i] for i in np.argsort(-np.abs(v)) if abs(v[i]) > 0.1 * abs(v[col])]
    others = [name for name in big if name != labels[col]][:4]
    if not others:
        return "not excited by these data"
    return "confounded with " + ", ".join(others) + " (the data cannot tell them apart)"


def _xlabels(system: System):
    n = system.n_x // 3
    return [(f"body{i}", a) for i in range(n) for a in "xyz"]


def fit_from_solution(
    robot: Robot,
    system: System,
    sol: Solution,
    *,
    rtol: float = DEFAULT_RTOL,
    method: Method = "ls",
) -> Fit:
    """The Fit of a least-squares solution (module docstring); residual MAE/RMS are nan until
    ``with_residuals``."""
    n_x = system.n_x
    lam, vecs, p = marginal_x(sol, n_x, rtol)
    sv = np.sqrt(np.clip(lam, 0, None))
    labels = label_columns(robot)
    r = sol.theta[:n_x].reshape(-1, 3)
    cov = sol.cov[:n_x, :n_x]
    kinds = tuple(
        KindFit(
            kind=k,
            n_rows=system.parts[k].ne.n_rows,
            n_poses=system.parts[k].ne.n_poses,
            sigma=sol.noise[k],
            sigma_by=sol.noise_by[k],
            dof=float(sol.dof[k]),
            rms=_rms_from_sums(system.parts[k], sol),
            mae=math.nan,
            weighted=system.parts[k].weighted,
            unit=UNITS[k],
        )
        for k in system.kinds
    )
    single = len(kinds) == 1
    return Fit(
        robot=robot,
        r=r,
        r_prior=sol.theta0[:n_x].reshape(-1, 3).copy(),
        cov=cov,
        basis=vecs[:, :p],
        singular_values=sv,
        rank=p,
        n_poses=system.n_poses,
        n_rows=sol.n_rows,
        sigma_hat=sol.scale,
        rms=kinds[0].rms if single else math.nan,
        mae=math.nan,
        rtol=rtol,
        method=method,
        base=tuple(base_combinations(sv, vecs, p, labels, r, cov)),
        unidentifiable=tuple(unidentifiable(robot, vecs[:, :p], labels, system.kinds)),
        weighted=(kinds[0].weighted if single else True),
        sigma_dof=_sigma_dof(kinds, sol),
        kinds=kinds,
        nuisance=nuisance_estimates(system, sol),
        total_mass=(system.total_mass if TORQUE in system.kinds or system.mass_given else math.nan),
        mass_given=system.mass_given,
        gravity_accel=system.gravity_accel,
    )


def _sigma_dof(kinds: tuple[KindFit, ...], sol: Solution) -> float | None:
    """Degrees of freedom of σ̂: None (n − p) for one kind's estimated noise, inf for a given
    one; several kinds (noises estimated together): n − p, which sets the intervals' t."""
    if len(kinds) == 1:
        return math.inf if kinds[0].sigma_by == "given" else None
    return float(sol.n_rows - sol.rank)


def _rms_from_sums(part: KindSums, sol: Solution) -> float:
    """RMS residual per row from the kind's sums (exact); nan for weighted rows (their RMS in
    physical units needs the data)."""
    if part.weighted or part.ne.n_rows == 0:
        return math.nan
    return math.sqrt(sol.rss[part.kind] / part.ne.n_rows)


#: a direction whose information is below this share of the largest is barely excited: least
#: squares takes it from the prior (a condition of 10⁷, a singular value 3000× below the largest)
WEAK_SHARE = 1e-7


def weak_directions(sol: Solution, system: System, rtol: float) -> np.ndarray:
    """(n_x, k) the directions of vec(r) the data see but barely excite: their information
    (nuisance marginalised) is below ``WEAK_SHARE`` of the largest, and so is every kind's own
    (each against its own largest: a direction only one precise kind sees is not weak)."""
    n_x = system.n_x
    lam, vecs, p = marginal_x(sol, n_x, rtol)
    if p == 0:
        return np.zeros((n_x, 0))
    cand = [i for i in range(p) if lam[i] < WEAK_SHARE * lam[0]]
    if not cand:
        return np.zeros((n_x, 0))
    v = vecs[:, cand]
    seen = np.zeros(len(cand), dtype=bool)
    for part in system.parts.values():
        a = part.ne.ata[:n_x, :n_x]
        top = float(np.linalg.eigvalsh((a + a.T) / 2)[-1])
        seen |= np.einsum("pi,pq,qi->i", v, a, v) >= WEAK_SHARE * top
    return v[:, ~seen]


def named(robot: Robot, directions: np.ndarray, reason: str) -> tuple[Combination, ...]:
    """The directions (3N, k) of vec(r) as named combinations with a reason."""
    labels = label_columns(robot)
    return tuple(
        Combination(sparse_terms(directions[:, i], labels, tol=1e-3), reason=reason,
                    kind=NOT_EXCITED)
        for i in range(directions.shape[1])
    )  # fmt: skip


WEAK_REASON = (
    "barely excited by these poses (its information is below 10⁻⁷ of the largest): taken "
    "from the prior model"
)


def fit_least_squares(
    robot: Robot,
    system: System,
    *,
    rtol: float = DEFAULT_RTOL,
    r_prior: np.ndarray | None = None,
    noise: dict[Kind, float] | None = None,
    allow_exact: bool = False,
) -> Fit:
    """Least-squares Fit of a pooled system (``solve.solve_system``, ``fit_from_solution``).
    Directions the data barely excite (``weak_directions``) are taken from the prior, not
    from noise: the system is solved again with them pinned (``system.pinned``), and the fit
    names them (``Fit.weak``)."""
    theta0 = prior_theta(robot, system, r_prior)
    count = structural_count(robot, system.kinds) + len(system.nuisance)
    sol = solve_system(
        system, theta0, rtol=rtol, noise=noise, allow_exact=allow_exact, structural=count
    )
    weak = weak_directions(sol, system, rtol)
    if weak.shape[1]:
        lifted = np.zeros((system.size, weak.shape[1]))
        lifted[: system.n_x] = weak
        sol = solve_system(
            pinned_system(system, lifted, theta0), theta0, rtol=rtol, noise=noise,
            allow_exact=allow_exact, structural=count,
        )  # fmt: skip
    view_system, view_sol = reference_view(robot, system, sol, rtol)
    fit = fit_from_solution(robot, view_system, view_sol, rtol=rtol)
    if system.space == "bodies":
        n_x = system.n_x
        bodies = body_fit(robot, system, sol, sol.theta[:n_x], sol.cov[:n_x, :n_x], rtol)
        fit = dataclasses.replace(fit, bodies=bodies, nuisance=nuisance_estimates(system, sol))
        if weak.shape[1]:  # named by their body parameters
            labels = x_labels(robot)
            fit = dataclasses.replace(fit, weak=tuple(
                Combination([(lab, "", c) for lab, _, c in sparse_terms(
                    weak[:, i], [(x, "") for x in labels], tol=1e-3)], reason=WEAK_REASON,
                    kind=NOT_EXCITED)
                for i in range(weak.shape[1])
            ))  # fmt: skip
        return fit
    if weak.shape[1]:
        fit = dataclasses.replace(fit, weak=named(robot, weak, WEAK_REASON))
    return fit


def cop_system(robot: Robot, ne: NormalEquations, weighted: bool = False) -> System:
    """A one-kind system from CoP normal equations over vec(r) (3N)."""
    return System(
        3 * len(robot.body_names), (), {COP: KindSums(COP, ne, weighted)}, robot.total_mass,
        False, ne.n_poses,
    )  # fmt: skip


def residuals(fit: Fit, m: Measurements) -> dict[str, np.ndarray]:
    """Residuals per kind at validated data m: "cop" (n, 2) m net of a CoP offset, "tau"
    (n, J) N·m net of the sensor offsets and friction bands, "balance" (n,) rad; data of
    another stance with the fit seen there (``pooled.for_support``)."""
    if m.support is not None:  # the fit seen in their stance
        from sescid.estimation.sums.pooled import for_support

        fit = for_support(fit, m.stance_on(fit.robot).label)
    out: dict[str, np.ndarray] = {}
    if m.balance is not None and m.gravity is not None:
        from sescid.estimation.data.balance_rows import balance_residuals

        out[BALANCE] = balance_residuals(fit.robot, fit.r, m.q, m.balance, m.gravity)
    if m.cop is not None:
        out[COP] = m.cop - fit.predict_cop(m.q, m.gravity) - fit.cop_bias
    if m.tau is not None and m.tau_joints:
        gain = fit.torque_nuisance("gain", m.tau_joints)
        out[TORQUE] = m.tau - torque_readings(fit, m) * (1.0 + gain)
    return out


def torque_readings(fit: Fit, m: Measurements) -> np.ndarray:
    """p(θ) = τ(r) + offset + side·friction (n, J) N·m: the predicted readings without gains."""
    joints = m.tau_joints
    p = fit.predict_torque(m.q, joints, m.gravity) + fit.torque_nuisance("offset", joints)
    if m.approach is not None:
        p = p + m.approach[:, None] * fit.torque_nuisance("friction", joints)
    return p


def with_residuals(
    fit: Fit,
    data: Iterable[Measurements] = (),
    *,
    sources: Iterable[Iterable[Measurements]] | None = None,
) -> Fit:
    """The fit with each kind's residual MAE and RMS (per row, in the kind's unit) and, for
    simulated data with a noise-free CoP, the RMS error against it: one pass over ``data``
    (chunks of one data set) or ``sources`` (each data set's chunks), ``residual_sums``."""
    sums = residual_sums(fit, [data] if sources is None else sources)
    abs_sum, sq_sum, count = sums.abs_sum, sums.sq_sum, sums.count
    truth_sq, truth_n = sums.truth_sq, sums.truth_n
    kinds = tuple(
        dataclasses.replace(
            kf,
            mae=abs_sum[kf.kind] / count[kf.kind] if count.get(kf.kind) else math.nan,
            rms=math.sqrt(sq_sum[kf.kind] / count[kf.kind]) if count.get(kf.kind) else math.nan,
        )
        for kf in fit.kinds
    )
    single = kinds[0] if len(kinds) == 1 else None
    return dataclasses.replace(
        fit,
        kinds=kinds,
        mae=single.mae if single else math.nan,
        rms=single.rms if single else math.nan,
        truth_cop_rmse=math.sqrt(truth_sq / truth_n) if truth_n else fit.truth_cop_rmse,
    )


def refit_nuisance(fit: Fit, system: System) -> Fit:
    """The nuisance parameters re-estimated for the fit's r (least squares given vec(r)): after
    the consistent step moves r along directions its offsets traded with, the offsets follow.
    Kinds are weighed by the fit's noise; what stays undetermined keeps its record."""
    if not system.nuisance:
        return fit
    from sescid.estimation.solvers.solve import weighted_sums

    noise: dict[Kind, float] = {k.kind: (k.sigma if math.isfinite(k.sigma) and k.sigma > 0
                                        else 1.0) for k in fit.kinds}  # fmt: skip
    if len(system.kinds) == 1:
        noise = {system.kinds[0]: 1.0}
    ne = weighted_sums(system, noise)
    n_x = system.n_x
    x = fit.bodies.x if system.space == "bodies" else fit.r.reshape(-1)
    a_nn = ne.ata[n_x:, n_x:]
    b_n = ne.atb[n_x:] - ne.ata[n_x:, :n_x] @ x
    values = np.linalg.pinv(a_nn, rcond=1e-10, hermitian=True) @ b_n
    out = tuple(
        dataclasses.replace(e, value=float(v)) if e.determined else e
        for e, v in zip(fit.nuisance, values, strict=True)
    )
    return dataclasses.replace(fit, nuisance=out)
