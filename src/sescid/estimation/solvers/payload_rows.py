"""A payload's rows: the base's body parameters θ_b, the map D of the payload p = (m, h) into
them, and every measured row as a function of p (``payload`` module docstring)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from sescid.errors import DataError
from sescid.estimation.data.balance_rows import MIN_RHO
from sescid.estimation.data.measurements import Measurements
from sescid.estimation.result.fit import Fit
from sescid.estimation.sums.pooled import PARAM_UNIT
from sescid.kinds import BALANCE, COP, TORQUE
from sescid.robot import Robot
from sescid.sesc import gravity_ratios, line_across, line_distance
from sescid.stance import stance_robot


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
class PayloadRows:
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


def rows_of(robot: Robot, ref: Robot, theta: np.ndarray, data: list[Measurements], g0: float,
            body: str, base_support: str | None = None) -> PayloadRows:  # fmt: skip
    """The rows of validated data (each chunk in its stance, ``Measurements.stance_on``) for a
    payload on the link ``body`` of ``ref`` with body parameters θ_b ``theta``, |g| ``g0``;
    ``base_support``: also each row's derivative in the base fit's r for rows of that stance."""
    dmap = payload_map(ref, body)
    parts: list[
        tuple[str, np.ndarray, np.ndarray, np.ndarray, np.ndarray, float, dict[str, Any]]
    ] = []
    nuisance: list[tuple[str, str]] = []
    stances: list[str] = []
    per_pose = 0
    for m in data:
        stance = m.stance_on(robot)
        rs, support = stance_robot(robot, stance), stance.label
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
        if TORQUE in m.kinds:  # not on both feet: ``Measurements.checked`` refuses it
            assert m.tau is not None
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
    return PayloadRows(np.concatenate(ys), np.concatenate(c0s), np.concatenate(us),
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


def predict_rows(rows: PayloadRows, p: np.ndarray, nu: np.ndarray, base_mass: float):
    """Predictions (R,) and their Jacobian (R, 4) in p = (m, h) at p."""
    den = base_mass + p[0]
    num = rows.u + rows.v @ p
    scale = np.where(rows.k > 0, 1.0 / den, 1.0)
    pred = rows.c0 + num * scale + rows.nuis @ nu
    jac = rows.v * scale[:, None]
    jac[:, 0] -= np.where(rows.k > 0, num / den**2, 0.0)
    return pred, jac
