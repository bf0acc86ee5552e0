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

from sescid.estimation.solvers.consistent.boxes import (
    FALLBACK_MARGIN,
    Box,
    body_boxes,
    mirror_pairs,
)
from sescid.estimation.solvers.consistent.prior import evidence_prior_std, least_squares_view
from sescid.estimation.solvers.consistent.qp import COM_SCALE, FIT_TOL, H_UNIT, sesc_map
from sescid.estimation.solvers.consistent.record import consistent_model, fit_inertials, model_coms
from sescid.estimation.solvers.consistent.solve import consistent_from_fit

__all__ = [
    "COM_SCALE",
    "FALLBACK_MARGIN",
    "FIT_TOL",
    "H_UNIT",
    "Box",
    "body_boxes",
    "consistent_from_fit",
    "consistent_model",
    "evidence_prior_std",
    "least_squares_view",
    "fit_inertials",
    "mirror_pairs",
    "model_coms",
    "sesc_map",
]
