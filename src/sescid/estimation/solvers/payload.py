"""A payload on a calibrated robot: its mass and CoM on one body, from a handful of poses.

The robot's own body parameters θ_b (4N: masses and first moments, kg and kg·m, each body's
frame; ``Robot.body_parameters``) are the base — a previous fit, or the model file — and are
kept. A payload of mass m on the link BODY with its CoM at c (BODY's frame) adds

    θ = θ_b + D p,      p = (m, h),  h = m c  [kg, kg·m]

(D puts m on BODY's mass and R h + m t on its first moment, (R, t) the link's place in its
body), and the total mass becomes M = M_b + m. Every kind is then a function of p alone:

- CoM (any stance s, K_s = ``Robot.sesc_matrix``): ``CoM = d + Φ(q) K_s θ / M = d + (A + B p)
  / (M_b + m)`` with A = Φ K_s θ_b, B = Φ K_s D; the CoP is its projection along gravity and a
  balance row its offset across the line — rational in m, linear in (m, h) after multiplying
  through by M (``M (y − d) = A + B p``), fitted exactly here by Gauss–Newton;
- joint torques ``τ = Φ_τ K_s θ`` (``sesc`` module docstring: M·r is K θ): linear in p, plus
  each measured joint's offset (and friction band with an approach side) as nuisance columns.

Each kind is weighed by its own noise (given, or estimated from its residuals with its share of
the degrees of freedom, by the rows' leverages); a base fit's own covariance enters the rows of
its support as a correlated error (``_whitener``); a model file is taken as exact. What the
poses leave undetermined (a payload on a body the poses never turn shows only its mass and
horizontal moment) is reported as nan with its reason and how many more poses would determine
it. ``payload_fit`` returns a ``Fit`` of the robot with its payload (``Fit.payload`` the
record), so that every prediction includes it.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from sescid.base import G0
from sescid.errors import DataError, ModelError, OptionError
from sescid.estimation.data.measurements import Measurements
from sescid.estimation.result.fit import Fit
from sescid.estimation.result.identifiability import DEFAULT_RTOL, basis_of
from sescid.estimation.result.payload_record import PayloadFit, PayloadKind
from sescid.estimation.result.records import KindFit, NuisanceEstimate
from sescid.estimation.solvers.payload_rows import (
    PayloadRows,
    base_parameters,
    payload_map,
    predict_rows,
    rows_of,
)
from sescid.estimation.solvers.solve import UNITS
from sescid.estimation.sums.pooled import PARAM_UNIT
from sescid.kinds import BALANCE, COP, TORQUE
from sescid.robot import Robot

#: noise levels the first Gauss–Newton pass weighs the kinds by (m, N·m, rad)
START_SIGMA: dict[str, float] = {COP: 1e-3, TORQUE: 1e-2, BALANCE: 1e-2}
#: most rows whose base-fit errors are propagated (a dense R × R covariance)
BASE_ROWS = 3000
#: names of p's components as reported
COMPONENTS = ("mass", "com_x", "com_y", "com_z")


@dataclass(frozen=True)
class PayloadOptions:
    """How a payload is identified: the link it is fixed to, its weighed mass [kg] (None:
    identified), known noise levels (None: estimated), |g| [m/s²] and the rank tolerance."""

    body: str
    mass: float | None = None
    cop_noise: float | None = None
    tau_noise: float | None = None
    gravity_accel: float = G0
    rtol: float = DEFAULT_RTOL


def check_payload(robot: Robot, body: str, mass: float | None) -> None:
    """ModelError for a body that is not a link of the model; OptionError for a weighed mass
    that is not a finite positive number of kg."""
    if body not in robot.model.link_frames:
        links = sorted(robot.model.link_frames)
        shown = ", ".join(links[:12]) + (f" … ({len(links)} links)" if len(links) > 12 else "")
        raise ModelError(
            f"{robot.model_path.name}: no link named '{body}' to carry the payload ({shown})"
        )
    if mass is not None and not (math.isfinite(mass) and mass > 0):
        raise OptionError("payload_mass", f"must be a finite mass > 0 kg, got {mass}")


def check_base(robot: Robot, fit: Fit, where: str) -> None:
    """DataError when the base fit was made for another robot (model file, bodies, joints)."""
    other = fit.robot
    if (
        other.source != robot.source
        or other.joint_names != robot.joint_names
        or sorted(other.body_names) != sorted(robot.body_names)
    ):
        raise DataError(
            f"{where}: the base fit is of the robot '{other.name}' ({other.source}), not of "
            f"'{robot.name}' ({robot.source}): give the fit of this robot, or its model file"
        )


def _solve(rows: PayloadRows, base_mass: float, opts: PayloadOptions):
    """Gauss–Newton with each kind weighed by its noise: p (4,), ν, the weighted Jacobian of the
    free parameters at the solution, the noise per kind and the residuals."""
    free = [0, 1, 2, 3] if opts.mass is None else [1, 2, 3]
    k = len(rows.nuisance)
    given: dict[str, float | None] = {COP: opts.cop_noise, TORQUE: opts.tau_noise, BALANCE: None}
    sigma = np.array([given[kd] or START_SIGMA[kd] for kd in rows.kinds])
    p = np.zeros(4)
    p[0] = 0.0 if opts.mass is None else opts.mass
    nu = np.zeros(k)
    # column scales: kg, kg·ℓ, N·m (rank decisions in comparable units)
    scale = np.concatenate([np.array([1.0, PARAM_UNIT, PARAM_UNIT, PARAM_UNIT])[free], np.ones(k)])
    for _outer in range(6):
        white, extra = _whitener(rows, sigma, p, base_mass)
        for _it in range(60):
            pred, jac = predict_rows(rows, p, nu, base_mass)
            e = white(rows.y - pred)
            jz = white(np.hstack([jac[:, free], rows.nuis])) * scale[None, :]
            step = np.linalg.lstsq(jz, e, rcond=opts.rtol)[0] * scale
            cost = float(e @ e)
            t = 1.0
            for _half in range(30):
                p_new, nu_new = p.copy(), nu + t * step[len(free) :]
                p_new[free] += t * step[: len(free)]
                if base_mass + p_new[0] > 0:
                    e_new = white(rows.y - predict_rows(rows, p_new, nu_new, base_mass)[0])
                    if float(e_new @ e_new) <= cost * (1 + 1e-12):
                        break
                t /= 2
            p, nu = p_new, nu_new
            if np.all(np.abs(t * step[: len(free)]) <= 1e-12 * (1 + np.abs(p[free]))):
                break
        pred, jac = predict_rows(rows, p, nu, base_mass)
        jz = white(np.hstack([jac[:, free], rows.nuis]))
        res = rows.y - pred
        info = jz.T @ jz
        lev = np.einsum("ri,ij,rj->r", jz, np.linalg.pinv(info, rcond=opts.rtol, hermitian=True),
                        jz)  # fmt: skip
        new = sigma.copy()
        dof = np.zeros(len(rows.kinds))
        for i, kd in enumerate(rows.kinds):
            at = rows.kind == i
            dof[i] = at.sum() - lev[at].sum()
            if given[kd] is None and dof[i] > 0.5:  # the base's share of the residuals taken out
                var = float(res[at] @ res[at]) / dof[i] - float(np.mean(extra[at]))
                new[i] = max(math.sqrt(max(var, 0.0)), 1e-12 * START_SIGMA[kd])
        if np.allclose(new, sigma, rtol=1e-6):
            break
        sigma = new
    white, _ = _whitener(rows, sigma, p, base_mass)
    jz = white(np.hstack([predict_rows(rows, p, nu, base_mass)[1][:, free], rows.nuis]))
    free_sigma = np.array([given[kd] is None and dof[i] <= 0.5 for i, kd in enumerate(rows.kinds)])
    return p, nu, jz, sigma, dof, res, free, free_sigma


def _whitener(rows: PayloadRows, sigma: np.ndarray, p: np.ndarray, base_mass: float):
    """The whitening v ↦ L⁻¹ v for the rows' error covariance σ_kind² I (+ the base fit's
    J_b C_b J_bᵀ), and that base share of each row's variance (zeros without it)."""
    s = sigma[rows.kind]
    if rows.jb is None or rows.cb is None:
        return (lambda v: v / (s[:, None] if v.ndim == 2 else s)), np.zeros(s.size)
    from scipy.linalg import cholesky, solve_triangular

    g = rows.jb * np.where(rows.k > 0, base_mass / (base_mass + p[0]), base_mass)[:, None]
    gc = g @ rows.cb
    extra = np.einsum("ij,ij->i", gc, g)
    cov = gc @ g.T
    cov[np.diag_indices_from(cov)] += s**2
    low = cholesky(cov, lower=True)
    return (lambda v: solve_triangular(low, v, lower=True)), extra


def _marginal(jz: np.ndarray, n_free: int, rtol: float):
    """Information of the payload's free parameters with the nuisance marginalised (Schur
    complement), in scaled units; its eigenvalues (descending) and vectors."""
    info = jz.T @ jz
    a = info[:n_free, :n_free]
    if info.shape[0] > n_free:
        b, c = info[:n_free, n_free:], info[n_free:, n_free:]
        a = a - b @ np.linalg.pinv(c, rcond=rtol, hermitian=True) @ b.T
    return (a + a.T) / 2


def solve_payload(robot: Robot, data: list[Measurements], opts: PayloadOptions,
                  base: Fit | None = None):  # fmt: skip
    """The payload of validated data on ``robot`` (a base fit's robot, or the model's):
    (PayloadFit, p (4,) with unseen components at their minimum-norm value, cov of p (4, 4),
    θ_b, the reference robot, the nuisance estimates, the rows' residuals per kind)."""
    ref = robot if base is None else base.robot
    check_payload(ref, opts.body, opts.mass)
    theta, label = base_parameters(base, robot)
    n = len(ref.body_names)
    base_mass = float(theta[:n].sum())
    # the base fit's own uncertainty, for rows of its support (dense: up to BASE_ROWS rows)
    same = base is not None and np.all(np.isfinite(base.cov)) and np.any(base.cov != 0)
    n_rows = sum(d.rows() for d in data)
    support = base.robot.support if base is not None and same and n_rows <= BASE_ROWS else None
    rows = rows_of(robot, ref, theta, data, opts.gravity_accel, opts.body, support)
    if support is not None:
        assert base is not None
        rows.cb = base.cov
    p, nu, jz, sigma, dof, res, free, free_sigma = _solve(rows, base_mass, opts)
    nf = len(free)
    sc = np.array([1.0, PARAM_UNIT, PARAM_UNIT, PARAM_UNIT])[free]
    info = _marginal(jz * np.concatenate([sc, np.ones(jz.shape[1] - nf)])[None, :], nf, opts.rtol)
    lam, vec = np.linalg.eigh(info)
    lam, vec = lam[::-1], vec[:, ::-1]
    top = max(float(lam[0]), 0.0) if lam.size else 0.0
    seen = np.sqrt(np.clip(lam, 0, None)) > opts.rtol * math.sqrt(top) if top > 0 else lam < -1
    rank = int(seen.sum())
    cov_scaled = (vec[:, seen] / lam[seen]) @ vec[:, seen].T
    cov_free = cov_scaled * sc[:, None] * sc[None, :]
    if np.any(free_sigma):  # a kind's noise not determined (no residual left): unknown errors
        cov_free = np.full_like(cov_free, np.nan)
    cov_p = np.zeros((4, 4))
    cov_p[np.ix_(free, free)] = cov_free
    unseen_dirs = vec[:, ~seen]
    lost_free = (
        np.linalg.norm(unseen_dirs, axis=1) > 1e-6 if unseen_dirs.size else np.zeros(nf, bool)
    )
    lost = np.zeros(4, dtype=bool)
    lost[free] = lost_free
    # (mass, com): c = h/m; com lost where its h is, or everything when the mass is
    m = float(p[0])
    com = p[1:] / m if m != 0 else np.full(3, np.nan)
    jmc = np.zeros((4, 4))
    jmc[0, 0] = 1.0
    jmc[1:, 0] = -com / m if m != 0 else np.nan
    jmc[1:, 1:] = np.eye(3) / m if m != 0 else np.nan
    cov_mc = jmc @ cov_p @ jmc.T
    lost_mc = lost.copy()
    lost_mc[1:] |= lost[0]
    mass_out = math.nan if lost_mc[0] else m
    com_out = np.where(lost_mc[1:], np.nan, com)
    std = np.sqrt(np.clip(np.diag(cov_mc), 0, None))
    std[lost_mc] = np.nan
    if opts.mass is not None:
        std[0] = 0.0
    cov_mc[lost_mc, :] = np.nan
    cov_mc[:, lost_mc] = np.nan
    unseen = tuple(c for c, x in zip(COMPONENTS, lost_mc, strict=True) if x)
    reason, more = _unseen_reason(robot, opts.body, unseen, nf - rank, rows.rows_per_pose)
    kinds = tuple(
        PayloadKind(kd, int((rows.kind == i).sum()), float(sigma[i]),
                    "given" if (kd == COP and opts.cop_noise) or (kd == TORQUE and opts.tau_noise)
                    else ("not determined" if free_sigma[i] else "estimated"),
                    float(dof[i]),
                    float(np.sqrt(np.mean(res[rows.kind == i] ** 2))))
        for i, kd in enumerate(rows.kinds)
    )  # fmt: skip
    record = PayloadFit(
        body=opts.body, mass=mass_out if opts.mass is None else float(opts.mass), com=com_out,
        mass_std=float(std[0]), com_std=std[1:], cov=cov_mc, mass_given=opts.mass is not None,
        base=label, base_mass=base_mass, n_poses=sum(d.n for d in data), n_rows=int(rows.y.size),
        kinds=kinds, unseen=unseen, reason=reason, more_poses=more, stances=tuple(rows.stances),
    )  # fmt: skip
    nuis_cov = np.full(len(nu), np.nan)
    if jz.shape[1] > nf and not np.any(free_sigma):
        full = np.linalg.pinv(jz.T @ jz, rcond=opts.rtol, hermitian=True)
        nuis_cov = np.diag(full)[nf:]
    nuisance = tuple(
        NuisanceEstimate(TORQUE, what, joint, "N·m", float(nu[i]),  # type: ignore[arg-type]
                         float(math.sqrt(max(nuis_cov[i], 0))) if math.isfinite(nuis_cov[i])
                         else math.nan, True)
        for i, (what, joint) in enumerate(rows.nuisance)
    )  # fmt: skip
    return record, p, cov_p, lost, theta, ref, nuisance, kinds


def _unseen_reason(robot: Robot, body: str, unseen: tuple[str, ...], k: int, per_pose: int):
    """Why components are not determined, and how many more poses would determine them."""
    if not unseen:
        return "", 0
    b = robot.model.link_frames[body][0]
    names = ", ".join(unseen)
    if b == 0:
        return (
            f"not determined: {names} — {body} is the support body, it never turns in this "
            "stance (measure in another stance, e.g. the other foot, or on a tilted support)",
            None,
        )
    more = max(1, math.ceil(k / max(min(per_pose, 3), 1)))
    return (
        f"not determined: {names} — the poses do not turn {body} enough to see it (a payload "
        "on a body the poses never turn shows only its mass and horizontal moment); at least "
        f"{more} more pose"
        f"{'s' if more > 1 else ''} turning {body} to new orientations would determine it "
        f"(sescid poses --payload {body})",
        more,
    )


def payload_fit(robot: Robot, data: list[Measurements], opts: PayloadOptions,
                base: Fit | None = None) -> Fit:  # fmt: skip
    """The robot (rooted as ``robot``) with its payload as a ``Fit``: r, total mass and cov
    include the payload, ``fit.payload`` holds its record; ``base`` None: the model file's
    masses. Data must be validated (``Measurements.checked``)."""
    if base is not None:
        check_base(robot, base, "base")
    record, p, cov_p, lost, theta, ref, nuisance, kinds = solve_payload(robot, data, opts, base)
    n = len(ref.body_names)
    kd = robot.sesc_matrix(ref)
    dmap = payload_map(ref, opts.body)
    p_used = p.copy()
    if opts.mass is None and lost[0]:
        p_used[:] = 0.0  # a mass the data do not see: no payload in the predictions
    mass = float(theta[:n].sum() + p_used[0])
    r = (kd @ (theta + dmap @ p_used) / mass).reshape(-1, 3)
    jr = (kd @ dmap - np.outer(r.reshape(-1), [1.0, 0, 0, 0])) / mass
    cov_r = jr @ np.nan_to_num(cov_p) @ jr.T
    same = base is not None and base.robot.support == robot.support
    r_prior = (kd @ theta / theta[:n].sum()).reshape(-1, 3)
    if same:
        assert base is not None
        cov_r = cov_r + (theta[:n].sum() / mass) ** 2 * base.cov
        b0 = base.basis
    else:
        b0 = np.eye(3 * n)
    gone = jr[:, lost] if lost.any() else np.zeros((3 * n, 0))
    seen = jr[:, ~lost]
    span = np.hstack([b0, seen])
    if gone.size:
        u = basis_of(gone, 1e-12)
        span = span - u @ (u.T @ span)
    basis = basis_of(span, 1e-9)
    kfits = tuple(
        KindFit(k.kind, k.n_rows, record.n_poses, k.sigma, k.sigma_by, k.dof, k.rms,
                math.nan, False, UNITS[k.kind])
        for k in kinds
    )  # fmt: skip
    first = kfits[0]
    fields = dict(
        robot=robot, r=r, r_prior=r_prior, cov=cov_r, basis=basis, rank=basis.shape[1],
        n_poses=record.n_poses, n_rows=record.n_rows, sigma_hat=first.sigma, rms=first.rms,
        mae=math.nan, kinds=kfits, nuisance=nuisance, total_mass=mass,
        mass_given=opts.mass is not None, gravity_accel=opts.gravity_accel, payload=record,
        sigma_dof=first.dof,
    )  # fmt: skip
    if same:
        assert base is not None
        out = dataclasses.replace(base, **fields)
        return dataclasses.replace(out, cv=None, robust=None, online=None, joint_noise=None,
                                   truth_cop_rmse=None, choice=None, bodies=None)  # fmt: skip
    return Fit(
        singular_values=np.zeros(3 * n), rtol=opts.rtol,
        method="ls" if base is None else base.method, **fields,
    )  # fmt: skip
