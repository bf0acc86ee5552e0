"""Poses for a robot held in a fixture (a gantry): no balance to keep, only joint limits,
self-collision and the floor under a robot hanging free.

The held link (the support: a torso or pelvis) is level and fixed; the rest hangs. The floor
lies ``hang_height`` below the held link's frame; by default the robot hangs as it would stand
on its feet at the zero pose, lifted by ``GANTRY_LIFT``: the floor lies ``GANTRY_LIFT`` below
the lowest point of its geometry at the zero pose (every body but the held one; collision
shapes, else visual, else the origin: ``ground``). A candidate is kept when every such point
stays ``clearance`` above the floor and no two collision capsules touch (pairs touching at the
zero pose skipped, ``collision``). Candidates are uniform draws within the sampling limits;
when fewer than ``GANTRY_SWITCH_RATE`` of them are accepted (a many-jointed robot whose limbs
cross), the rest are drawn near accepted poses (``adjust.draw``: a quarter uniform, the others
a random 30 % of the joints moved by a quarter of their range from an accepted pose).

The mount follows from the support unless given: a support at which the robot's mass splits
into several heavy branches (a trunk, ``model.sole.supporting_leg``) is held in a gantry; a
support at the end of a limb (a foot) stands on the floor.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sescid.errors import OptionError, SescidError, check_choice
from sescid.kinds import COP, TORQUE, DesignKind, Kinds, parse_kinds
from sescid.planning.feasibility.adjust import draw
from sescid.planning.feasibility.broadphase import collision_free_mask_broad
from sescid.planning.feasibility.candidates import Candidates, Mount, Sampling
from sescid.planning.feasibility.collision import collision_capsules
from sescid.planning.feasibility.ground import clear_above, ground_checks, lowest_heights
from sescid.planning.feasibility.limits import sampling_limits
from sescid.planning.feasibility.stability import DEFAULT_CLEARANCE
from sescid.robot import Robot
from sescid.stance import own_stance

#: m: by default the held robot's lowest point hangs this far above the floor at the zero pose
GANTRY_LIFT = 0.05
#: draws without one accepted pose after which the gantry search gives up
GANTRY_GIVE_UP = 200_000
#: accepted share of the first uniform chunk below which the draws move near accepted poses
GANTRY_SWITCH_RATE = 0.05


@dataclass(frozen=True)
class GantryOptions:
    """How ``gantry_candidates`` draws and checks poses (SI units, radians)."""

    limits: np.ndarray | None = None  #: (nq, 2) rad; None: ``sampling_limits(robot)``
    hang_height: float | None = None  #: m, held link above the floor (None: ``gantry_floor``)
    clearance: float = DEFAULT_CLEARANCE  #: m, every body above the floor
    chunk: int = 20_000  #: uniform draws per batch (at most)


def resolve_mount(robot: Robot, mount: Mount | None, kinds: Kinds | DesignKind) -> Mount:
    """The plan's mount: ``mount``, or the support's own (``own_stance``: gantry at a trunk), for
    the planned ``kinds`` (or any ``parse_kinds`` spelling); OptionError for a CoP design on a
    gantry (a held robot loads no foot) and for torques on both feet."""
    kinds = parse_kinds(kinds)
    if mount is None:
        mount = own_stance(robot).mount
    check_choice("mount", mount, Mount)
    if mount == "double" and kinds != (COP,):
        raise OptionError(
            "kinds",
            "on both feet the joint torques depend on how the load splits between the feet (a "
            "closed chain), not on the mass model alone: plan the CoP on both feet (--kinds cop)",
        )
    if mount == "gantry" and kinds != (TORQUE,):
        raise OptionError(
            "kinds",
            f"'{robot.support}' is held in a gantry: no foot carries a load, so there is no CoP "
            "to plan for; plan the joint torques (--kinds tau), or stand it on a foot "
            "(--support <sole frame> --mount stand)",
        )
    return mount


def standing_height(robot: Robot) -> float:
    """Height [m] of the held link's frame above the robot's lowest point at the zero pose
    (every body but the held one): how high it is when the robot stands on its feet."""
    rot, org = robot.forward(np.zeros((1, robot.nq)))
    low = float(lowest_heights(robot, rot, org, exempt=False)[0])
    if not np.isfinite(low):
        raise SescidError(f"{robot.name}: no body below '{robot.support}' to hang from it")
    return -low


def gantry_floor(robot: Robot, hang_height: float | None, clearance: float) -> tuple[float, str]:
    """(floor z [m] in the held link's frame, how it was set); SescidError when the robot at
    the zero pose would not clear it by ``clearance``."""
    stand = standing_height(robot)
    if hang_height is None:
        height = stand + GANTRY_LIFT
        how = (
            f"held link {height:.3f} m above the floor: its standing height at the zero pose "
            f"({stand:.3f} m) + {GANTRY_LIFT * 1e3:g} mm"
        )
    else:
        height = float(hang_height)
        if not (math.isfinite(height) and height > 0):
            raise OptionError("hang_height", f"must be a finite height > 0 m, got {hang_height}")
        how = f"held link {height:.3f} m above the floor (given; standing height {stand:.3f} m)"
    if not height - stand > clearance:
        raise SescidError(
            f"{robot.name} held {height:.3f} m above the floor touches it at the zero pose (its "
            f"lowest point hangs {stand:.3f} m below '{robot.support}'; clearance "
            f"{clearance * 1e3:g} mm): hang it higher"
        )
    return -height, how


def gantry_candidates(
    robot: Robot,
    n: int,
    seed: int | np.random.Generator = 0,
    options: GantryOptions | None = None,
    *,
    progress: Callable[[int, int], None] | None = None,
) -> Candidates:
    """``n`` uniform draws within the limits that keep every body ``clearance`` [m] above the
    floor (``gantry_floor``) and free of self-collision (``GantryOptions``), reporting
    ``progress(accepted, n)``; ``cop`` is nan (no foot is loaded)."""
    opt = options or GantryOptions()
    if n < 1:
        raise SescidError(f"number of candidates must be ≥ 1, got {n}")
    rng = np.random.default_rng(seed)
    lim = sampling_limits(robot) if opt.limits is None else np.asarray(opt.limits, dtype=float)
    clearance, chunk = opt.clearance, opt.chunk
    floor, how = gantry_floor(robot, opt.hang_height, clearance)
    cap = collision_capsules(robot)
    checks = ground_checks(robot, exempt=False)
    width = lim[:, 1] - lim[:, 0]
    qs: list[np.ndarray] = []
    counts = np.zeros(3, dtype=np.int64)  # drawn, clear of the floor, free of self-collision
    sampler: Sampling = "uniform"
    size = chunk
    while counts[2] < n:
        if sampler == "uniform":
            q = rng.random((size, robot.nq)) * width + lim[:, 0]
        else:
            q = draw(lim, size, rng, np.concatenate(qs) if counts[2] else None)
        rot, org = robot.forward(q)
        ok = clear_above(checks, rot, org, floor + clearance)
        q, rot, org = q[ok], rot[ok], org[ok]
        counts[0] += size
        counts[1] += len(q)
        free = collision_free_mask_broad(cap, rot, org)
        qs.append(q[free])
        counts[2] += int(free.sum())
        rate = int(free.sum()) / size  # of the last chunk's draws
        if sampler == "uniform" and counts[2] < min(GANTRY_SWITCH_RATE * counts[0], n):
            sampler, size = "uniform+adjusted", 1_000
        else:  # what is missing at the last rate, at most 4× the last chunk: rates climb
            want = 1.05 * (n - counts[2]) / rate + 500 if rate > 0 else chunk
            size = int(min(chunk, 4 * size, max(1_000, want)))
        if progress is not None:
            progress(int(min(counts[2], n)), n)
        if not counts[2] and counts[0] >= GANTRY_GIVE_UP:
            stage = "the floor" if not counts[1] else "self-collision"
            raise SescidError(
                f"no pose of {robot.name} held by '{robot.support}' passes: of {counts[0]} draws "
                f"{counts[1]} cleared the floor ({how}), none was free of self-collision"
                if counts[1]
                else f"no pose of {robot.name} held by '{robot.support}' clears the floor "
                f"({how}) in {counts[0]} draws: {stage} stops them (hang it higher)"
            )
    out = Candidates.counted(
        counts[[0, 0, 0, 1, 2]],  # no CoP box, no balance: every draw counts as in and stable
        q=np.concatenate(qs)[:n],
        cop=np.full((n, 2), np.nan),
        limits=lim,
        half_extents=np.full(2, np.nan),
        capsules=cap,
        sampler=sampler,
        mount="gantry",
    )
    out.notes.append(f"gantry: {how}; every body ≥ {clearance * 1e3:g} mm above it")
    out.notes += checks.notes[:1]
    tilt = held_tilt(robot)
    if tilt is not None:
        out.notes.append(tilt)
    return out


#: rad: a held frame whose z axis is farther than this from the model's world up is not upright
HELD_TILT = math.radians(5.0)


def held_tilt(robot: Robot) -> str | None:
    """A warning when the held frame is not upright in the model file's world at q = 0 (the
    gantry holds it with its z axis vertical: a frame tilted 90°, as the CMU humanoid's y-up
    root, hangs the robot on its side), None when it is (within ``HELD_TILT``) or the model
    file cannot say."""
    from sescid.model import frame_up

    try:
        z = frame_up(robot.model_path, robot.support)
    except (SescidError, OSError):
        return None
    tilt = math.acos(min(1.0, max(-1.0, float(z[2]))))
    if tilt <= HELD_TILT:
        return None
    along = ", ".join(f"{v:+.2f}" for v in z)
    return (
        f"the held frame '{robot.support}' is tilted {math.degrees(tilt):.0f}° from upright in "
        f"the model's world (its z axis along ({along})): held with its z vertical, the robot "
        "hangs tilted as much (on its side at 90°); hold a frame whose z points up"
    )
