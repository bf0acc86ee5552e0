"""The measurements as linear rows in the body parameters, and which bodies explain a misfit.

Every kind is linear in a stance's SESC vectors, and those in the body parameters
θ = [m (N) kg; vec(m c) (3N) kg·m] shared by every stance (``Robot.sesc_matrix``):
``r_s = E_s θ / M``. ``kind_rows`` gives, for one candidate θ, each kind's measured values, the
candidate's predictions and their Jacobian in θ (exact for torques, first order for the CoP and
the balance through M = Σ m). ``attribute`` then names the bodies whose mass or first moment
explain a whitened residual beyond its noise: a greedy selection of one-body hypotheses
(4 parameters each) and one "all masses scaled" hypothesis, each tested by the χ² drop it
brings, Bonferroni-corrected over the hypotheses, as a two-sided z.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sescid.base import G0
from sescid.errors import DataError
from sescid.estimation import Measurements
from sescid.estimation.data.balance_rows import balance_rows
from sescid.estimation.data.torque_rows import nuisance_names
from sescid.estimation.result.identifiability import basis_of
from sescid.estimation.solvers.map_prior import BODY_COM_SCALE
from sescid.kinds import KINDS
from sescid.robot import Robot
from sescid.stance import stance_robot

#: singular values below this fraction of a block's largest count as not seen
SEEN_RTOL = 1e-6
#: at most this many hypotheses are named
MAX_NAMED = 6
#: the unit a kind's noise is given in on the command line (``--noise KIND=VALUE``)
NOISE_UNITS = {"cop": "mm", "tau": "N·m", "balance": "degrees"}
#: a hypothesis: the bodies it names and its directions (4N, k) in the body parameters
Hypothesis = tuple[tuple[str, ...], np.ndarray]
#: χ² units within which two hypotheses explain the data equally well
TIE_CHI2 = 2.0
#: hypothesis name for "every mass scaled by one factor"
ALL_BODIES = "all bodies"


@dataclass(frozen=True)
class KindRows:
    """One measurement kind's rows over all data sets, for one candidate."""

    kind: str
    y: np.ndarray  #: (m,) measured (m, N·m, or rad for a balance)
    pred: np.ndarray  #: (m,) the candidate's prediction, same unit
    jac: np.ndarray  #: (m, 4N) d pred / d θ
    noise: float  #: the data's noise standard deviation (residual of their own fit), same unit
    dof: int  #: degrees of freedom behind ``noise``
    #: (m, K) the kind's nuisance columns (a torque sensor's offset, its friction band), each
    #: free whatever the file: sescid's fits estimate them too (``torque_rows.nuisance_names``)
    nuisance: np.ndarray
    nuisance_names: tuple[str, ...]


def _stance(robot: Robot, m: Measurements) -> Robot:
    return stance_robot(robot, m.stance_on(robot))


def r_jacobian(e: np.ndarray, theta: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The SESC vectors r = E θ / M (3N,) and dr/dθ (3N, 4N) at the body parameters θ."""
    mass = float(theta[:n].sum())
    r = e @ theta / mass
    dr = e / mass
    dr[:, :n] -= np.outer(r, np.ones(n)) / mass
    return r, dr


def _group_rows(robot: Robot, m: Measurements, theta: np.ndarray) -> dict[str, tuple]:
    """{kind: (y, pred, jac, ls_x, ls_y, nuisance)} for one data set; ``ls_x``, ``ls_y`` the
    rows in the stance's own linear parameters (vec(r), or M·vec(r) for torques), for the noise
    estimate; ``nuisance`` {name: column} (torques: each sensor's offset, friction band)."""
    n = len(robot.body_names)
    rs = _stance(robot, m)
    e = rs.sesc_matrix(robot)
    r, dr = r_jacobian(e, theta, n)
    q = m.q
    out: dict[str, tuple] = {}
    if m.cop is not None:
        if m.gravity is None:
            phi = rs.regressor(q, (0, 1))
            d = np.broadcast_to(rs.d[:2], (m.n, 2))
        else:
            phi = rs.regressor_tilted(q, m.gravity)
            d = rs.d_tilted(m.gravity, m.n)
        ok = ~np.isnan(m.cop)
        x = phi[ok]  # (rows, 3N)
        pred = d[ok] + x @ r
        out["cop"] = (m.cop[ok], pred, x @ dr, x, m.cop[ok] - d[ok], {})
    if m.tau is not None and m.tau_joints:
        phi_t = rs.torque_regressor(q, list(m.tau_joints), m.gravity, G0)  # (n, J, 3N)
        x = phi_t.reshape(-1, phi_t.shape[2])
        u = e @ theta  # M r
        y = m.tau.reshape(-1)  # rows (pose, joint)
        nj = len(m.tau_joints)
        nuis = {}
        for what, joint in nuisance_names(m):
            col = np.zeros(y.size)
            j = m.tau_joints.index(joint)
            side = m.approach if what == "friction" else None
            col[j::nj] = 1.0 if side is None else side
            nuis[f"tau.{what}[{joint}]"] = col
        out["tau"] = (y, x @ u, x @ e, x, y, nuis)
    if m.balance is not None:
        assert m.gravity is not None
        xb, yb = balance_rows(rs, q, m.balance, m.gravity)
        out["balance"] = (yb, xb.T @ r, xb.T @ dr, xb.T, yb, {})
    return out


def _noise(parts: list[tuple[np.ndarray, np.ndarray]]) -> tuple[float, int]:
    """σ̂ and its dof from the data sets' own least-squares fits (rows (x, y) per set)."""
    rss, dof = 0.0, 0
    for x, y in parts:
        if x.shape[0] == 0:
            continue
        u, s, vt = np.linalg.svd(x, full_matrices=False)
        keep = s > SEEN_RTOL * s[0] if s.size and s[0] > 0 else np.zeros(s.size, bool)
        if x.shape[0] <= int(keep.sum()):  # a set that its own fit meets exactly
            continue
        res = y - u[:, keep] @ (u[:, keep].T @ y)
        rss += float(res @ res)
        dof += x.shape[0] - int(keep.sum())
    return (math.sqrt(rss / dof) if dof > 0 else math.nan), dof


def kind_rows(
    robot: Robot,
    data: list[Measurements],
    theta: np.ndarray | None = None,
    noise: dict[str, float] | None = None,
) -> list[KindRows]:
    """Each kind's rows over the data sets ``data`` for the body parameters ``theta`` (4N,)
    (default: the robot's own). ``noise``: given standard deviations per kind (else estimated
    from the residuals of each data set's own least-squares fit, ``KindRows.noise``)."""
    th = robot.body_parameters() if theta is None else np.asarray(theta, dtype=float)
    got: dict[str, list[tuple]] = {}
    for m in data:
        for kind, rows in _group_rows(robot, m, th).items():
            got.setdefault(kind, []).append(rows)
    out = []
    for kind in KINDS:
        if kind not in got:
            continue
        parts = got[kind]
        y = np.concatenate([p[0] for p in parts])
        pred = np.concatenate([p[1] for p in parts])
        jac = np.concatenate([p[2] for p in parts])
        names = tuple(dict.fromkeys(k for p in parts for k in p[5]))
        nuis = np.zeros((y.size, len(names)))
        start = 0
        for p in parts:
            for k, col in p[5].items():
                nuis[start : start + col.size, names.index(k)] = col
            start += p[0].size
        if noise is not None and kind in noise:
            sigma, dof = float(noise[kind]), 0
        else:
            sigma, dof = _noise([(np.column_stack([p[3], *p[5].values()]), p[4]) for p in parts])
        if not (math.isfinite(sigma) and sigma > 0):
            raise DataError(
                f"{data[0].source}: the {kind} rows leave no degrees of freedom to judge their "
                f"noise ({y.size} rows): measure more poses, or give the noise (--noise "
                f"{kind}=VALUE, in {NOISE_UNITS[kind]})"
            )
        out.append(KindRows(kind, y, pred, jac, sigma, dof, nuis, names))
    return out


# --- naming the bodies behind a misfit -------------------------------------------------------
@dataclass(frozen=True)
class Named:
    """One hypothesis the data support beyond their noise: a body's (or every body's) change."""

    bodies: tuple[str, ...]  #: the body (its fixed links included), or every body
    mass: float  #: kg, the change in mass the data ask for (data − file)
    mass_std: float  #: kg
    moment: np.ndarray  #: (3,) kg·m, the change in first moment about the body frame's origin
    moment_std: np.ndarray  #: (3,) kg·m
    com_shift: float  #: m, how far the body's CoM moves (nan for every body)
    z: float  #: the hypothesis's significance in the joint fit, as a two-sided normal z
    z_selected: float  #: its Bonferroni-corrected z when it was selected
    #: bodies whose change would explain the data as well (the data cannot tell them apart)
    alternatives: tuple[str, ...] = ()


def tail(chi2: float, dof: int, noise_dof: float) -> float:
    """P(X ≥ chi2) for X ~ χ²(dof) (a known noise), or dof·F(dof, noise_dof) (an estimated one)."""
    from scipy.special import chdtrc, fdtrc

    if dof <= 0:
        return 1.0
    if math.isinf(noise_dof):
        return float(chdtrc(dof, max(chi2, 0.0)))
    return float(fdtrc(dof, noise_dof, max(chi2, 0.0) / dof))


def z_of_p(p: float) -> float:
    """The two-sided normal z of a tail probability p (0 for p ≥ 1; 40 for p = 0)."""
    from scipy.special import ndtri

    return 40.0 if p <= 0 else float(max(-ndtri(min(p, 1.0) / 2), 0.0)) + 0.0


def hypotheses(robot: Robot, theta: np.ndarray) -> list[Hypothesis]:
    """(bodies, (4N, k) directions in θ): one per body (its mass and first moment) and one for
    every mass scaled by one factor (θ itself)."""
    n = len(robot.body_names)
    out: list[Hypothesis] = []
    for b, name in enumerate(robot.body_names):
        cols = np.zeros((4 * n, 4))
        cols[b, 0] = 1.0
        cols[n + 3 * b : n + 3 * b + 3, 1:] = np.eye(3)
        out.append(((name,), cols))
    out.append(((ALL_BODIES,), theta.reshape(-1, 1)))
    return out


def _relative(d: np.ndarray, cols: np.ndarray, theta: np.ndarray, n: int) -> float:
    """How large a hypothesis's change is against the file: the scale factor for every body,
    else ‖(δm / m, δh / (m · BODY_COM_SCALE))‖ of its body (inf for a massless body)."""
    if cols.shape[1] == 1:
        return abs(float(d[0]))
    b = int(np.flatnonzero(cols[:n, 0])[0])
    m = float(theta[b])
    if m <= 0:
        return math.inf
    return float(np.hypot(d[0] / m, np.linalg.norm(d[1:]) / (m * BODY_COM_SCALE)))


#: Gauss–Newton steps of the named changes' estimate (the CoP is divided by the total mass)
GN_STEPS = 4
#: halvings of a Gauss–Newton step that raises the misfit before the estimate stops there
GN_HALVINGS = 4


@dataclass(frozen=True)
class _Test:
    """The test a change must pass: the z ``level`` it must reach, and the degrees of freedom
    of the noise estimate that whitened the residual (inf: the noise is known)."""

    level: float
    noise_dof: float


def _select(
    e: np.ndarray,
    a: np.ndarray,
    hyps: list[Hypothesis],
    theta: np.ndarray,
    test: _Test,
    start: list[int],
    limit: int = MAX_NAMED,
) -> list[tuple[int, float, tuple[str, ...]]]:
    """Greedy selection beyond ``start`` (their blocks projected out first): (hypothesis, its
    Bonferroni-corrected z, the equally good alternatives) while the z reaches the level."""
    level, noise_dof = test.level, test.noise_dof
    n = (theta.size) // 4
    blocks = [a @ cols for _, cols in hyps]
    chosen = list(start)
    out: list[tuple[int, float, tuple[str, ...]]] = []
    q = np.column_stack([blocks[h] for h in chosen]) if chosen else np.zeros((e.size, 0))
    q = basis_of(q, SEEN_RTOL)
    while len(chosen) < MAX_NAMED and len(out) < limit:
        res = e - q @ (q.T @ e)
        scored: list[tuple[float, float, int, float]] = []  # (p, drop, h, relative size)
        for h, blk in enumerate(blocks):
            if h in chosen:
                continue
            b = blk - q @ (q.T @ blk)
            ub = basis_of(b, SEEN_RTOL)
            if ub.shape[1] == 0:
                continue
            drop = float(np.sum((ub.T @ res) ** 2))
            p = min(tail(drop, ub.shape[1], noise_dof) * len(blocks), 1.0)
            d = np.linalg.lstsq(b, res, rcond=None)[0]
            scored.append((p, drop, h, _relative(d, hyps[h][1], theta, n)))
        if not scored:
            break
        p_best, drop_best = min(scored, key=lambda t: (t[0], -t[1]))[:2]
        if z_of_p(p_best) < level:
            break
        ties = [t for t in scored if t[1] >= drop_best - TIE_CHI2 and z_of_p(t[0]) >= level]
        pick = min(ties, key=lambda t: (t[3], t[2]))
        alts = tuple(hyps[t[2]][0][0] for t in sorted(ties, key=lambda t: t[3]) if t is not pick)
        chosen.append(pick[2])
        out.append((pick[2], z_of_p(pick[0]), alts))
        q = basis_of(np.column_stack([q, blocks[pick[2]]]), SEEN_RTOL)
    return out


def _estimate(
    e: np.ndarray,
    a: np.ndarray,
    cols: np.ndarray,
    theta: np.ndarray,
    residual: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """δ of the chosen directions ``cols`` (4N, k) and its covariance, by least squares on the
    whitened residual (Gauss–Newton through ``residual(θ) → (e, a)`` when given); also the
    residual and Jacobian at the estimate."""
    delta = np.zeros(cols.shape[1])
    for _ in range(GN_STEPS if residual is not None else 1):
        j = a @ cols
        step = np.linalg.lstsq(j, e, rcond=None)[0]
        if residual is None:
            delta = delta + step
            e = e - j @ step
            break
        for _ in range(GN_HALVINGS):  # a step that does not lower the misfit is halved
            e_new, a_new = residual(theta + cols @ (delta + step))
            if float(e_new @ e_new) <= float(e @ e):
                break
            step = step / 2
        else:
            break
        delta = delta + step
        done = float(np.linalg.norm(j @ step)) < 1e-9 * max(float(np.linalg.norm(e)), 1.0)
        e, a = e_new, a_new
        if done:
            break
    j = a @ cols
    return delta, np.linalg.pinv(j.T @ j, hermitian=True), e, a


def attribute(
    e: np.ndarray,
    a: np.ndarray,
    robot: Robot,
    theta: np.ndarray,
    level: float,
    noise_dof: float = math.inf,
    residual: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None,
) -> tuple[list[Named], float, int]:
    """Name the hypotheses (``hypotheses``) that explain the whitened residual ``e`` (m,) with
    whitened Jacobian ``a`` (m, 4N) at the body parameters ``theta``: greedily the one whose χ²
    drop is most significant, while its Bonferroni-corrected z reaches ``level``; ``noise_dof``:
    the degrees of freedom of the noise estimate that whitened ``e`` (an F test; inf: the noise
    is known, χ²). The first name needs its own test only (the family-wise rate is the
    Bonferroni bound); each further one also needs what is left beyond the named to exceed the
    noise. Hypotheses that explain the residual as well (χ² drop within ``TIE_CHI2``)
    are the data's alternatives: the one asking the smallest change of its body (``_relative``)
    is named, the others kept in ``Named.alternatives``. ``residual(θ) → (e, a)``: the rows at
    other parameters (the named changes are then estimated by Gauss–Newton and what is left is
    examined once more at the estimate). Returns the named (most significant first), the
    residual's overall z over everything ``a`` sees, and that dof."""
    seen = basis_of(a, SEEN_RTOL)
    dof_all = seen.shape[1]
    z_all = z_of_p(tail(float(np.sum((seen.T @ e) ** 2)), dof_all, noise_dof))
    hyps = hypotheses(robot, theta)
    step = MAX_NAMED if residual is None else 1  # relinearised after each name when possible
    picked: list[tuple[int, float, tuple[str, ...]]] = []
    e1, a1 = e, a
    delta = cov = np.zeros((0,))
    while len(picked) < MAX_NAMED:
        if picked:  # what is left beyond the named must itself exceed the noise
            qc = basis_of(np.column_stack([a1 @ hyps[h][1] for h, _, _ in picked]), SEEN_RTOL)
            seen1 = basis_of(a1, SEEN_RTOL)
            left = seen1.T @ e1
            left_chi = float(left @ left - np.sum((qc.T @ e1) ** 2))
            if z_of_p(tail(left_chi, seen1.shape[1] - qc.shape[1], noise_dof)) < level:
                break
        test = _Test(level, noise_dof)
        more = _select(e1, a1, hyps, theta, test, [h for h, _, _ in picked], step)
        if not more:
            break
        picked += more
        cols = np.column_stack([hyps[h][1] for h, _, _ in picked])
        delta, cov, e1, a1 = _estimate(e, a, cols, theta, residual)
        if residual is None:
            break
    if not picked:
        return [], z_all, dof_all
    n = len(robot.body_names)
    out = []
    k = 0
    for h, zs, alt in picked:
        cols = hyps[h][1]
        w = cols.shape[1]
        d, c = delta[k : k + w], cov[k : k + w, k : k + w]
        k += w
        dtheta = cols @ d
        ctheta = cols @ c @ cols.T
        ci = np.linalg.pinv(c, hermitian=True)
        z = z_of_p(tail(float(d @ ci @ d), int(np.linalg.matrix_rank(c)), noise_dof))
        std = np.sqrt(np.clip(np.diag(ctheta), 0, None))
        if hyps[h][0] == (ALL_BODIES,):
            mass = float(dtheta[:n].sum())
            mass_std = math.sqrt(max(float(np.sum(ctheta[:n, :n])), 0.0))
            moment, moment_std, shift = np.full(3, np.nan), np.full(3, np.nan), math.nan
        else:
            b = robot.body_names.index(hyps[h][0][0])
            mass, mass_std = float(dtheta[b]), float(std[b])
            sl = slice(n + 3 * b, n + 3 * b + 3)
            moment, moment_std = dtheta[sl].copy(), std[sl].copy()
            m0, h0 = float(theta[b]), theta[sl]
            m1 = m0 + mass
            ok = m0 > 0 and m1 > 0
            shift = float(np.linalg.norm((h0 + moment) / m1 - h0 / m0)) if ok else math.nan
        out.append(Named(hyps[h][0], mass, mass_std, moment, moment_std, shift, z, zs, alt))
    # a name whose change the joint estimate does not hold beyond the noise is not kept
    return [x for x in out if x.z >= level], z_all, dof_all
