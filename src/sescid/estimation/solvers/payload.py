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
from typing import Any

import numpy as np

from sescid.base import G0
from sescid.errors import DataError, ModelError, OptionError
from sescid.estimation.data.balance_rows import MIN_RHO
from sescid.estimation.data.measurements import BALANCE, COP, TORQUE, Measurements
from sescid.estimation.result.fit import Fit, KindFit, NuisanceEstimate
from sescid.estimation.result.identifiability import DEFAULT_RTOL
from sescid.estimation.result.payload_record import PayloadFit, PayloadKind
from sescid.estimation.solvers.solve import UNITS
from sescid.estimation.sums.pooled import PARAM_UNIT
from sescid.robot import DOUBLE, Robot
from sescid.sesc import gravity_ratios, line_across, line_distance

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


def base_parameters(fit: Fit | None, robot: Robot) -> tuple[np.ndarray, str]:
    """θ_b (4N,) of ``fit.robot``'s bodies (or ``robot``'s model when fit is None) and how it
    was made: a pooled fit's body parameters, a consistent fit's masses and CoMs, else the
    model's parameters changed least (in units of kg and kg·ℓ) to reproduce the fit's r and
    total mass."""
    if fit is None:
        return robot.body_parameters(), "model"
    ref = fit.robot
    n = len(ref.body_names)
    label = f"fit: {fit.method_label}"
    if fit.bodies is not None:
        x = np.asarray(fit.bodies.x, dtype=float)
        theta = x * fit.bodies.total_mass
        theta[n:] *= PARAM_UNIT
        return theta, label
    if fit.inertials is not None:
        m = np.asarray(fit.inertials.masses, dtype=float)
        c = np.asarray(fit.inertials.coms, dtype=float)
        return np.concatenate([m, (m[:, None] * c).reshape(-1)]), label
    mass = fit.total_mass if math.isfinite(fit.total_mass) else ref.total_mass
    theta0 = ref.body_parameters()
    k = ref.sesc_matrix()
    a = np.vstack([k, np.concatenate([np.ones(n), np.zeros(3 * n)])[None, :]])
    rhs = np.concatenate([mass * fit.r.reshape(-1) - k @ theta0, [mass - theta0[:n].sum()]])
    scale = np.concatenate([np.ones(n), np.full(3 * n, PARAM_UNIT)])
    delta = np.linalg.lstsq(a * scale[None, :], rhs, rcond=None)[0] * scale
    return theta0 + delta, label


def payload_map(ref: Robot, body: str) -> np.ndarray:
    """D (4N, 4): θ = θ_b + D (m, h) for a payload of mass m and first moment h = m c [kg·m]
    about the link ``body``'s origin, in its frame (``ref``'s body frames)."""
    n = len(ref.body_names)
    b, x = ref.model.link_frames[body]
    d = np.zeros((4 * n, 4))
    d[b, 0] = 1.0
    d[n + 3 * b : n + 3 * b + 3, 0] = x[:3, 3]
    d[n + 3 * b : n + 3 * b + 3, 1:] = x[:3, :3]
    return d


@dataclass
class _Rows:
    """Every row of the data: pred = c0 + (u + v·p) / M^k + nuisance · ν (k 1: CoM-based, 0:
    torques), with the target y and the kind of each row."""

    y: np.ndarray
    c0: np.ndarray
    u: np.ndarray
    v: np.ndarray  #: (R, 4)
    k: np.ndarray  #: (R,) 1.0 or 0.0
    nuis: np.ndarray  #: (R, K)
    kind: np.ndarray  #: (R,) index into kinds
    kinds: list[str]
    nuisance: list[tuple[str, str]]  #: (what, joint)
    rows_per_pose: int  #: most rows one pose gives that see the payload
    stances: list[str]
    #: (R, 3N) ∂pred/∂vec(r_b) over M_b (CoM rows, then over M) of the rows measured in the base
    #: fit's own support (0 elsewhere), and the base's covariance (3N, 3N); None: not propagated
    jb: np.ndarray | None = None
    cb: np.ndarray | None = None


def _rows(robot: Robot, ref: Robot, theta: np.ndarray, dmap: np.ndarray, data: list[Measurements],
          g0: float, body: str, base_support: str | None = None) -> _Rows:  # fmt: skip
    """The rows of validated data (each chunk in its stance, ``Measurements.support``);
    ``base_support``: also each row's derivative in the base fit's r for rows of that stance."""
    parts: list[
        tuple[str, np.ndarray, np.ndarray, np.ndarray, np.ndarray, float, dict[str, Any]]
    ] = []
    nuisance: list[tuple[str, str]] = []
    stances: list[str] = []
    per_pose = 0
    for m in data:
        rs = robot.stance(m.support)
        support = m.support or robot.support
        if support not in stances:
            stances.append(support)
        ks = rs.sesc_matrix(ref)
        kb, kd = ks @ theta, ks @ dmap
        seen_here = 0
        mine = base_support is not None and support == base_support
        if COP in m.kinds or BALANCE in m.kinds:
            phi = rs.regressor(m.q, (0, 1, 2))  # (n, 3, 3N)
            a, bm = phi @ kb, phi @ kd  # (n, 3), (n, 3, 4)
            d = rs.d
        if COP in m.kinds:
            assert m.cop is not None
            n = m.n
            proj = np.zeros((n, 2, 3))
            proj[:, 0, 0] = proj[:, 1, 1] = 1.0
            if m.gravity is not None:
                proj[:, :, 2] = -gravity_ratios(m.gravity, n)
            c0 = proj @ d
            u = np.einsum("nij,nj->ni", proj, a)
            v = np.einsum("nij,njp->nip", proj, bm)
            keep = ~np.isnan(m.cop)
            jb = np.einsum("nij,njp->nip", proj, phi)[keep] if mine else None
            parts.append((COP, m.cop[keep], c0[keep], u[keep], v[keep], 1.0, {"jb": jb}))
            seen_here += 2
        if BALANCE in m.kinds:
            assert m.balance is not None and m.gravity is not None
            if rs.line is None:
                raise DataError(f"{m.source}: balance rows need a support line (--line)")
            ndir = line_across(rs.line, m.gravity)
            rho = np.maximum(line_distance(rs.line, d + a / theta[: len(ref.body_names)].sum()),
                             MIN_RHO)  # fmt: skip
            jb = np.einsum("na,nap->np", ndir, phi) / rho[:, None] if mine else None
            parts.append((BALANCE, m.balance / rho, ndir @ d / rho,
                          np.einsum("na,na->n", ndir, a) / rho,
                          np.einsum("na,nap->np", ndir, bm) / rho[:, None], 1.0,
                          {"jb": jb}))  # fmt: skip
            seen_here += 1
        if TORQUE in m.kinds:
            assert m.tau is not None
            if support == DOUBLE:
                raise DataError(
                    f"{m.source}: joint torques on both feet are not determined by statics "
                    "(measure them on one foot or in a fixture)"
                )
            joints = list(m.tau_joints)
            phit = rs.torque_regressor(m.q, joints, m.gravity, g0)  # (n, J, 3N)
            t0, tb = phit @ kb, phit @ kd  # (n, J), (n, J, 4)
            cols = {}
            for j, name in enumerate(joints):
                for what in ("offset", "friction") if m.approach is not None else ("offset",):
                    if (what, name) not in nuisance:
                        nuisance.append((what, name))
                    cols[(what, name, j)] = nuisance.index((what, name))
            nj = len(joints)
            extra: dict[str, Any] = {
                "cols": cols,
                "n": m.n,
                "nj": nj,
                "approach": m.approach,
                "jb": phit.reshape(-1, phit.shape[2]) if mine else None,
            }
            parts.append((TORQUE, m.tau.reshape(-1), np.zeros(m.n * nj), t0.reshape(-1),
                          tb.reshape(-1, 4), 0.0, extra))  # fmt: skip
            bidx = rs.model.link_frames[body][0]
            sub = _chain_to(rs, bidx)
            seen_here += int(sum(1 for j in joints if _drives(rs, j, sub)))
        per_pose = max(per_pose, seen_here)
    kinds: list[str] = [k for k in (COP, TORQUE, BALANCE) if any(p[0] == k for p in parts)]
    if not parts:
        raise DataError("no CoP, joint torque or balance rows to identify a payload from")
    ys, c0s, us, vs, ks_, nus, kis, jbs = [], [], [], [], [], [], [], []
    n_x = 3 * len(ref.body_names)
    for kind, y, c0, u, v, kk, extra in parts:
        r = y.shape[0]
        nu = np.zeros((r, len(nuisance)))
        jbs.append(extra["jb"] if extra["jb"] is not None else np.zeros((r, n_x)))
        if "cols" in extra:
            n, nj, app = extra["n"], extra["nj"], extra["approach"]
            for (what, _name, j), col in extra["cols"].items():
                rows = np.arange(n) * nj + j
                nu[rows, col] = 1.0 if what == "offset" else app
        ys.append(y)
        c0s.append(c0)
        us.append(u)
        vs.append(v)
        ks_.append(np.full(r, kk))
        nus.append(nu)
        kis.append(np.full(r, kinds.index(kind)))
    jb = np.vstack(jbs) if base_support is not None else None
    return _Rows(np.concatenate(ys), np.concatenate(c0s), np.concatenate(us),
                 np.concatenate(vs), np.concatenate(ks_), np.vstack(nus),
                 np.concatenate(kis), kinds, nuisance, per_pose, stances, jb)  # fmt: skip


def _chain_to(rs: Robot, b: int) -> set[int]:
    """Bodies from the root to body b (their joints carry b's weight)."""
    out = set()
    while b >= 0:
        out.add(b)
        b = int(rs.tree.parent[b])
    return out


def _drives(rs: Robot, joint: str, chain: set[int]) -> bool:
    """Whether the joint turns one of the bodies of ``chain`` (so its torque sees them)."""
    col = int(rs.joint_columns([joint])[0])
    return any(int(rs.tree.jcol[b]) == col for b in chain if b > 0)


def _predict(rows: _Rows, p: np.ndarray, nu: np.ndarray, base_mass: float):
    """Predictions (R,) and their Jacobian (R, 4) in p = (m, h) at p."""
    den = base_mass + p[0]
    num = rows.u + rows.v @ p
    scale = np.where(rows.k > 0, 1.0 / den, 1.0)
    pred = rows.c0 + num * scale + rows.nuis @ nu
    jac = rows.v * scale[:, None]
    jac[:, 0] -= np.where(rows.k > 0, num / den**2, 0.0)
    return pred, jac


def _solve(rows: _Rows, base_mass: float, opts: PayloadOptions):
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
            pred, jac = _predict(rows, p, nu, base_mass)
            e = white(rows.y - pred)
            jz = white(np.hstack([jac[:, free], rows.nuis])) * scale[None, :]
            step = np.linalg.lstsq(jz, e, rcond=opts.rtol)[0] * scale
            cost = float(e @ e)
            t = 1.0
            for _half in range(30):
                p_new, nu_new = p.copy(), nu + t * step[len(free) :]
                p_new[free] += t * step[: len(free)]
                if base_mass + p_new[0] > 0:
                    e_new = white(rows.y - _predict(rows, p_new, nu_new, base_mass)[0])
                    if float(e_new @ e_new) <= cost * (1 + 1e-12):
                        break
                t /= 2
            p, nu = p_new, nu_new
            if np.all(np.abs(t * step[: len(free)]) <= 1e-12 * (1 + np.abs(p[free]))):
                break
        pred, jac = _predict(rows, p, nu, base_mass)
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
    jz = white(np.hstack([_predict(rows, p, nu, base_mass)[1][:, free], rows.nuis]))
    free_sigma = np.array([given[kd] is None and dof[i] <= 0.5 for i, kd in enumerate(rows.kinds)])
    return p, nu, jz, sigma, dof, res, free, free_sigma


def _whitener(rows: _Rows, sigma: np.ndarray, p: np.ndarray, base_mass: float):
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
    dmap = payload_map(ref, opts.body)
    # the base fit's own uncertainty, for rows of its support (dense: up to BASE_ROWS rows)
    same = base is not None and np.all(np.isfinite(base.cov)) and np.any(base.cov != 0)
    n_rows = sum(d.rows() for d in data)
    support = base.robot.support if base is not None and same and n_rows <= BASE_ROWS else None
    rows = _rows(robot, ref, theta, dmap, data, opts.gravity_accel, opts.body, support)
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
        u, s, _ = np.linalg.svd(gone, full_matrices=False)
        u = u[:, s > 1e-12 * max(s.max(), 1e-300)]
        span = span - u @ (u.T @ span)
    uu, ss, _ = np.linalg.svd(span, full_matrices=False)
    basis = uu[:, ss > 1e-9 * max(float(ss.max()) if ss.size else 0.0, 1e-300)]
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
