"""Static stability and ground clearance of candidate poses.

A pose is stable when the model's CoP lies inside a rectangle around the support sole's centre:
the profile's CoP box (the OP2: the paper's ±23 mm), else the middle ``SOLE_BOX_FRACTION`` of the
robot's sole (``Robot.sole``: the profile's, or derived from the foot's geometry), or the sole
rectangle shrunk by a margin. It is ground-clear when every body other than the support body is
above the floor (``Robot.floor``) and the free sole's corners (``Robot.free_sole``) above
``clearance`` (see ``ground``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sescid.errors import SescidError
from sescid.kinematics import Tree, cop_xy, reducible
from sescid.robot import Robot

#: m, CoP box half-width for a robot whose profile gives neither a CoP box nor a sole size
FALLBACK_COP_BOX = 0.023


DEFAULT_CLEARANCE = 0.005  #: m, free sole corners above the ground

#: coarse stability pre-check (``stable_subset``): bodies whose subtree carries more than this
#: fraction of the summed SESC norms, and from how many poses it is worth it
COARSE_SUBTREE = 0.1
COARSE_MIN_POSES = 1_000

#: default CoP box of a robot without a profile CoP box: this fraction of its sole's half-sizes
SOLE_BOX_FRACTION = 0.5


#: m: a support whose sole (as ``model.sole`` derives it: sides below its ``MIN_SOLE`` widened to
#: the foot's extent) is still narrower than this has no sole to stand on
NO_SOLE_BELOW = 0.005


def cop_half_extents(
    robot: Robot,
    cop_box: float | tuple[float, float] | None = None,
    margin: float | None = None,
    sole_size: tuple[float, float] | None = None,
) -> np.ndarray:
    """(2,) half-extents [m] of the allowed CoP rectangle around the support-frame origin.

    ``margin`` given: the sole rectangle (``sole_size``; the robot's sole by default) shrunk by
    it; otherwise the box ``cop_box`` (a half-width, or (x, y) half-widths; default the
    profile's, else ``SOLE_BOX_FRACTION`` of the robot's sole, else ``FALLBACK_COP_BOX``).
    The rectangle is centred on ``robot.sole_centre`` (0 for a sole frame).
    """
    if margin is None and cop_box is None and robot.profile.cop_box is None:
        sole = robot.sole
        if sole is not None:
            if min(sole.size) < NO_SOLE_BELOW:
                raise SescidError(
                    f"the support '{robot.support}' has no sole to stand on (its lowest face is "
                    f"{sole.size[0] * 1e3:.1f} x {sole.size[1] * 1e3:.1f} mm): give --support a "
                    "sole frame, the flat bottom of a foot"
                )
            return SOLE_BOX_FRACTION * np.asarray(sole.size, dtype=float) / 2
    if margin is not None:
        sole_size = sole_size or (robot.sole.size if robot.sole is not None else None)
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


def stable_mask(robot: Robot, q, half_extents, centre=None) -> tuple[np.ndarray, np.ndarray]:
    """(mask (n,), cop (n, 2) [m]): model CoP strictly inside ``centre`` ± half_extents."""
    cop = robot.cop(q)
    off = cop if centre is None else cop - np.asarray(centre, dtype=float)
    return np.all(np.abs(off) < np.asarray(half_extents), axis=1), cop


def stable_subset(
    robot: Robot, q, half_extents, centre=None, coarse: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """(mask (n,), cop (mask.sum(), 2) [m]): ``stable_mask`` with the CoP of the kept poses only.

    Many poses are first rejected by a coarse CoP from the heavy bodies alone
    (``coarse_cop_tree``; ``coarse=False`` skips it): the light bodies move the CoP by at most
    their bound, so a pose whose coarse CoP lies outside the box widened by it is unstable. The
    rest get the whole tree's CoP in one compiled pass (``kinematics.cop_xy``); only poses within
    ``EXACT_BAND`` of the box edge are decided by ``robot.cop``, which also gives the kept poses'
    CoP — so the mask and the CoPs are ``stable_mask``'s.
    """
    q = np.ascontiguousarray(q, dtype=float)
    half = np.asarray(half_extents, dtype=float)
    c = np.zeros(2) if centre is None else np.asarray(centre, dtype=float)
    idx = np.arange(len(q))
    plain = q.ndim == 2 and q.shape[1] == robot.nq and len(q) > 0
    plain = plain and reducible(q)
    # the pre-checks on plain finite poses only; anything else gets stable_mask's checks
    if plain and coarse and len(q) >= COARSE_MIN_POSES:
        tree, r, bound = coarse_cop_tree(robot)
        idx = inside_box(cop_xy(tree, q, r), c, half + bound)
    if plain and len(idx) >= COARSE_MIN_POSES // 10:
        full = cop_xy(robot.tree, q[idx], robot.sesc_vectors())
        keep = inside_box(full, c, half + EXACT_BAND)  # the rest are certainly unstable
        idx = idx[keep]
    ok, cop = stable_mask(robot, q[idx], half, c)
    mask = np.zeros(len(q), dtype=bool)
    mask[idx[ok]] = True
    return mask, cop[ok]


#: m: ``kinematics.cop_xy`` and ``robot.cop`` round differently by ~1e-16 m; poses whose
#: compiled CoP lies farther than this outside the box are unstable by either
EXACT_BAND = 1e-12


def inside_box(xy: np.ndarray, centre: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Indices of the rows of ``xy`` (n, 2) strictly within ``centre`` ± ``half``."""
    dx = np.abs(xy[:, 0] - centre[0]) < half[0]
    dx &= np.abs(xy[:, 1] - centre[1]) < half[1]
    return np.flatnonzero(dx)


def coarse_screen_tree(
    robot: Robot, lo: np.ndarray, width: np.ndarray
) -> tuple[Tree, np.ndarray, float]:
    """``coarse_cop_tree`` for unit draws u ∈ [0, 1)^nq standing for q = lo + width · u: each
    joint's scale and offset folded into the tree (θ = coef·q + off = coef·width·u + coef·lo +
    off, equal to rounding, far below the bound's margin), so draws need not be scaled first."""
    tree, r, bound = coarse_cop_tree(robot)
    moving = tree.jcol >= 0
    coef, off = tree.coef.copy(), tree.off.copy()
    col = tree.jcol[moving]
    coef[moving] = tree.coef[moving] * width[col]
    off[moving] = tree.coef[moving] * lo[col] + tree.off[moving]
    return dataclasses.replace(tree, coef=coef, off=off), r, bound


def coarse_cop_tree(robot: Robot) -> tuple[Tree, np.ndarray, float]:
    """(tree, r, bound): the bodies whose subtree's SESC norms sum to more than
    ``COARSE_SUBTREE`` of the whole (closed under parents) and their SESC vectors; ``bound``
    [m] ≥ how far the other bodies can move the CoP (the sum of their norms, plus rounding)."""
    full, r = robot.tree, robot.sesc_vectors()
    norm = np.linalg.norm(r, axis=1)
    sub = norm.copy()
    for i in range(len(norm) - 1, 0, -1):  # children come after their parents
        sub[full.parent[i]] += sub[i]
    keep = np.flatnonzero(sub > COARSE_SUBTREE * sub[0])
    keep = np.union1d(keep, [0])
    new = -np.ones(len(norm), dtype=np.int64)
    new[keep] = np.arange(len(keep))
    nz = [np.arange(full.nz_ptr[b], full.nz_ptr[b + 1]) for b in keep]
    ptr = np.r_[0, np.cumsum([len(z) for z in nz])].astype(np.int64)
    z = np.concatenate(nz)
    tree = dataclasses.replace(
        full,
        parent=np.array([new[p] if p >= 0 else -1 for p in full.parent[keep]], dtype=np.int64),
        nz_ptr=ptr,
        **{f: getattr(full, f)[keep] for f in ("jcol", "coef", "off", "a0", "a1", "a2", "t")},
        **{f: getattr(full, f)[z] for f in ("nz_k", "nz_j", "nz_a")},
    )
    rest = np.setdiff1d(np.arange(len(norm)), keep)
    bound = float(norm[rest].sum()) + 1e-9 * (1.0 + float(norm.sum()))
    return tree, np.ascontiguousarray(r[keep]), bound


def free_sole(robot: Robot) -> str | None:
    """The free foot's sole link (the profile's other sole, else the mirror-named foot's, see
    ``Robot.free_sole``), or None if not known."""
    sole = robot.free_sole
    return None if sole is None else sole.link
