"""The consistent step of a MAP fit: masses and first moments whose SESC vectors equal the fit's
exactly, closest to CAD in the metric of the fit's own prior.

A MAP fit determines every direction of vec(r) (the prior fills what the data leave), so its
masses are not a compromise: every r is reachable for any masses (a body's first moment h_i
enters only its own r_i), and among the (m, h) with K·[m/M, h/(Mℓ)] = vec(r̂) and Σ m = M the
step takes the one closest to CAD in the per-body prior's metric (mass std ∝ m̄_j = m_j + M/(10N),
first-moment std ∝ m̄_j·ℓ_c, ``solvers.map_prior.body_prior``) under the mass floor, the
CoM boxes and the mirror pairs. Without active constraints that is the posterior mean in body
parameters of the fit's "bodies" prior, so a body the data never see keeps CAD's values.
After the solve the first moments are recomputed from the masses in closed form,
h_i = M r̂_i − Σ_j K_m[i, j] m_j, so the exported model's CoM equals ``fit.predict_com`` to
round-off (not to the solver's tolerance).

A massive body's mass stays within ``MASS_SIGMAS`` prior standard deviations of CAD's (the
fit's own uncertainty on it; a body held there is named). When the boxes then make r̂
unreachable, they become soft (a slack per face, costing ``SOFT_BOX``): a CoM leaves its box
only as far as r̂ demands and is named (``BodyInertials.notes``), never silently moved; when
even that fails (the Σ m = M the fit did not impose moves the masses), the band goes and every
body beyond it is named.
"""

from __future__ import annotations

import math

import numpy as np

from sescid.errors import SolverError
from sescid.estimation.result.fit import Fit
from sescid.estimation.solvers.consistent.boxes import Box
from sescid.estimation.solvers.consistent.qp import H_UNIT, sesc_map, solve_qp
from sescid.sesc import sesc_matrix

#: a body mass beyond this many prior standard deviations of CAD's is reported
MASS_SIGMAS = 3.0
#: a mass change smaller than this (relative to CAD's) is not reported, whatever its z-score
MATERIAL = 0.01
#: a body whose parameters carry less than this share of the largest data information is
#: "not determined by the data"
UNSEEN_RTOL = 1e-10
#: weight (per m of r, relative to the CAD term's unit) of a frame-only body's r mismatch: its
#: r follows from the masses alone, and a MAP prior leaves it reachable only to round-off
FRAME_WEIGHT = 1e7
#: cost of a box slack when the boxes cannot all hold, relative to the CAD term's unit
SOFT_BOX = 1e6


def unseen_bodies(fit: Fit) -> np.ndarray:
    """(N,) bool: bodies whose mass and first moment the fit's data carry no information on
    (every direction of vec(r) they move is outside the data's identified subspace)."""
    robot = fit.robot
    nb = len(robot.body_names)
    if fit.bodies is not None:  # pooled stances: information over x = [m, h] directly
        info = np.abs(np.asarray(fit.bodies.information, dtype=float))
        per = np.array([info[j, j] + sum(info[nb + 3 * j + a, nb + 3 * j + a] for a in range(3))
                        for j in range(nb)])  # fmt: skip
    else:
        p = max(int(fit.rank), 0)
        g = (fit.singular_values[:p, None] * fit.basis[:, :p].T) @ sesc_map(robot)
        cols = np.abs(g).max(axis=0) if p else np.zeros(4 * nb)
        per = np.maximum(cols[:nb], cols[nb:].reshape(nb, 3).max(axis=1))
    top = float(per.max()) if per.size else 0.0
    return per <= UNSEEN_RTOL * max(top, 1e-300)


def prior_weights(fit: Fit, com_scale: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(w (4N,), m̄ (N,) relative masses, ℓ_c m): the CAD term's weights in the fit's prior
    metric (``body_prior``'s m̄ and CoM scale when the fit has a "bodies" prior)."""
    masses = fit.robot.masses
    big = float(masses.sum())
    m_bar = (masses + big / (10 * masses.size)) / big
    info = fit.map
    ell = com_scale
    if info is not None and info.prior == "bodies" and info.prior_com_std:
        ell = float(info.prior_com_std) / float(info.prior_scale)
    w = np.concatenate([1 / m_bar, np.repeat(H_UNIT / (m_bar * ell), 3)])
    return w, m_bar, ell


def solve_exact(
    fit: Fit,
    big_m: float,
    a_eq_extra: tuple[np.ndarray, np.ndarray],
    bounds: tuple[np.ndarray, np.ndarray],
    floor_only: tuple[np.ndarray, np.ndarray],
    com_scale: float,
):
    """The x = [m/M, h/(Mℓ)] closest to CAD with K x = vec(r̂) (``a_eq_extra``: Σ m, frame-only
    and mirror rows; ``bounds``: floor and boxes as A x ≤ b; ``floor_only``: the floor alone).
    Returns x, statuses, iterations, unseen (N,) bool, boxes dropped (bool)."""
    robot = fit.robot
    nb = len(robot.body_names)
    k = sesc_map(robot)
    r_hat = np.asarray(fit.r, dtype=float).reshape(-1)
    frame = np.repeat([b.frame_only for b in robot.model.bodies], 3)
    a_eq = np.vstack([k[~frame], a_eq_extra[0]])
    b_eq = np.concatenate([r_hat[~frame], a_eq_extra[1]])
    m_cad = robot.masses / float(robot.masses.sum())
    coms = np.array([b.com for b in robot.model.bodies])
    x_cad = np.concatenate([m_cad, (m_cad[:, None] * coms).ravel() / H_UNIT])
    w, _, _ = prior_weights(fit, com_scale)
    p_mat, q_vec = 2 * np.diag(w**2), -2 * w**2 * x_cad
    if frame.any():  # a frame-only body's r follows from the masses: matched in least squares
        kf = k[frame] * FRAME_WEIGHT
        p_mat = p_mat + 2 * kf.T @ kf
        q_vec = q_vec - 2 * kf.T @ (r_hat[frame] * FRAME_WEIGHT)
    unseen = unseen_bodies(fit)
    fixed = np.zeros((4 * int(unseen.sum()), 4 * nb))
    for r, j in enumerate(np.flatnonzero(unseen)):
        cols = [j, nb + 3 * j, nb + 3 * j + 1, nb + 3 * j + 2]
        fixed[4 * r + np.arange(4), cols] = 1.0
    fixed_rhs = fixed @ x_cad
    band = mass_band(fit, com_scale)
    banded = [(bounds, floor_only)]
    if band is not None:  # masses within MASS_SIGMAS prior std of CAD's (massive bodies)
        lo, hi = band
        live = np.flatnonzero(robot.masses > 0)
        rows = np.zeros((2 * live.size, a_eq.shape[1]))
        rows[np.arange(live.size), live] = 1.0
        rows[live.size + np.arange(live.size), live] = -1.0
        rhs_b = np.concatenate([hi[live], -lo[live]])
        with_band = (
            (np.vstack([bounds[0], rows]), np.concatenate([bounds[1], rhs_b])),
            (np.vstack([floor_only[0], rows]), np.concatenate([floor_only[1], rhs_b])),
        )
        banded.insert(0, with_band)
    # the most held first: unseen bodies at CAD, then hard boxes, then the mass band
    tries = [
        (unseen_kept, boxes_hard, limits)
        for limits in banded
        for boxes_hard in (True, False)
        for unseen_kept in ((True, False) if unseen.any() else (False,))
    ]
    last: SolverError | None = None
    for keep_unseen, keep_boxes, (full, hard) in tries:
        eq = np.vstack([a_eq, fixed]) if keep_unseen else a_eq
        rhs = np.concatenate([b_eq, fixed_rhs]) if keep_unseen else b_eq
        try:
            if keep_boxes:
                x, status, it = solve_qp(p_mat, q_vec, eq, rhs, *full, "consistent fit (exact)")
            else:
                x, status, it = _soft_boxes(p_mat, q_vec, eq, rhs, full, hard, nb)
        except SolverError as exc:
            last = exc
            continue
        return x, [status], [it], unseen & keep_unseen, not keep_boxes
    assert last is not None
    raise last


def _soft_boxes(p_mat, q_vec, a_eq, b_eq, bounds, hard, nb: int):
    """The QP with the box rows of ``bounds`` (6N rows after the N floor rows) softened: a
    slack s ≥ 0 per row costing ``SOFT_BOX`` · s² (s in units of ℓ·m/M), so a CoM leaves its box
    only as far as r̂ demands; ``hard``: the rows kept as they are (floor, mass band)."""
    box_a, box_b = bounds[0][nb : 7 * nb], bounds[1][nb : 7 * nb]
    nx = p_mat.shape[0]
    ns = box_a.shape[0]
    p2 = np.zeros((nx + ns, nx + ns))
    p2[:nx, :nx] = p_mat
    p2[nx:, nx:] = 2 * SOFT_BOX * np.eye(ns)
    q2 = np.concatenate([q_vec, np.zeros(ns)])
    nh = hard[0].shape[0]
    a_in2 = np.zeros((nh + 2 * ns, nx + ns))
    a_in2[:nh, :nx] = hard[0]
    a_in2[nh : nh + ns, :nx] = box_a
    a_in2[nh : nh + ns, nx:] = -np.eye(ns)
    a_in2[nh + ns :, nx:] = -np.eye(ns)
    b_in2 = np.concatenate([hard[1], box_b, np.zeros(ns)])
    a_eq2 = np.hstack([a_eq, np.zeros((a_eq.shape[0], ns))])
    what = "consistent fit (exact, soft boxes)"
    x, status, it = solve_qp(p2, q2, a_eq2, b_eq, a_in2, b_in2, what)
    return x[:nx], status, it


def mass_band(fit: Fit, com_scale: float) -> tuple[np.ndarray, np.ndarray] | None:
    """(lo, hi) (N,) relative masses m/M: CAD's ± ``MASS_SIGMAS`` prior standard deviations of
    the fit's "bodies" prior (None for another prior: no mass scale to hold)."""
    info = fit.map
    if info is None or info.prior != "bodies" or not np.isfinite(info.prior_scale):
        return None
    _, m_bar, _ = prior_weights(fit, com_scale)
    cad = fit.robot.masses / float(fit.robot.masses.sum())
    half = MASS_SIGMAS * float(info.prior_scale) * m_bar
    return np.maximum(cad - half, 0.0), cad + half


def exact_parameters(
    fit: Fit, x: np.ndarray, big_m: float, floor: float, frame: np.ndarray, unseen: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Masses (N,) kg from the solver, then CoMs (N, 3) m from r̂ in closed form (see the
    module doc) and the first moments h (N, 3) kg·m r̂ asks for; a massless body keeps CAD's
    CoM. Unseen bodies keep CAD's exactly."""
    robot = fit.robot
    nb = len(robot.body_names)
    cad_m = robot.masses * (big_m / float(robot.masses.sum()))
    masses = np.where(frame, 0.0, np.maximum(x[:nb] * big_m, floor))
    masses = np.where(unseen, cad_m, masses)
    free = ~unseen & ~frame
    if free.any():  # Σ m = M exactly, by the bodies the solver placed
        masses[free] += (big_m - masses.sum()) * masses[free] / masses[free].sum()
    k = sesc_matrix(robot.model)
    h = big_m * np.asarray(fit.r, dtype=float).reshape(-1) - k[:, :nb] @ masses
    h = h.reshape(nb, 3)
    coms_cad = np.array([b.com for b in robot.model.bodies])
    tiny = masses <= 1e-12 * big_m
    coms = np.where(tiny[:, None], coms_cad, h / np.where(tiny, 1.0, masses)[:, None])
    return masses, coms, h


def impossible(fit: Fit, masses: np.ndarray, h: np.ndarray, big_m: float) -> list[str]:
    """Bodies left without mass whose first moment h (N, 3) kg·m the fit's r still needs
    (over 1e-9·M·1 m): no consistent inertia carries a first moment without mass."""
    names = fit.robot.body_names
    bad = (masses <= 1e-12 * big_m) & (np.abs(h).max(axis=1) > 1e-9 * big_m)
    return [
        f"{names[j]}: the fit needs a first moment of {np.abs(h[j]).max():.3g} kg·m on a body "
        "left without mass; no consistent inertia holds it (written massless, so the model's "
        "CoM differs from the fit's there)"
        for j in np.flatnonzero(bad)
    ]


def mass_notes(
    fit: Fit, masses: np.ndarray, big_m: float, com_scale: float, unseen: np.ndarray,
    outside: list[str],
) -> list[str]:  # fmt: skip
    """What the record says about an exact solution: bodies kept at CAD, CoMs outside their
    boxes, masses held ``MASS_SIGMAS`` prior standard deviations from CAD's."""
    names = fit.robot.body_names
    notes = []
    if unseen.any():
        notes.append(
            "not determined by the data, CAD's mass and CoM kept: "
            + ", ".join(n for n, u in zip(names, unseen, strict=True) if u)
        )
    if outside:
        notes.append(
            "the fit's SESC vectors put these CoMs outside their bodies' boxes (no masses "
            "reach them inside): " + ", ".join(outside)
        )
    info = fit.map
    if info is None or info.prior != "bodies":
        return notes
    tau = float(info.prior_scale)
    _, m_bar, _ = prior_weights(fit, com_scale)
    cad = fit.robot.masses * (big_m / float(fit.robot.masses.sum()))
    z = (masses - cad) / (tau * m_bar * big_m)
    material = (cad > 0) & (np.abs(masses - cad) > MATERIAL * cad)
    for j in np.flatnonzero((np.abs(z) > MASS_SIGMAS * (1 - 1e-6)) & material):
        held = "held at" if abs(z[j]) <= MASS_SIGMAS * (1 + 1e-6) else "at"
        notes.append(
            f"{names[j]}: mass {masses[j]:.4g} kg against CAD's {cad[j]:.4g} kg "
            f"({100 * (masses[j] / cad[j] - 1) if cad[j] > 0 else math.inf:+.2g} %) {held} "
            f"{z[j]:+.1f} prior standard deviations (τ = {tau:.3g}; {MASS_SIGMAS:g} is the most "
            "the fit's uncertainty allows): the fit's SESC vectors pull it there, check the data"
        )
    return notes


def outside_boxes(coms: np.ndarray, masses: np.ndarray, box_list: list[Box], names) -> list[str]:
    """Names of massive bodies whose CoM (N, 3) m lies outside its box by over 1 µm."""
    out = []
    for j, (c, box) in enumerate(zip(coms, box_list, strict=True)):
        gap = np.maximum(box.lo - c, c - box.hi).max()
        if masses[j] > 0 and gap > 1e-6:
            out.append(f"{names[j]} ({1e3 * gap:.3g} mm)")
    return out
