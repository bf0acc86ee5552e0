"""The joint-torque measurement kind: one row per measured joint per pose.

A measured holding torque of joint j (the torque its actuator applies, model sign) is

    τ_j = M Φ_τ,j(q) vec(r) + o_j + s f_j + e,      e ~ N(0, σ_τ²)

with M the total mass (a weigh scale, else the model's), ``Φ_τ`` the torque regressor
(``sesc.torque_regressor``), o_j a constant offset of the joint's torque sensor (always
estimated), and, when each pose says from which side it was reached (``approach`` s = ±1),
f_j ≥ 0 the half-width of the joint's static-friction band: a held torque sits at the edge of
the band on the side it came from. The rows are built in the same reduced coordinates as the
CoP's (``Robot.reduction``): torques see every combination the CoP sees except the support
body's own horizontal components (its intercept columns are zero here).
"""

from __future__ import annotations

import numpy as np

from sescid.estimation.data.measurements import Measurements
from sescid.estimation.result.records import NuisanceWhat
from sescid.kinds import TORQUE
from sescid.robot import Robot
from sescid.sesc import torque_regressor

#: MAP prior standard deviation of a torque sensor's offset and friction band: effectively flat
#: against any held torque of a humanoid joint, N·m
NUISANCE_PRIOR_TORQUE = 100.0


def nuisance_names(m: Measurements) -> list[tuple[NuisanceWhat, str]]:
    """(what, joint) of the torque kind's nuisance columns for these data: an offset per
    measured joint, then a friction band per joint when the approach side is known."""
    out: list[tuple[NuisanceWhat, str]] = [("offset", j) for j in m.tau_joints]
    if m.approach is not None:
        out += [("friction", j) for j in m.tau_joints]
    return out


def torque_columns(
    robot: Robot, m: Measurements, total_mass: float, weighted: bool, g0: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Rows of a validated block as columns: X (P_red + K, n·J) [reduced SESC columns, then the
    nuisance columns of ``nuisance_names``], targets y (n·J,) N·m and square-root weights
    (n·J,) 1/N·m (None: unweighted); g0 the magnitude of gravity [m/s²]. Rows are ordered
    (joint, pose)."""
    assert m.tau is not None
    red = robot.reduction
    n, nj = m.tau.shape
    cols = robot.joint_columns(m.tau_joints)
    phi = torque_regressor(robot.tree, m.q, cols, m.gravity, g0)  # (n, J, 3N)
    nb = len(robot.body_names)
    nr = len(red.rows)
    p_red = red.g.shape[0]
    # reduced columns: Φ_τ[:, j, body i] · u_{i,l}; the support body's intercepts are zero
    body = phi.reshape(n, nj, nb, 3)[:, :, 1:, :]  # (n, J, N−1, 3)
    reduced = np.einsum("njbk,blk->jnbl", body, red.u[1:]) * total_mass  # (J, n, N−1, 2)
    names = nuisance_names(m)
    x = np.zeros((p_red + len(names), nj * n))
    x[nr:p_red] = reduced.reshape(nj * n, p_red - nr).T
    for k in range(nj):  # offsets: 1 on the joint's rows
        x[p_red + k, k * n : (k + 1) * n] = 1.0
    if m.approach is not None:
        for k in range(nj):  # friction: the approach side on the joint's rows
            x[p_red + nj + k, k * n : (k + 1) * n] = m.approach
    y = m.tau.T.reshape(-1)
    sw = None
    if weighted:
        if m.tau_se is None:
            from sescid.errors import DataError

            raise DataError(f"{m.source}: weighted torques need tau_se_<joint> columns")
        sw = 1.0 / m.tau_se.T.reshape(-1)
    return x, y, sw


KIND = TORQUE
