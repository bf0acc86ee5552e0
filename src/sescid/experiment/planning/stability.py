"""Static stability and ground clearance of candidate poses.

A pose is stable when the model's CoP lies inside a rectangle around the support-frame origin:
the profile's CoP box (the OP2: the paper's ±23 mm), or the sole rectangle shrunk by a margin.
It is ground-clear when every collision capsule of a body other than the support body is above
the floor (z = 0 of the support frame) and the free sole's corners above ``clearance``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ...errors import SescidError
from ...robot import Robot
from .collision import Capsules

#: m, CoP box half-width for a robot whose profile gives neither a CoP box nor a sole size
FALLBACK_COP_BOX = 0.023


DEFAULT_CLEARANCE = 0.005  #: m, free sole corners above the ground


def cop_half_extents(
    robot: Robot,
    cop_box: float | tuple[float, float] | None = None,
    margin: float | None = None,
    sole_size: tuple[float, float] | None = None,
) -> np.ndarray:
    """(2,) half-extents [m] of the allowed CoP rectangle around the support-frame origin.

    ``margin`` given: the sole rectangle (``sole_size``; the profile's by default) shrunk by it;
    otherwise the box ``cop_box`` (a half-width, or (x, y) half-widths; default the profile's,
    else ``FALLBACK_COP_BOX``).
    """
    if margin is not None:
        sole_size = sole_size or robot.profile.sole_size
        if sole_size is None:
            raise SescidError("a support-polygon margin needs the sole size (sole_size)")
        half = np.asarray(sole_size, dtype=float) / 2 - margin
        what = f"sole {sole_size[0]:g} x {sole_size[1]:g} m shrunk by {margin:g} m"
    else:
        if cop_box is None:
            cop_box = robot.profile.cop_box or FALLBACK_COP_BOX
        half = np.broadcast_to(np.asarray(cop_box, dtype=float), (2,)).copy()
        what = f"CoP box {cop_box}"
    if not np.all(np.isfinite(half)) or np.any(half <= 0):
        raise SescidError(f"{what} leaves no room for the CoP")
    return half


def stable_mask(robot: Robot, q, half_extents) -> tuple[np.ndarray, np.ndarray]:
    """(mask (n,), cop (n, 2) [m]): model CoP strictly inside the rectangle ±half_extents."""
    cop = robot.cop(q)
    return np.all(np.abs(cop) < np.asarray(half_extents), axis=1), cop


def free_sole(robot: Robot) -> str | None:
    """The sole frame of the free foot (the profile's other sole), or None if not known."""
    return robot.profile.free_sole.get(robot.support)


def sole_corners(robot: Robot, q: ArrayLike, sole: str, sole_size: ArrayLike) -> np.ndarray:
    """(n, 4, 3) corners [m] of the sole rectangle of frame ``sole`` in the support frame."""
    rot, pos = robot.link_poses(q, sole)
    hx, hy = np.asarray(sole_size, dtype=float) / 2
    local = np.array([[hx, hy, 0.0], [hx, -hy, 0.0], [-hx, hy, 0.0], [-hx, -hy, 0.0]])
    return pos[:, None, :] + np.einsum("nij,cj->nci", rot, local)


def ground_clear_mask(
    robot: Robot,
    q: np.ndarray,
    cap: Capsules,
    rot: np.ndarray,
    org: np.ndarray,
    clearance: float,
    sole_size: ArrayLike | None = None,
) -> np.ndarray:
    """(n,) True where all non-support capsules are above z = 0 and the free sole's corners
    (the profile's other sole, of ``sole_size``, default the profile's) above ``clearance``
    [m]."""
    n = rot.shape[0]
    ok = np.ones(n, dtype=bool)
    moving = cap.body != 0
    if moving.any():
        w0, w1 = cap.world(rot, org)
        low = np.minimum(w0[..., 2], w1[..., 2]) - cap.radius
        ok &= np.all(low[:, moving] > 0.0, axis=1)
    free = free_sole(robot)
    sole_size = sole_size or robot.profile.sole_size
    if free is not None and sole_size is not None:
        ok &= np.all(sole_corners(robot, q, free, sole_size)[..., 2] > clearance, axis=1)
    return ok
