"""The quadratic programs of the consistent step: the linear map π → r and the solver."""

from __future__ import annotations

import numpy as np

from sescid.errors import SolverError
from sescid.robot import Robot
from sescid.sesc import sesc_matrix

#: default CoM deviation that costs as much as a 100 % mass change in the closest-to-CAD step, m
COM_SCALE = 0.02
#: default tolerance on the CoP RMS when choosing the closest-to-CAD solution, m
FIT_TOL = 1e-7
#: internal length unit of the first moments h (m), to keep the QP well scaled
H_UNIT = 0.1


def sesc_map(robot: Robot) -> np.ndarray:
    """K (3N, 4N) with vec(r) = K · [m/M, vec(h)/(M ℓ)] for ℓ = 0.1 m (m kg, h = m c kg·m):
    ``sesc_matrix`` with the first moments in units of ℓ."""
    k = sesc_matrix(robot.model)
    k[:, len(robot.model.bodies) :] *= H_UNIT
    return k


def solve_qp(p_mat, q_vec, a_eq, b_eq, a_in, b_in, what: str):
    """Min ½xᵀPx + qᵀx s.t. A_eq x = b_eq, A_in x ≤ b_in (Clarabel): x, status, iterations."""
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
