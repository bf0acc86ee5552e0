"""SESC vectors, the regressor Φ(q) and CoM/CoP prediction.

``CoM(q) = d + Σ_i B_i(q) r_i`` with ``B_i`` the rotation of body i in the support frame and

    r_i = (m_i c_i + Σ_{children ch} M_ch t_ch) / M        [m]

where ``c_i`` is the body's CoM and ``t_ch`` the constant offset of child ``ch``'s frame, both in
body i's frame, and ``M_ch`` the mass carried by the subtree of ``ch``. The CoP of a robot in
static balance on a level floor is the (x, y) of the CoM; with gravity along g (support frame,
not along the sole normal) it is where the gravity line through the CoM meets the sole plane,
``c_xy − c_z g_xy / g_z`` — still linear in r.

Joint torques. With the support link held fixed, the torque an actuator applies to hold the pose
balances the gravity moment of the bodies beyond its joint (away from the support). The bodies
beyond body b's joint carry the first moment ``Σ_{i ∈ sub(b)} m_i (c_i − o_b) = M Σ_{i ∈ sub(b)}
R_i r_i`` about the joint (the SESC vectors carry each subtree's mass times its joint offsets),
so the generalized gravity force on joint column j is

    τ_j = M Σ_{b: joint(b) = j} coef_b ((R_b a_b) × g)ᵀ Σ_{i ∈ sub(b)} R_i r_i            [N·m]

with a_b the joint axis in body b's frame, ``coef_b`` the joint's sign (and mimic multiplier)
and g the gravity vector (m/s²) in the support frame: linear in M·r, the same parameters as the
CoP. The support body's own r never appears (its weight goes to the floor without crossing a
joint), and a body's component along its own joint axis only in its sum with its parent's: the
CoP's structural null space plus the support body's horizontal components.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from sescid.base import G0
from sescid.errors import DataError
from sescid.kinematics import (
    Tree,
    as_poses,
    com_one,
    com_rows,
    regressor,
    torque_rows,
    torque_values,
)
from sescid.model import RobotModel
from sescid.model.sole import subtree_mass


def subtree_masses(model: RobotModel) -> np.ndarray:
    """Mass (kg) carried by each body's subtree, itself included."""
    return subtree_mass([b.parent for b in model.bodies], np.array([b.mass for b in model.bodies]))


def sesc_vectors(model: RobotModel) -> np.ndarray:
    """SESC vectors r (N, 3) in metres, each in its body's frame."""
    msub = subtree_masses(model)
    total = msub[0]
    r = np.array([b.mass * b.com for b in model.bodies])
    for i, b in enumerate(model.bodies):
        if b.parent >= 0:
            r[b.parent] += msub[i] * b.trans_const
    return r / total


def sesc_matrix(model: RobotModel) -> np.ndarray:
    """K (3N, 4N) with vec(r) = K θ / M for the body parameters θ = [m (N); vec(m c) (3N)]
    (kg, kg·m, each body's frame) and M = Σ m: the first moments directly, plus each body's
    mass times its joint offsets for every ancestor that carries it."""
    bodies = model.bodies
    n = len(bodies)
    k = np.zeros((3 * n, 4 * n))
    k[:, n:] = np.eye(3 * n)
    for j in range(n):  # the mass of j moves r[parent(a)] by t_a for every ancestor-or-self a
        a = j
        while bodies[a].parent >= 0:
            par = bodies[a].parent
            k[3 * par : 3 * par + 3, j] += bodies[a].trans_const
            a = par
    return k


def com_from_sesc(
    tree: Tree, q: ArrayLike, r: np.ndarray, rows: tuple[int, ...] = (0, 1, 2)
) -> np.ndarray:
    """CoM[rows] (n, len(rows)) in metres for SESC vectors r (N, 3); rows (0, 1) is the CoP."""
    if type(q) is np.ndarray and q.ndim == 1 and _plain(q) and _plain(r) and r.ndim == 2:
        # one pose, the common case (a controller's query): one compiled call that also checks q
        if rows == (0, 1, 2) or rows == (0, 1):
            com = com_one(tree, q, r, len(rows))
            if com is not None:
                return com
    q = as_poses(q, tree.nq)
    if q.shape[0] == 1:  # one pose: one compiled call, no blocks
        rr = r if _plain(r) else np.ascontiguousarray(r, dtype=float)
        com = com_one(tree, q[0], rr.reshape(-1, 3))
        if com is not None:
            first = tuple(rows) in ((0, 1), (0, 1, 2))  # CoP or CoM: a view, no index array
            return com[:, : len(rows)] if first else com[:, list(rows)]
    k = 2 if tuple(rows) == (0, 1) else 3  # the CoP's rows alone, else all three
    com = com_rows(tree, q, np.asarray(r, dtype=float).reshape(-1, 3), k)
    return com if tuple(rows) in ((0, 1), (0, 1, 2)) else com[:, list(rows)]


def _plain(r) -> bool:
    return type(r) is np.ndarray and r.dtype == np.float64 and r.flags.c_contiguous


def gravity_ratios(gravity, n: int) -> np.ndarray:
    """Per-pose g_xy / g_z (n, 2) of gravity directions (n, 3) in the support frame."""
    g = np.asarray(gravity, dtype=float)
    if g.shape != (n, 3):
        raise DataError(f"gravity: expected shape ({n}, 3) (support frame), got {g.shape}")
    if not np.all(np.isfinite(g)):
        raise DataError(
            f"gravity: non-finite value at pose {int(np.argwhere(~np.isfinite(g))[0, 0])}"
        )
    bad = np.flatnonzero(g[:, 2] >= -0.5 * np.linalg.norm(g, axis=1))
    if bad.size:
        raise DataError(
            f"gravity: pose {bad[0]}: {g[bad[0]].tolist()} does not point down through the sole "
            "(its z must be negative, tilt < 60°)"
        )
    return g[:, :2] / g[:, 2:3]


def tilted_cop(com: np.ndarray, ratios: np.ndarray) -> np.ndarray:
    """CoP (n, 2) where the gravity line through CoM (n, 3) meets z = 0: c_xy − c_z g_xy/g_z."""
    return com[:, :2] - com[:, 2:3] * ratios


def gravity_vectors(gravity: ArrayLike | None, n: int, g0: float = G0) -> np.ndarray:
    """(n, 3) gravity vectors [m/s²] in the support frame: directions (n, 3) scaled to g0, or
    a level support's (0, 0, −g0) when ``gravity`` is None."""
    if gravity is None:
        out = np.zeros((n, 3))
        out[:, 2] = -g0
        return out
    g = np.asarray(gravity, dtype=float)
    gravity_ratios(g, n)  # shape, finiteness, pointing down
    return g * (g0 / np.linalg.norm(g, axis=1, keepdims=True))


def torque_regressor(
    tree: Tree,
    q: ArrayLike,
    cols: ArrayLike,
    gravity: ArrayLike | None = None,
    g0: float = G0,
) -> np.ndarray:
    """Φ_τ (n, J, 3N) [m/s²] with τ[:, j] = M · Φ_τ[:, j] · vec(r) [N·m] for the q columns
    ``cols`` (J,), under gravity (n, 3) directions in the support frame (None: level) of
    magnitude g0 [m/s²]."""
    q = as_poses(q, tree.nq)
    cols = np.asarray(cols, dtype=np.int64).reshape(-1)
    return torque_rows(tree, q, cols, gravity_vectors(gravity, q.shape[0], g0))


def torques(
    tree: Tree,
    q: ArrayLike,
    r: np.ndarray,
    total_mass: float,
    cols: ArrayLike | None = None,
    gravity: ArrayLike | None = None,
    g0: float = G0,
) -> np.ndarray:
    """Holding torques (n, J) [N·m] of the q columns ``cols`` (default: all) for SESC vectors
    r (N, 3) [m] and total mass [kg], under gravity (n, 3) directions (None: level) of
    magnitude g0 [m/s²]."""
    cols = np.arange(tree.nq) if cols is None else np.asarray(cols, dtype=np.int64)
    q = as_poses(q, tree.nq)
    g = gravity_vectors(gravity, q.shape[0], g0)
    return torque_values(tree, q, np.asarray(r, dtype=float), float(total_mass), cols, g)


# --- balance on a line (a wheel axle, an edge) ---------------------------------------
def line_across(line: np.ndarray, gravity: np.ndarray) -> np.ndarray:
    """(n, 3) unit horizontal directions across the line (u × up) for gravity (n, 3)."""
    up = -gravity / np.linalg.norm(gravity, axis=1, keepdims=True)
    n = np.cross(line[None, :], up)
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def line_distance(line: np.ndarray, com: np.ndarray) -> np.ndarray:
    """(n,) distance of CoM points (n, 3) from the line through the origin, m."""
    perp = com - np.outer(com @ line, line)
    return np.linalg.norm(perp, axis=1)


def _tilt_axes(line: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(e_up, e_side): the support frame's z axis perpendicular to the line, and line × e_up."""
    z = np.array([0.0, 0.0, 1.0]) - line[2] * line
    norm = float(np.linalg.norm(z))
    if norm < 1e-6:
        raise ValueError("a support line along the support frame's z axis has no balance tilt")
    e_up = z / norm
    return e_up, np.cross(line, e_up)


def balance_tilt(
    tree: Tree,
    line: np.ndarray,
    q: ArrayLike,
    r: np.ndarray,
    cov: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """The tilt φ (n,) [rad] about the support line (right-handed about ``Robot.line``) that
    balances the robot at poses q (n, nq) for SESC vectors r (N, 3): the support frame turned by
    φ from upright (its z axis vertical) puts the CoM vertically above the line. For a base
    whose IMU is aligned with the support frame and a line along its y axis, φ is the IMU's
    pitch. With ``cov`` (3N, 3N) of vec(r): also its standard error (n,) [rad] (first order)."""
    e_up, e_side = _tilt_axes(line)
    q = as_poses(q, tree.nq)
    com = com_from_sesc(tree, q, r, (0, 1, 2))
    x, z = com @ e_side, com @ e_up
    tilt = -np.arctan2(x, z)
    if cov is None:
        return tilt, None
    phi = regressor(tree, q, (0, 1, 2))  # (n, 3, 3N)
    d2 = np.maximum(x * x + z * z, 1e-300)
    grad_c = (x[:, None] * e_up[None, :] - z[:, None] * e_side[None, :]) / d2[:, None]
    grad = np.einsum("na,nap->np", grad_c, phi)
    var = np.einsum("np,pk,nk->n", grad, cov, grad)
    return tilt, np.sqrt(np.clip(var, 0, None))


def balance_gravity(line: np.ndarray, tilt: ArrayLike) -> np.ndarray:
    """(n, 3) unit gravity directions in the support frame of a robot on a line tilted by
    ``tilt`` (n,) [rad] about it from upright (``balance_tilt``'s convention)."""
    e_up, e_side = _tilt_axes(line)
    t = np.asarray(tilt, dtype=float).reshape(-1)
    up = np.cos(t)[:, None] * e_up[None, :] - np.sin(t)[:, None] * e_side[None, :]
    return -up
