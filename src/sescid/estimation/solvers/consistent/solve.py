"""The consistent step: masses and CoMs whose r reproduce a fit, as one or two QPs."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, fields
from typing import Literal

import numpy as np

from sescid.errors import SescidError, check_choice
from sescid.estimation.data.checks import check_total_mass
from sescid.estimation.result.fit import Fit
from sescid.estimation.solvers.consistent.boxes import Box, body_boxes, mirror_pairs, mirror_plane
from sescid.estimation.solvers.consistent.exact import (
    exact_parameters,
    impossible,
    mass_notes,
    outside_boxes,
    solve_exact,
)
from sescid.estimation.solvers.consistent.qp import COM_SCALE, FIT_TOL, H_UNIT, sesc_map, solve_qp
from sescid.estimation.solvers.consistent.record import consistent_model, make_fit, model_coms, tidy
from sescid.robot import Robot
from sescid.sesc import sesc_vectors

#: how the CAD masses meet a weighed total: scaled uniformly to it, or kept as the data put them
#: (``consistent.prior``)
Spread = Literal["uniform", "data"]


@dataclass(frozen=True)
class MassSettings:
    """What the consistent step is told (``consistent_from_fit``'s keywords)."""

    total_mass: float | None = None
    mass_floor: float = 0.0
    symmetric: bool = False
    boxes: dict[str, tuple] | None = None
    box_margin: float | None = None
    com_scale: float = COM_SCALE
    fit_tol: float = FIT_TOL
    prior_std: float | None = None
    spread: Spread = "uniform"
    extra: dict = field(default_factory=dict)

    def check(self, robot: Robot) -> float:
        """SescidError for a value out of range; returns the total mass M [kg]."""
        check_total_mass(robot, self.total_mass)
        big_m = robot.total_mass if self.total_mass is None else float(self.total_mass)
        floor = self.mass_floor
        if not (math.isfinite(floor) and floor >= 0):
            raise SescidError(f"mass floor must be a finite mass ≥ 0 kg, got {floor}")
        frame = sum(b.frame_only for b in robot.model.bodies)
        n_massive = len(robot.body_names) - frame
        if floor * n_massive > big_m:
            raise SescidError(
                f"mass floor {floor} kg × {n_massive} bodies = {floor * n_massive:.4g} kg "
                f"exceeds the total mass {big_m:.4g} kg"
            )
        if not (math.isfinite(self.com_scale) and self.com_scale > 0):
            raise SescidError(f"com_scale must be a positive length in m, got {self.com_scale}")
        std = self.prior_std
        if std is not None and not (math.isfinite(std) and std > 0):
            raise SescidError(f"prior std must be a positive relative deviation, got {std}")
        if not (math.isfinite(self.fit_tol) and self.fit_tol > 0):
            raise SescidError(f"fit_tol must be a positive length in m, got {self.fit_tol}")
        check_choice("spread", self.spread, Spread)
        return big_m


@dataclass(frozen=True)
class DataTerm:
    """The fit's data term in whitened units: u = D x − e, ‖u‖² the increase of the mean
    squared residual in mm² (m units) — see ``data_term``."""

    d_mat: np.ndarray  #: (p, 4N)
    e_vec: np.ndarray  #: (p,)
    scale_u: float
    w_bar: float
    n_rows: int


def data_term(fit: Fit, kmat: np.ndarray) -> DataTerm:
    """U = c S Vᵀ (K x − r̂), c chosen so that ‖u‖² is the increase of the mean squared
    residual in mm². For a weighted fit S carries the row weights; their mean w̄ = weighted RSS
    / RSS is read off sigma_hat (weighted) and rms (m) (1 for a noise-free fit)."""
    basis = fit.basis
    sv = fit.singular_values[: basis.shape[1]]
    n_rows = max(fit.n_rows, 1)
    dof = fit.n_rows - fit.rank
    w_bar = 1.0
    if dof > 0 and math.isfinite(fit.sigma_hat) and math.isfinite(fit.rms) and fit.rms > 1e-12:
        w_bar = fit.sigma_hat**2 * dof / (fit.rms**2 * n_rows)
        w_bar = w_bar if math.isfinite(w_bar) and w_bar > 0 else 1.0
    scale_u = 1e3 / math.sqrt(n_rows * w_bar)
    if fit.bodies is not None:  # pooled stances: the data's information about x itself
        lam, vecs = np.linalg.eigh(fit.bodies.information)
        keep = lam > 1e-12 * max(float(lam.max()), 1e-300)
        s_x, v_x = np.sqrt(lam[keep]), vecs[:, keep]
        d_mat = scale_u * (s_x[:, None] * v_x.T)
        e_vec = scale_u * s_x * (v_x.T @ fit.bodies.x)
        return DataTerm(d_mat, e_vec, scale_u, w_bar, n_rows)
    d_mat = scale_u * (sv[:, None] * basis.T) @ kmat
    e_vec = scale_u * sv * (basis.T @ fit.r.reshape(-1))
    return DataTerm(d_mat, e_vec, scale_u, w_bar, n_rows)


def equalities(robot: Robot, term: DataTerm, frame: np.ndarray, pairs) -> tuple:
    """A_eq x = b_eq over x = [m/M, h/(M ℓ), u]: u's definition, Σ m = M, frame-only bodies
    massless, mirrored pairs equal (masses, world first moments at q = 0)."""
    nb = len(robot.body_names)
    p = term.d_mat.shape[0]
    nv = 4 * nb + p
    eq_rows = [np.hstack([-term.d_mat, np.eye(p)])]
    eq_rhs = [-term.e_vec]
    row = np.zeros((1, nv))
    row[0, :nb] = 1.0
    eq_rows.append(row)
    eq_rhs.append(np.ones(1))
    for i in np.flatnonzero(frame):  # frame-only bodies: m_i = 0, h_i = 0
        rows = np.zeros((4, nv))
        rows[0, i] = 1.0
        rows[1:, nb + 3 * i : nb + 3 * i + 3] = np.eye(3)
        eq_rows.append(rows)
        eq_rhs.append(np.zeros(4))
    if pairs:
        normal, offset = mirror_plane(robot, pairs)
        s_lin = np.eye(3) - 2 * np.outer(normal, normal)
        rot, org = robot.forward(np.zeros((1, robot.nq)))
        rot, org = rot[0], org[0]
        for i, j in pairs:  # world first moments at q = 0: ℓ R h̃ + o m̃
            rows = np.zeros((4, nv))
            rows[0, i], rows[0, j] = 1.0, -1.0
            rows[1:, i] = org[i] / H_UNIT
            rows[1:, nb + 3 * i : nb + 3 * i + 3] = rot[i]
            rows[1:, j] = -(s_lin @ org[j] + 2 * offset * normal) / H_UNIT
            rows[1:, nb + 3 * j : nb + 3 * j + 3] = -s_lin @ rot[j]
            eq_rows.append(rows)
            eq_rhs.append(np.zeros(4))
    return np.vstack(eq_rows), np.concatenate(eq_rhs)


def inequalities(nv: int, frame, floor: float, big_m: float, box_list: list[Box]) -> tuple:
    """A_in x ≤ b_in: the mass floor, then each CoM inside its box (linear in π)."""
    nb = len(box_list)
    in_rows, in_rhs = [], []
    floor_rows = np.zeros((nb, nv))
    floor_rows[:, :nb] = -np.eye(nb)
    in_rows.append(floor_rows)
    in_rhs.append(np.where(frame, 0.0, -floor / big_m))
    for i, box in enumerate(box_list):
        for a in range(3):
            col = nb + 3 * i + a
            upper = np.zeros(nv)
            upper[col], upper[i] = 1.0, -box.hi[a] / H_UNIT
            lower = np.zeros(nv)
            lower[col], lower[i] = -1.0, box.lo[a] / H_UNIT
            in_rows += [upper[None], lower[None]]
            in_rhs += [np.zeros(1), np.zeros(1)]
    return np.vstack(in_rows), np.concatenate(in_rhs)


def cad_term(robot: Robot, big_m: float, nv: int, settings: MassSettings) -> tuple:
    """‖w ⊙ (x − x_cad)‖² as (P, q): CAD masses scaled to M ("uniform") or as they are ("data":
    the sum constraint and the data term place the weighed difference), CoMs unchanged."""
    m_cad = robot.masses
    nb = m_cad.size
    nx = 4 * nb
    m_prior = m_cad * (big_m / m_cad.sum()) if settings.spread == "uniform" else m_cad.copy()
    m_bar = np.maximum(m_prior, big_m / (10 * nb)) / big_m
    x_cad = np.concatenate([m_prior / big_m, (m_prior[:, None] * model_coms(robot)).ravel()])
    x_cad[nb:] /= big_m * H_UNIT
    w = np.concatenate([1 / m_bar, np.repeat(H_UNIT / (m_bar * settings.com_scale), 3)])
    p_cad = np.zeros((nv, nv))
    p_cad[:nx, :nx] = 2 * np.diag(w**2)
    q_cad = np.zeros(nv)
    q_cad[:nx] = -2 * w**2 * x_cad
    return p_cad, q_cad


def _solve(fit: Fit, term: DataTerm, constraints, cad, settings: MassSettings):
    """One QP with a CAD prior (``prior_std``), or two: best data fit, then closest to CAD
    among the fits within ``fit_tol``. The solution and the solver's statuses/iterations."""
    a_eq, b_eq, a_in, b_in = constraints
    p_cad, q_cad = cad
    p = term.d_mat.shape[0]
    nv = p_cad.shape[0]
    nx = nv - p
    p_data = np.zeros((nv, nv))
    p_data[nx:, nx:] = 2 * np.eye(p)
    if settings.prior_std is not None:  # one QP: Gaussian prior on the deviations (MAP in π)
        sigma = fit.sigma_hat / math.sqrt(term.w_bar) if math.isfinite(fit.sigma_hat) else fit.rms
        lam = (sigma * 1e3 / math.sqrt(term.n_rows)) ** 2 / settings.prior_std**2
        x2, status, it = solve_qp(
            p_data + lam * p_cad, lam * q_cad, a_eq, b_eq, a_in, b_in, "consistent fit"
        )
        return x2, [status], [it]
    x1, status1, it1 = solve_qp(p_data, np.zeros(nv), a_eq, b_eq, a_in, b_in, "consistent fit")
    u_star = x1[nx:]
    delta = settings.fit_tol * 1e3 / math.sqrt(max(p, 1))
    band = np.zeros((2 * p, nv))
    band[:p, nx:] = np.eye(p)
    band[p:, nx:] = -np.eye(p)
    a_in2 = np.vstack([a_in, band])
    b_in2 = np.concatenate([b_in, u_star + delta, -(u_star - delta)])
    x2, status2, it2 = solve_qp(p_cad, q_cad, a_eq, b_eq, a_in2, b_in2, "consistent fit (CAD step)")
    return x2, [status1, status2], [it1, it2]


def consistent_from_fit(fit: Fit, *, spread: Spread = "uniform", **settings) -> Fit:
    """Masses and CoMs that reproduce ``fit``'s identified directions (see the package doc).

    Keywords (``MassSettings``): ``total_mass`` kg (default: the model's), ``mass_floor`` kg
    lower bound on every body's mass, ``symmetric`` mirrored bodies equal,
    ``boxes``/``box_margin`` see ``body_boxes``, ``com_scale`` m and ``fit_tol`` m tune the
    closest-to-CAD step; ``prior_std`` (relative, e.g. 0.1): instead of the two steps, one QP
    trading the data fit against the CAD deviation as a Gaussian prior of that relative mass
    std (CoM std ``com_scale·prior_std``), with the noise σ from the fit. Returns a new Fit
    (method "consistent") with r computed from the masses and CoMs (``fit.inertials``).
    """
    known = {f.name for f in fields(MassSettings)} - {"extra", "spread"}
    unknown = set(settings) - known
    if unknown:
        raise SescidError(f"consistent step: unknown setting {sorted(unknown)[0]!r}")
    opts = MassSettings(spread=spread, **settings)
    robot = fit.robot
    big_m = opts.check(robot)
    names = robot.body_names
    frame = np.array([b.frame_only for b in robot.model.bodies], dtype=bool)
    box_list = body_boxes(robot, opts.boxes, opts.box_margin)
    pairs = mirror_pairs(names) if opts.symmetric else []
    if opts.symmetric and not pairs:
        raise SescidError(
            "symmetric: no left/right body pairs found (names like *_R/*_L, r_*/l_*, …)"
        )
    t0 = time.perf_counter()
    if fit.method == "map" and opts.prior_std is None:
        return _exact(fit, opts, big_m, frame, box_list, pairs, t0)
    term = data_term(fit, sesc_map(robot))
    nv = 4 * len(names) + term.d_mat.shape[0]
    a_eq, b_eq = equalities(robot, term, frame, pairs)
    a_in, b_in = inequalities(nv, frame, opts.mass_floor, big_m, box_list)
    cad = cad_term(robot, big_m, nv, opts)
    x2, statuses, iterations = _solve(fit, term, (a_eq, b_eq, a_in, b_in), cad, opts)
    elapsed = time.perf_counter() - t0
    nx = 4 * len(names)
    masses, coms = tidy(x2[:nx], big_m, opts.mass_floor, box_list, model_coms(robot), pairs, robot)
    r = sesc_vectors(consistent_model(robot, masses, coms))
    sv = fit.singular_values[: fit.basis.shape[1]]
    du = term.scale_u * sv * (fit.basis.T @ (r - fit.r).reshape(-1))
    d_rss = float(du @ du) * term.n_rows * 1e-6  # extra residual sum of squares vs the fit, m²
    info = {
        "total_mass": big_m,
        "mass_floor": opts.mass_floor,
        "symmetric": bool(opts.symmetric),
        "com_scale": opts.com_scale,
        "fit_tol": opts.fit_tol,
        "prior_std": opts.prior_std,
        "solver_status": statuses,
        "solver_iterations": iterations,
        "solve_time": elapsed,
    }
    return make_fit(fit, r, masses, coms, (box_list, pairs), d_rss, info)


def _exact(fit: Fit, opts: MassSettings, big_m, frame, box_list, pairs, t0) -> Fit:
    """A MAP fit's SESC vectors reproduced exactly (``consistent.exact``)."""
    robot = fit.robot
    nb = len(robot.body_names)
    empty = DataTerm(np.zeros((0, 4 * nb)), np.zeros(0), 1.0, 1.0, max(fit.n_rows, 1))
    a_eq, b_eq = equalities(robot, empty, frame, pairs)
    a_in, b_in = inequalities(4 * nb, frame, opts.mass_floor, big_m, box_list)
    x, statuses, iterations, unseen, dropped = solve_exact(
        fit, big_m, (a_eq, b_eq), (a_in, b_in), (a_in[:nb], b_in[:nb]), opts.com_scale
    )
    masses, coms, h = exact_parameters(fit, x, big_m, opts.mass_floor, frame, unseen)
    outside = outside_boxes(coms, masses, box_list, robot.body_names) if dropped else []
    r = sesc_vectors(consistent_model(robot, masses, coms))
    sv = fit.singular_values[: fit.rank]
    du = sv * (fit.basis[:, : fit.rank].T @ (r - fit.r).reshape(-1))
    info = {
        "total_mass": big_m,
        "mass_floor": opts.mass_floor,
        "symmetric": bool(opts.symmetric),
        "com_scale": opts.com_scale,
        "fit_tol": 0.0,
        "prior_std": None,
        "solver_status": statuses,
        "solver_iterations": iterations,
        "solve_time": time.perf_counter() - t0,
        "exact": True,
        "undetermined": [n for n, u in zip(robot.body_names, unseen, strict=True) if u],
        "notes": impossible(fit, masses, h, big_m)
        + mass_notes(fit, masses, big_m, opts.com_scale, unseen, outside),
    }
    return make_fit(fit, r, masses, coms, (box_list, pairs), float(du @ du), info)
