"""Both feet flat on the floor: the closed chain of double support, closed by inverse kinematics.

The tree stays rooted at the reference foot's sole (the support frame, z up, the floor at
``Robot.floor``). The free foot (``Robot.free_sole``) carries a *sole frame*: origin at its
sole's centre, axes those of the support frame at the zero pose (the free sole's rectangle lies
level there). Standing on both feet, that frame must sit on the floor plane with its z axis up,
at a placement (x, y, yaw ψ) on the floor: six equations in the joints of the loop, the joints
on the path from the support body to the free foot (both legs). ``close_chain`` solves them by
Newton's method, vectorised across poses: each step the minimum-norm change
Δq = −Jᵀ (J Jᵀ + λ I)⁻¹ e of the loop's joints, e the free sole frame's position error and
rotation error (the skew part of R R_targetᵀ, sin θ times its axis: the rotation vector to
first order), J its geometric Jacobian (each loop joint turns the foot about its world axis
through its body's origin); a step changes a joint by at most ``MAX_STEP``
(``closure_kernels``: one compiled pass per step, the same bits on every CPU). A pose stops
once converged (``CLOSE_TOL``, and within 60° of the target's orientation); those that do not
converge within ``NEWTON_STEPS`` are reported as not closed. The other joints keep their
angles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.errors import SescidError
from sescid.robot import Robot

NEWTON_STEPS = 30  #: Newton steps at most
#: m and rad: a pose is closed when the free sole frame is this near its placement (position and
#: rotation vector, every component)
CLOSE_TOL = 1e-12
MAX_STEP = 0.3  #: rad, largest change of a joint per Newton step
_DAMP = 1e-12  #: m², damping λ of J Jᵀ (near-singular legs, a stretched knee)


@dataclass(frozen=True)
class Loop:
    """The closed chain of a robot on both feet (module docstring)."""

    free: str  #: the free foot's sole link (``Robot.free_sole``)
    body: int  #: the free foot's body
    rot: np.ndarray  #: (3, 3) the free sole frame's axes in its body's frame
    centre: np.ndarray  #: (3,) the free sole frame's origin (the sole's centre) in its body, m
    size: tuple[float, float]  #: the free sole's length and width, m
    path: np.ndarray  #: (k,) bodies from the support body (excluded) to the free foot
    cols: np.ndarray  #: (c,) q columns of the loop's joints
    nominal: np.ndarray  #: (2,) x, y [m] of the free sole frame at the zero pose (yaw 0)
    floor: float  #: m, the floor's height in the support frame


def loop_of(robot: Robot) -> Loop:
    """The double-support loop of ``robot`` standing on its support sole; SescidError when its
    free foot is unknown or no joint moves it."""
    sole = robot.free_sole
    if sole is None or sole.body <= 0 or min(sole.size) <= 0:
        raise SescidError(
            f"{robot.name}: double support needs the other foot's sole, and none is known for "
            f"'{robot.support}' (a profile's free_sole, or a foot found from the geometry)"
        )
    rot0, org0 = robot.forward(np.zeros((1, robot.nq)))
    b = sole.body
    frame = rot0[0, b].T  # support-frame axes at the zero pose, in the body's frame
    path = []
    x = b
    while x > 0:
        path.append(x)
        x = robot.model.bodies[x].parent
    path_arr = np.array(path[::-1], dtype=np.int64)
    cols = sorted({int(robot.tree.jcol[p]) for p in path_arr if robot.tree.jcol[p] >= 0})
    if not cols:
        raise SescidError(f"{robot.name}: no joint moves the free foot '{sole.link}'")
    pos = org0[0, b] + rot0[0, b] @ sole.centre
    nominal = pos[:2].copy()
    return Loop(
        sole.link, b, frame, np.asarray(sole.centre, dtype=float), sole.size, path_arr,
        np.array(cols, dtype=np.int64), nominal, robot.floor,
    )  # fmt: skip


def free_sole_frame(
    robot: Robot, loop: Loop, q: np.ndarray, fk: tuple[np.ndarray, np.ndarray] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (n, 3, 3) and origin (n, 3) [m] of the free sole frame in the support frame at
    poses q (n, nq) [rad]; ``fk``: ``robot.forward(q)`` already computed."""
    rot, org = robot.forward(q) if fk is None else fk
    rb = rot[:, loop.body]
    return rb @ loop.rot, org[:, loop.body] + rb @ loop.centre


def placements(loop: Loop, n: int, rng: np.random.Generator, half: np.ndarray) -> np.ndarray:
    """(n, 4) placements x, y [m], cos ψ, sin ψ of the free sole on the floor: uniform within
    ``half`` = (Δx [m], Δy [m], Δψ [rad]) of its zero-pose placement; the yaw through
    t = tan(ψ / 2) uniform (cos ψ = (1 − t²)/(1 + t²), sin ψ = 2t/(1 + t²): exact arithmetic,
    the same bits on every CPU)."""
    u = rng.uniform(-1.0, 1.0, (n, 3))
    t = u[:, 2] * math.tan(float(half[2]) / 2)
    d = 1.0 + t * t
    x = loop.nominal[0] + u[:, 0] * half[0]
    y = loop.nominal[1] + u[:, 1] * half[1]
    return np.stack([x, y, (1.0 - t * t) / d, 2.0 * t / d], axis=1)


def close_chain(
    robot: Robot, loop: Loop, q: np.ndarray, target: np.ndarray, steps: int = NEWTON_STEPS
) -> tuple[np.ndarray, np.ndarray]:
    """(q (n, nq), closed (n,)): the loop's joints of poses q (n, nq) [rad] moved by Newton's
    method until the free sole frame sits at ``target`` (n, 4: x, y [m], cos ψ, sin ψ) on the
    floor (module docstring); ``closed`` where it converged to ``CLOSE_TOL``."""
    from sescid.planning.feasibility.closure_kernels import newton_kernel

    q = np.array(q, dtype=float, copy=True).reshape(-1, robot.nq)
    target = np.ascontiguousarray(target, dtype=float).reshape(-1, 4)
    tree = robot.tree
    col_of = -np.ones(len(tree.jcol), dtype=np.int64)
    for b in loop.path:
        if tree.jcol[b] >= 0:
            col_of[b] = int(np.searchsorted(loop.cols, tree.jcol[b]))
    axis = np.ascontiguousarray(tree.axis * tree.coef[:, None])
    active = np.arange(len(q))
    closed = np.zeros(len(q), dtype=bool)
    for k in range(steps + 1):
        if not len(active):
            break
        rot, org = robot.forward(q[active])
        m = len(active)
        err, step, up = np.empty((m, 6)), np.empty((m, len(loop.cols))), np.empty(m)
        newton_kernel(rot, org, loop.body, loop.rot, loop.centre, loop.path, col_of, axis,
                target[active], loop.floor, _DAMP, err, step, up)  # fmt: skip
        done = np.all(np.abs(err) <= CLOSE_TOL, axis=1) & (up > 2.0)
        closed[active[done]] = True
        keep = ~done & np.all(np.isfinite(step), axis=1)
        if k == steps:
            break
        active, step = active[keep], step[keep]
        q[active[:, None], loop.cols[None, :]] += np.clip(step, -MAX_STEP, MAX_STEP)
    return q, closed
