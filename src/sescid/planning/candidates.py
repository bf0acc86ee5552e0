"""Candidate poses: drawn uniformly within the sampling limits, kept when statically stable,
clear of the ground and free of self-collision.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sescid.errors import SescidError
from sescid.kinematics import MAX_ANGLE, cop_xy
from sescid.planning.collision import Capsules, collision_capsules
from sescid.planning.limits import sampling_limits
from sescid.planning.stability import (
    DEFAULT_CLEARANCE,
    coarse_screen_tree,
    cop_centre,
    cop_half_extents,
    ground_clear_mask,
    inside_box,
    stable_subset,
)
from sescid.robot import Robot


@dataclass
class Candidates:
    """Stable, collision-free, ground-clear poses sampled uniformly within ``limits``."""

    q: np.ndarray  #: (n, nq) rad
    cop: np.ndarray  #: (n, 2) model CoP, m
    limits: np.ndarray  #: (nq, 2) sampling limits, rad
    half_extents: np.ndarray  #: (2,) CoP rectangle, m
    n_sampled: int  #: raw poses drawn
    n_stable: int  #: of which statically stable
    n_ground: int  #: of which also clear of the ground
    n_free: int  #: of which also free of self-collision (= accepted, before truncation)
    capsules: Capsules | None = None
    sampler: str = "uniform"  #: "uniform" or "adjusted" (supporting leg moved)
    centre: np.ndarray | None = None  #: (2,) centre of the CoP rectangle, m (None: 0)

    @property
    def acceptance(self) -> float:
        """Fraction of raw uniform poses that are stable, ground-clear and collision free."""
        return self.n_free / max(self.n_sampled, 1)

    def summary(self) -> str:
        """One line: acceptance at each stage and the number accepted."""
        s = max(self.n_sampled, 1)
        kind = (
            "uniform poses"
            if self.sampler == "uniform"
            else "draws (those in self-collision dropped first, then the supporting leg adjusted)"
        )
        return (
            f"{self.n_sampled} {kind}: {self.n_stable / s:.2%} stable, "
            f"{self.n_ground / s:.2%} also ground-clear, {self.n_free / s:.2%} also free of "
            f"self-collision ({self.n_free} accepted)"
        )


def candidates(
    robot: Robot,
    n: int,
    seed: int | np.random.Generator = 0,
    *,
    limits: np.ndarray | None = None,
    half_extents=None,
    clearance: float = DEFAULT_CLEARANCE,
    sole_size: tuple[float, float] | None = None,
    chunk: int = 100_000,
    max_sampled: int = 200_000_000,
    progress: Callable[[int, int], None] | None = None,
    sampler: str | None = None,
) -> Candidates:
    """Draw ``n`` accepted poses (uniform within ``limits``, default ``sampling_limits(robot)``).

    ``half_extents``: CoP rectangle (default ``cop_half_extents(robot)``). Raises SescidError when
    the acceptance rate would need more than ``max_sampled`` raw poses. ``sampler``:
    "uniform" or "adjusted" (``adjust.adjust_support_leg``; default the profile's).
    """
    from sescid.planning.adjust import adjusted_draws
    from sescid.planning.broadphase import collision_free_mask_broad

    sampler = sampler or robot.profile.pose_sampler
    if sampler not in ("uniform", "adjusted"):
        raise SescidError(f"unknown pose sampler '{sampler}' (uniform or adjusted)")
    centre = cop_centre(robot)
    if sampler == "adjusted":
        chunk = min(chunk, 4_000)
    if n < 1:
        raise SescidError(f"number of candidates must be ≥ 1, got {n}")
    rng = np.random.default_rng(seed)
    lim = sampling_limits(robot) if limits is None else np.asarray(limits, dtype=float)
    half = cop_half_extents(robot) if half_extents is None else np.asarray(half_extents, float)
    cap = collision_capsules(robot)
    qs: list[np.ndarray] = []
    cops: list[np.ndarray] = []
    n_sampled = n_stable = n_ground = n_free = 0
    width = lim[:, 1] - lim[:, 0]
    draw = np.empty((chunk if sampler == "uniform" else 0, robot.nq))
    screen = None
    if sampler == "uniform" and np.all(np.abs(lim) < MAX_ANGLE):
        screen = coarse_screen_tree(robot, lim[:, 0], width)
    while n_free < n:
        if sampler == "adjusted":
            pool = np.concatenate(qs) if qs else None
            q = adjusted_draws(robot, cap, lim, chunk, rng, pool, half, centre)
            ok, cop = stable_subset(robot, q, half, centre)
        elif screen is None:
            q = rng.random((chunk, robot.nq), out=draw[:chunk])
            q *= width
            q += lim[:, 0]
            ok, cop = stable_subset(robot, q, half, centre)
        else:
            # unit draws screened by the coarse CoP before they are scaled; the survivors get
            # the same numbers as lim[:, 0] + width * rng.random((chunk, nq))
            u = rng.random((chunk, robot.nq), out=draw[:chunk])
            tree, r, bound = screen
            q = u[inside_box(cop_xy(tree, u, r), centre, half + bound)]
            q *= width
            q += lim[:, 0]
            ok, cop = stable_subset(robot, q, half, centre, coarse=False)
        n_sampled += chunk
        q = q[ok]
        n_stable += len(q)
        if len(q):
            rot, org = robot.forward(q)
            g = ground_clear_mask(robot, q, cap, rot, org, clearance, sole_size)
            q, cop, rot, org = q[g], cop[g], rot[g], org[g]
            n_ground += len(q)
            f = collision_free_mask_broad(cap, rot, org)
            q, cop = q[f], cop[f]
            n_free += len(q)
            qs.append(q)
            cops.append(cop)
        if progress is not None:
            progress(min(n_free, n), n)
        if sampler == "adjusted" and n_free:  # next chunk sized to what is still missing
            chunk = int(min(100_000, max(1_000, 1.2 * (n - n_free) * n_sampled / n_free)))
        rate = n_free / n_sampled
        if n_sampled >= 1_000_000 and (rate == 0 or n / rate > max_sampled):
            raise SescidError(
                f"only {n_free} of {n_sampled} uniform poses are stable and collision free "
                f"({rate:.2e}); {n} candidates would need more than {max_sampled} samples — "
                "widen the CoP box or the joint ranges"
            )
    return Candidates(
        q=np.concatenate(qs)[:n],
        cop=np.concatenate(cops)[:n],
        limits=lim,
        half_extents=half,
        n_sampled=n_sampled,
        n_stable=n_stable,
        n_ground=n_ground,
        n_free=n_free,
        capsules=cap,
        sampler=sampler,
        centre=centre,
    )
