"""Physically consistent parameters: body masses and CoMs that reproduce an identified fit.

The SESC vectors are linear in the per-body parameters π_i = (m_i, h_i = m_i c_i) once the total
mass M is fixed (weighed, or the URDF's):

    r_i = (h_i + Σ_{children ch} M_sub(ch) t_ch) / M        M_sub(ch) = Σ_{j in subtree(ch)} m_j

so "masses and CoMs whose r reproduce the data" is a convex quadratic program in π (4 unknowns
per body) with linear constraints:

- Σ m_i = M;  m_i ≥ mass_floor;
- m_i = 0 and h_i = 0 for a frame-only body (``Body.frame_only``: a frame between two hinges of
  one MJCF body, which the model file cannot give mass), so every fit can be exported;
- CoM inside the body's box:  m_i·lo_i ≤ h_i ≤ m_i·hi_i  (linear in π, per axis);
- optional left/right symmetry: mirrored bodies (``*_R``/``*_L``, ``r_*``/``l_*`` …) have equal
  masses and mirror-image CoMs at the zero pose (reflection in the sagittal plane through the
  mirrored links' frame origins).

It is solved lexicographically with Clarabel (an interior-point conic solver):

1. data fit: min ‖S Vᵀ(r(π) − r̂)‖², the least-squares cost of the fit r̂ restricted to the
   directions it identifies (S, V: its singular values and basis) — equal to the CoP residual
   sum of squares up to a constant;
2. closest to CAD among the (near-)optimal solutions of step 1: min Σ_i (Δm_i/m̄_i)² +
   ‖Δh_i‖²/(m̄_i ℓ)², deviations from the URDF's masses scaled to M (CoMs unchanged), with
   m̄_i = max(m_i^CAD, M/(10 N)) and ℓ = ``com_scale`` (m), subject to every whitened residual
   staying within ``fit_tol``/√p of its step-1 value (a CoP RMS change ≤ ``fit_tol``, 0.1 µm).

When no constraint is active, step 1 reproduces r̂ exactly along the identified directions
(any r is reachable for any masses, by moving the CoMs), so the CoP predictions equal the
least-squares ones; step 2 then fills the directions the data leave free with the CAD values.
With noisy data, r̂ is noisy along weakly excited directions and step 1 follows it: masses can
land far from any real robot, with CoMs on box faces (``fit.inertials.active_constraints``).
``prior_std`` replaces the two steps by one QP, data fit + (σ²/τ²)·(CAD deviation) — a Gaussian
prior of relative std τ on the deviation from CAD — which gives plausible masses.

Why Clarabel: a maintained interior-point QP/conic solver that reaches 1e-10 feasibility and
reports infeasibility reliably (the tolerance band of step 2 needs that; ADMM solvers such as
OSQP stop near 1e-4–1e-6), and scipy has no QP with general linear constraints (``lsq_linear``
takes bounds only; ``trust-constr`` is slow and inexact).

Boxes (in each body's frame, see ``body_boxes``): the axis-aligned hull of the URDF's
``<collision>`` shapes (box, cylinder, sphere; meshes ignored), else of its ``<visual>`` shapes,
else a fallback: the hull of the body's joint points (its own joint, its children's joints, its
merged links' frame origins) and its CAD CoM, grown by ``box_margin`` (default 0.02 m).
"""

from __future__ import annotations

import dataclasses
import math
import re
import time
from dataclasses import dataclass

import numpy as np

from sescid.errors import SescidError, SolverError
from sescid.estimation.checks import check_total_mass
from sescid.estimation.fit import BodyInertials, Fit
from sescid.model import body_hulls
from sescid.robot import Robot
from sescid.sesc import sesc_vectors

#: default growth of the fallback box (joint points + CAD CoM), m
FALLBACK_MARGIN = 0.02
#: default CoM deviation that costs as much as a 100 % mass change in the closest-to-CAD step, m
COM_SCALE = 0.02
#: default tolerance on the CoP RMS when choosing the closest-to-CAD solution, m
FIT_TOL = 1e-7
_ELL = 0.1  #: internal length unit of h (m), to keep the QP well scaled
_ACTIVE_M = 1e-7  #: a CoM within this of a box face counts as on it, m
_ACTIVE_KG = 1e-7  #: a mass within this (× M) of the floor counts as on it


@dataclass(frozen=True)
class Box:
    """An axis-aligned box in a body's frame (m) and where it came from."""

    lo: np.ndarray  #: (3,) m
    hi: np.ndarray  #: (3,) m
    source: str  #: "collision", "visual", "fallback" or "given"
    grown: bool = False  #: grown to contain the body's CAD CoM


# --- boxes ------------------------------------------------------------------------------
def body_boxes(
    robot: Robot,
    boxes: dict[str, tuple] | None = None,
    box_margin: float | None = None,
) -> list[Box]:
    """One box per body (in the body's frame, m) bounding where its CoM may lie.

    ``boxes``: ``{body name: (lo (3,), hi (3,))}`` in the frame of the body's main URDF link
    (its name), m; they take precedence. Otherwise the model's collision shapes, else its visual
    shapes, else the fallback (joint points + CAD CoM). ``box_margin`` (m) grows every box;
    default 0 for given/shape boxes and ``FALLBACK_MARGIN`` for fallback ones. A shape box that
    does not contain the body's CAD CoM is grown to contain it (``Box.grown``): the CAD model
    itself must be feasible.
    """
    model = robot.model
    names = robot.body_names
    if box_margin is not None and not (math.isfinite(box_margin) and box_margin >= 0):
        raise SescidError(f"box margin must be a finite length ≥ 0 m, got {box_margin}")
    given = {}
    for name, box in (boxes or {}).items():
        if name not in names:
            raise SescidError(f"box for unknown body '{name}' (bodies: {', '.join(names)})")
        try:
            lo, hi = (np.asarray(v, dtype=float).reshape(3) for v in box)
        except (TypeError, ValueError):
            raise SescidError(f"box for body '{name}': expected (lo xyz, hi xyz) in m") from None
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(lo <= hi)):
            raise SescidError(f"box for body '{name}': needs finite lo ≤ hi on every axis (m)")
        b = names.index(name)
        x = model.link_frames[model.bodies[b].name][1]  # main link frame in the body frame
        corners = np.array([[(lo, hi)[k >> a & 1][a] for a in range(3)] for k in range(8)])
        pts = corners @ x[:3, :3].T + x[:3, 3]
        given[b] = (pts.min(axis=0), pts.max(axis=0))
    collision = body_hulls(model.shapes, "collision")
    visual = body_hulls(model.shapes, "visual")
    children: list[list[int]] = [[] for _ in names]
    for i, body in enumerate(model.bodies):
        if body.parent >= 0:
            children[body.parent].append(i)
    out = []
    for b, body in enumerate(model.bodies):
        if b in given:
            (lo, hi), source, margin = given[b], "given", box_margin or 0.0
        elif b in collision:
            (lo, hi), source, margin = collision[b], "collision", box_margin or 0.0
        elif b in visual:
            (lo, hi), source, margin = visual[b], "visual", box_margin or 0.0
        else:
            pts = [np.zeros(3), body.com]
            pts += [model.bodies[c].trans_const for c in children[b]]
            pts += [model.link_frames[lk][1][:3, 3] for lk in body.links]
            pts = np.array(pts)
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            source = "fallback"
            margin = FALLBACK_MARGIN if box_margin is None else box_margin
        lo, hi = lo - margin, hi + margin
        grown = False
        if source in ("collision", "visual") and body.mass > 0:
            new_lo, new_hi = np.minimum(lo, body.com), np.maximum(hi, body.com)
            grown = bool(np.any(new_lo < lo) or np.any(new_hi > hi))
            lo, hi = new_lo, new_hi
        out.append(Box(lo, hi, source, grown))
    return out


# --- symmetry ---------------------------------------------------------------------------
_SIDES = [
    (r"^(.*)_R$", r"\1_L"),
    (r"^(.*)_r$", r"\1_l"),
    (r"^r_(.*)$", r"l_\1"),
    (r"^R_(.*)$", r"L_\1"),
    (r"^(.*)right(.*)$", r"\1left\2"),
    (r"^(.*)Right(.*)$", r"\1Left\2"),
]


def mirror_pairs(names: list[str]) -> list[tuple[int, int]]:
    """Index pairs (right, left) of bodies whose names differ only by a side marker."""
    index = {n: i for i, n in enumerate(names)}
    pairs = []
    for i, n in enumerate(names):
        for pat, rep in _SIDES:
            if re.match(pat, n):
                other = re.sub(pat, rep, n)
                if other in index and other != n:
                    pairs.append((i, index[other]))
                    break
    return pairs


def _mirror(robot: Robot, pairs) -> tuple[np.ndarray, float]:
    """Sagittal plane (unit normal n, offset c: n·p = c) from the mirrored links at q = 0."""
    names = robot.body_names
    q0 = np.zeros((1, robot.nq))
    p = {names[b]: robot.link_poses(q0, names[b])[1][0] for pair in pairs for b in pair}
    diff = sum(p[names[j]] - p[names[i]] for i, j in pairs)
    if np.linalg.norm(diff) < 1e-9:
        raise SescidError("symmetric: the mirrored bodies' frames coincide; no sagittal plane")
    n = diff / np.linalg.norm(diff)
    c = float(np.mean([n @ (p[names[i]] + p[names[j]]) / 2 for i, j in pairs]))
    for i, j in pairs:
        pr, pl = p[names[i]], p[names[j]]
        if np.linalg.norm(pl - 2 * (n @ pl - c) * n - pr) > 1e-3:
            raise SescidError(
                f"symmetric: {names[i]} and {names[j]} are not mirror images at the zero pose "
                "(their frames differ by > 1 mm after reflection)"
            )
    return n, c


# --- the linear map π → r ---------------------------------------------------------------
def sesc_map(robot: Robot) -> np.ndarray:
    """K (3N, 4N) with vec(r) = K · [m/M, vec(h)/(M ℓ)] for ℓ = 0.1 m (m kg, h = m c kg·m)."""
    bodies = robot.model.bodies
    n = len(bodies)
    k = np.zeros((3 * n, 4 * n))
    for i in range(n):
        k[3 * i : 3 * i + 3, n + 3 * i : n + 3 * i + 3] = _ELL * np.eye(3)
    for j in range(n):  # mass of j moves r[parent(a)] by t_a for every ancestor-or-self a ≠ root
        a = j
        while bodies[a].parent >= 0:
            par = bodies[a].parent
            k[3 * par : 3 * par + 3, j] += bodies[a].trans_const
            a = par
    return k


# --- solver -----------------------------------------------------------------------------
def _solve_qp(p_mat, q_vec, a_eq, b_eq, a_in, b_in, what: str):
    import clarabel
    import scipy.sparse as sp

    a = sp.csc_matrix(np.vstack([a_eq, a_in]))
    b = np.concatenate([b_eq, b_in])
    cones = [clarabel.ZeroConeT(len(b_eq)), clarabel.NonnegativeConeT(len(b_in))]
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = 1e-10
    settings.tol_feas = 1e-10
    settings.max_iter = 500
    solver = clarabel.DefaultSolver(
        sp.triu(sp.csc_matrix(p_mat)).tocsc(), q_vec, a, b, cones, settings
    )
    sol = solver.solve()
    status = str(sol.status)
    if "Infeasible" in status:
        raise SolverError(
            f"{what}: the constraints are infeasible (total mass, mass floor, CoM boxes and "
            "symmetry cannot all hold); loosen the floor or the boxes"
        )
    if "Solved" not in status:
        raise SolverError(f"{what}: the QP solver stopped with status {status}")
    return np.asarray(sol.x), status, int(sol.iterations)


def consistent_from_fit(
    fit: Fit,
    *,
    total_mass: float | None = None,
    mass_floor: float = 0.0,
    symmetric: bool = False,
    boxes: dict[str, tuple] | None = None,
    box_margin: float | None = None,
    com_scale: float = COM_SCALE,
    fit_tol: float = FIT_TOL,
    prior_std: float | None = None,
    spread: str = "uniform",
) -> Fit:
    """Masses and CoMs that reproduce ``fit``'s identified directions (see the module doc).

    ``total_mass`` kg (default: the URDF's), ``mass_floor`` kg lower bound on every body's mass,
    ``symmetric`` mirrored bodies equal, ``boxes``/``box_margin`` see ``body_boxes``,
    ``com_scale`` m and ``fit_tol`` m tune the closest-to-CAD step. ``prior_std`` (relative,
    e.g. 0.1): instead of the two steps, one QP trading the data fit against the CAD deviation
    as a Gaussian prior of that relative mass std (CoM std ``com_scale·prior_std``), with the
    noise σ from the fit — plausible masses from noisy data, at some CoP residual. Returns a
    new Fit (method "consistent") with r computed from the masses and CoMs (``fit.inertials``).
    """
    robot = fit.robot
    names = robot.body_names
    nb = len(names)
    m_cad = robot.masses
    check_total_mass(robot, total_mass)
    big_m = robot.total_mass if total_mass is None else float(total_mass)
    if not (math.isfinite(mass_floor) and mass_floor >= 0):
        raise SescidError(f"mass floor must be a finite mass ≥ 0 kg, got {mass_floor}")
    frame = np.array([b.frame_only for b in robot.model.bodies], dtype=bool)
    n_massive = int(nb - frame.sum())
    if mass_floor * n_massive > big_m:
        raise SescidError(
            f"mass floor {mass_floor} kg × {n_massive} bodies = {mass_floor * n_massive:.4g} kg "
            f"exceeds the total mass {big_m:.4g} kg"
        )
    if not (math.isfinite(com_scale) and com_scale > 0):
        raise SescidError(f"com_scale must be a positive length in m, got {com_scale}")
    if prior_std is not None and not (math.isfinite(prior_std) and prior_std > 0):
        raise SescidError(f"prior std must be a positive relative deviation, got {prior_std}")
    if not (math.isfinite(fit_tol) and fit_tol > 0):
        raise SescidError(f"fit_tol must be a positive length in m, got {fit_tol}")
    box_list = body_boxes(robot, boxes, box_margin)
    pairs = mirror_pairs(names) if symmetric else []
    if symmetric and not pairs:
        raise SescidError(
            "symmetric: no left/right body pairs found (names like *_R/*_L, r_*/l_*, …)"
        )
    t0 = time.perf_counter()

    # Data term in whitened units: u = c S Vᵀ (K x − r̂) with c chosen so that ‖u‖² is the
    # increase of the mean squared CoP residual in mm². For a weighted fit, S carries the row
    # weights; their mean w̄ = (weighted RSS)/(RSS) is read off sigma_hat (weighted) and rms (m)
    # (taken as 1 for a noise-free fit, whose residuals are round-off).
    basis = fit.basis
    p = basis.shape[1]
    sv = fit.singular_values[:p]
    n_rows = max(fit.n_rows, 1)
    dof = fit.n_rows - fit.rank
    w_bar = 1.0
    if dof > 0 and math.isfinite(fit.sigma_hat) and math.isfinite(fit.rms) and fit.rms > 1e-12:
        w_bar = fit.sigma_hat**2 * dof / (fit.rms**2 * n_rows)
        w_bar = w_bar if math.isfinite(w_bar) and w_bar > 0 else 1.0
    scale_u = 1e3 / math.sqrt(n_rows * w_bar)
    kmat = sesc_map(robot)
    d_mat = scale_u * (sv[:, None] * basis.T) @ kmat  # (p, 4N)
    e_vec = scale_u * sv * (basis.T @ fit.r.reshape(-1))
    nx = 4 * nb
    nv = nx + p

    # Equalities.
    eq_rows = [np.hstack([-d_mat, np.eye(p)])]
    eq_rhs = [-e_vec]
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
        normal, offset = _mirror(robot, pairs)
        s_lin = np.eye(3) - 2 * np.outer(normal, normal)
        rot, org = robot.forward(np.zeros((1, robot.nq)))
        rot, org = rot[0], org[0]
        for i, j in pairs:  # world first moments at q = 0: ℓ R h̃ + o m̃
            rows = np.zeros((4, nv))
            rows[0, i], rows[0, j] = 1.0, -1.0
            rows[1:, i] = org[i] / _ELL
            rows[1:, nb + 3 * i : nb + 3 * i + 3] = rot[i]
            rows[1:, j] = -(s_lin @ org[j] + 2 * offset * normal) / _ELL
            rows[1:, nb + 3 * j : nb + 3 * j + 3] = -s_lin @ rot[j]
            eq_rows.append(rows)
            eq_rhs.append(np.zeros(4))
    a_eq, b_eq = np.vstack(eq_rows), np.concatenate(eq_rhs)

    # Inequalities (A x ≤ b): mass floor, then CoM boxes.
    in_rows, in_rhs = [], []
    floor_rows = np.zeros((nb, nv))
    floor_rows[:, :nb] = -np.eye(nb)
    in_rows.append(floor_rows)
    in_rhs.append(np.where(frame, 0.0, -mass_floor / big_m))
    for i, box in enumerate(box_list):
        for a in range(3):
            col = nb + 3 * i + a
            upper = np.zeros(nv)
            upper[col], upper[i] = 1.0, -box.hi[a] / _ELL
            lower = np.zeros(nv)
            lower[col], lower[i] = -1.0, box.lo[a] / _ELL
            in_rows += [upper[None], lower[None]]
            in_rhs += [np.zeros(1), np.zeros(1)]
    a_in, b_in = np.vstack(in_rows), np.concatenate(in_rhs)

    # Closeness to CAD (scaled to the total mass): ‖w ⊙ (x − x_cad)‖².
    if spread not in ("uniform", "data"):
        raise SescidError(f"spread must be 'uniform' or 'data', got {spread!r}")
    # CAD target: masses scaled to M ("uniform"), or as they are ("data": the sum constraint
    # and the data term place the weighed difference, the prior spreads only what is left)
    m_prior = m_cad * (big_m / m_cad.sum()) if spread == "uniform" else m_cad.copy()
    m_bar = np.maximum(m_prior, big_m / (10 * nb)) / big_m
    x_cad = np.concatenate([m_prior / big_m, (m_prior[:, None] * model_coms(robot)).ravel()])
    x_cad[nb:] /= big_m * _ELL
    w = np.concatenate([1 / m_bar, np.repeat(_ELL / (m_bar * com_scale), 3)])
    p_cad = np.zeros((nv, nv))
    p_cad[:nx, :nx] = 2 * np.diag(w**2)
    q_cad = np.zeros(nv)
    q_cad[:nx] = -2 * w**2 * x_cad
    p_data = np.zeros((nv, nv))
    p_data[nx:, nx:] = 2 * np.eye(p)

    if prior_std is not None:  # one QP: Gaussian prior on the deviations (MAP in π)
        sigma = fit.sigma_hat / math.sqrt(w_bar) if math.isfinite(fit.sigma_hat) else fit.rms
        lam = (sigma * 1e3 / math.sqrt(n_rows)) ** 2 / prior_std**2  # σ in m, as ‖u‖² in mm²
        x2, status, it = _solve_qp(
            p_data + lam * p_cad, lam * q_cad, a_eq, b_eq, a_in, b_in, "consistent fit"
        )
        statuses, iterations = [status], [it]
    else:
        # Stage 1: best data fit.
        x1, status1, it1 = _solve_qp(p_data, np.zeros(nv), a_eq, b_eq, a_in, b_in, "consistent fit")
        u_star = x1[nx:]
        # Stage 2: closest to CAD among the near-optimal fits.
        delta = fit_tol * 1e3 / math.sqrt(max(p, 1))
        band = np.zeros((2 * p, nv))
        band[:p, nx:] = np.eye(p)
        band[p:, nx:] = -np.eye(p)
        a_in2 = np.vstack([a_in, band])
        b_in2 = np.concatenate([b_in, u_star + delta, -(u_star - delta)])
        x2, status2, it2 = _solve_qp(
            p_cad, q_cad, a_eq, b_eq, a_in2, b_in2, "consistent fit (CAD step)"
        )
        statuses, iterations = [status1, status2], [it1, it2]
    elapsed = time.perf_counter() - t0

    masses, coms = _tidy(x2[:nx], big_m, mass_floor, box_list, model_coms(robot), pairs, robot)
    r = sesc_vectors(consistent_model(robot, masses, coms))
    du = scale_u * sv * (basis.T @ (r - fit.r).reshape(-1))
    d_rss = float(du @ du) * n_rows * 1e-6  # extra residual sum of squares vs the fit, m²
    return _make_fit(
        fit,
        r,
        masses,
        coms,
        box_list,
        pairs,
        d_rss,
        {
            "total_mass": big_m,
            "mass_floor": mass_floor,
            "symmetric": bool(symmetric),
            "com_scale": com_scale,
            "fit_tol": fit_tol,
            "prior_std": prior_std,
            "solver_status": statuses,
            "solver_iterations": iterations,
            "solve_time": elapsed,
        },
    )


def model_coms(robot: Robot) -> np.ndarray:
    """(N, 3) CAD CoMs of the bodies in their frames, m."""
    return np.array([b.com for b in robot.model.bodies])


def _tidy(x, big_m, floor, box_list, com_cad, pairs, robot):
    """Solver output → masses (kg) and CoMs (m, body frames) meeting the constraints exactly."""
    nb = len(box_list)
    frame = np.array([b.frame_only for b in robot.model.bodies], dtype=bool)
    masses = np.where(frame, 0.0, np.maximum(x[:nb] * big_m, floor))
    h = x[nb:].reshape(nb, 3) * big_m * _ELL
    lo = np.array([b.lo for b in box_list])
    hi = np.array([b.hi for b in box_list])
    tiny = masses <= 1e-12 * big_m
    coms = np.where(tiny[:, None], com_cad, h / np.where(tiny, 1.0, masses)[:, None])
    if pairs:  # make mirrored pairs exact mirror images (the solver meets them to ~1e-10)
        normal, offset = _mirror(robot, pairs)
        rot, org = robot.forward(np.zeros((1, robot.nq)))
        rot, org = rot[0], org[0]
        for i, j in pairs:
            m = 0.5 * (masses[i] + masses[j])
            pi = org[i] + rot[i] @ coms[i]
            pj = org[j] + rot[j] @ coms[j]
            pj_m = pj - 2 * (normal @ pj - offset) * normal
            pi_new = 0.5 * (pi + pj_m)
            pj_new = pi_new - 2 * (normal @ pi_new - offset) * normal
            masses[i] = masses[j] = m
            coms[i] = rot[i].T @ (pi_new - org[i])
            coms[j] = rot[j].T @ (pj_new - org[j])
    coms = np.clip(coms, lo, hi)
    masses *= big_m / masses.sum()
    return masses, coms


def consistent_model(robot: Robot, masses: np.ndarray, coms: np.ndarray):
    """The robot's RobotModel with new body masses (N,) kg and CoMs (N, 3) m (body frames)."""
    bodies = [
        dataclasses.replace(b, mass=float(m), com=np.asarray(c, dtype=float).copy())
        for b, m, c in zip(robot.model.bodies, masses, coms, strict=True)
    ]
    return dataclasses.replace(robot.model, bodies=bodies)


def _make_fit(src: Fit, r, masses, coms, box_list, pairs, d_rss, info) -> Fit:
    robot = src.robot
    names = robot.body_names
    model = robot.model
    big_m = info["total_mass"]
    active = []
    com_link = np.empty((len(names), 3))
    for i, name in enumerate(names):
        x = model.link_frames[model.bodies[i].name][1]
        com_link[i] = x[:3, :3].T @ (coms[i] - x[:3, 3])
        box = box_list[i]
        faces = [
            f"{'xyz'[a]}{side}"
            for a in range(3)
            for side, dist in (("-", coms[i][a] - box.lo[a]), ("+", box.hi[a] - coms[i][a]))
            if dist <= _ACTIVE_M and masses[i] > _ACTIVE_KG * big_m
        ]
        if not model.bodies[i].frame_only and masses[i] - info["mass_floor"] <= _ACTIVE_KG * big_m:
            active.append(f"{name}: mass at floor")
        active += [f"{name}: CoM on box face {f}" for f in faces]
    rms = math.sqrt(src.rms**2 + d_rss / max(src.n_rows, 1)) if math.isfinite(src.rms) else src.rms
    dof = src.n_rows - src.rank
    sigma_hat = math.sqrt(rms**2 * src.n_rows / dof) if dof > 0 and math.isfinite(rms) else math.nan
    base = tuple(
        dataclasses.replace(
            c, value=float(sum(coef * r[names.index(b), "xyz".index(a)] for b, a, coef in c.terms))
        )
        for c in src.base
    )
    inertials = BodyInertials(
        masses=np.asarray(masses, dtype=float),
        coms=np.asarray(coms, dtype=float),
        coms_link=com_link,
        box_lo=np.array([b.lo for b in box_list]),
        box_hi=np.array([b.hi for b in box_list]),
        box_source=[b.source for b in box_list],
        active_constraints=active,
        mirror_pairs=[[names[i], names[j]] for i, j in pairs],
        source_method=src.method_label,
        source_rms=src.rms,
        cop_rss_increase=d_rss,
        cad_masses=robot.masses,
        grown_boxes=[names[i] for i, b in enumerate(box_list) if b.grown],
        **info,
    )
    return dataclasses.replace(
        src,
        r=r,
        method="consistent",
        base=base,
        inertials=inertials,
        rms=rms,
        sigma_hat=sigma_hat,
        mae=math.nan,
    )


def fit_inertials(fit: Fit) -> tuple[np.ndarray, np.ndarray]:
    """Body masses (N,) kg and CoMs (N, 3) m (body frames) held by a consistent fit."""
    b = fit.inertials
    if b is None:
        raise SescidError(
            f"this {fit.method} fit has no body masses; run the consistent step first "
            "(sescid.consistent_from_fit)"
        )
    masses, coms = np.asarray(b.masses, dtype=float), np.asarray(b.coms, dtype=float)
    if coms.shape != (len(fit.robot.body_names), 3) or masses.shape != (coms.shape[0],):
        raise SescidError("the fit's body masses/CoMs do not match the robot's bodies")
    if not (np.all(np.isfinite(masses)) and np.all(masses >= 0) and np.all(np.isfinite(coms))):
        raise SescidError("the fit's body masses/CoMs must be finite, masses ≥ 0 kg")
    return masses, coms
