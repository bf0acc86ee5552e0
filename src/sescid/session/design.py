"""What a guided session chooses from and how: the candidate pool (standing on the support
foot, or held in a gantry) and the sequential D-optimal design for the kinds the robot
reports.

The kinds (``SessionOptions.kinds``): "cop", "tau", "both", or "auto" — what the robot
reports, known at the first measured pose: a loaded foot sensor gives the CoP, ``tau_<joint>``
columns the joint torques. Until then an "auto" session plans for the CoP (a held robot: for the
torques); when the first measurement shows other kinds, the design is rebuilt for them with
what was commanded so far (``switch``), so every later pose is chosen for the rows the robot
gives. The decisions depend only on the options and the measurements (a replay repeats them).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sescid.bench.real_robot import check_limits
from sescid.errors import DataError, OptionError
from sescid.kinds import COP, TORQUE, Kinds, parse_kinds
from sescid.planning import (
    CandidateOptions,
    Candidates,
    Mount,
    PlanOptions,
    TorqueRows,
    block_rows,
    design_kinds,
    identifiable_basis,
    kind_basis,
    min_block_poses,
    projected_regressor,
    resolve_mount,
)
from sescid.planning.design.sequential import SequentialDesign
from sescid.planning.funnel import sampling_range, stance_candidates
from sescid.robot import Robot
from sescid.session.records import SessionOptions
from sescid.stance import own_stance


def session_mount(robot: Robot, opt: SessionOptions) -> tuple[Mount, Kinds]:
    """(mount, kinds planned for before the first measurement); OptionError for kinds a mount
    cannot give (a CoP in a gantry)."""
    mount: Mount = opt.mount or own_stance(robot).mount
    kinds: Kinds
    if opt.kinds == "auto":
        kinds = (TORQUE,) if mount == "gantry" else (COP,)
    else:
        kinds = parse_kinds(opt.kinds)
    return resolve_mount(robot, mount, kinds), kinds


def session_candidates(
    robot: Robot, mount: Mount, opt: SessionOptions, seed, progress: Callable | None
) -> tuple[Candidates, np.ndarray | None]:
    """(``opt.n_candidates`` candidates of ``robot`` held as ``mount``, drawn by the planner's
    funnel (``stance_candidates``), and the (2,) m CoP box they stand in; None in a gantry).
    A session checks stability by the CoP box alone (no compliant-robot margin): it measures
    the real CoP at every pose and refuses to command an unsafe one (``unsafe_pose``)."""
    half = (
        None if mount == "gantry" else CandidateOptions(half_extents=opt.half_extents).half(robot)
    )
    draw = PlanOptions(
        limits=opt.limits, half_extents=half, hang_height=opt.hang_height, rigid=True,
        allow_missing_meshes=opt.allow_missing_meshes,
    )  # fmt: skip
    lim, _, _ = sampling_range(robot, draw)
    return stance_candidates(robot, mount, opt.n_candidates, seed, draw, lim, progress), half


def kinds_of(cop: bool, tau: bool) -> Kinds:
    """The design kinds of a measurement with a CoP and/or joint torques (neither: torques)."""
    return (COP, TORQUE) if cop and tau else (COP,) if cop else (TORQUE,)


class KindSwitch:
    """A session's design that can change the kinds it plans for (``SessionDesign``,
    ``session.stances.StanceDesign``): ``_design(kinds)`` makes the new one."""

    kinds: Kinds
    basis: np.ndarray
    design: SequentialDesign
    min_rows: int

    def _design(self, kinds: Kinds) -> tuple[np.ndarray, SequentialDesign, int]:
        raise NotImplementedError

    def switch(self, kinds: Kinds, measured: list[int]) -> None:
        """Plan for ``kinds`` from now on: a new design holding the poses ``measured`` (pool
        indices) and never proposing one already commanded."""
        if kinds == self.kinds:
            return
        tried = self.design.tried.copy()
        self.basis, self.design, self.min_rows = self._design(kinds)
        self.kinds = kinds
        for i in measured:
            self.design.add(i)
        self.design.tried |= tried


class SessionDesign(KindSwitch):
    """The session's candidates and its sequential design for ``kinds``."""

    def __init__(self, robot: Robot, opt: SessionOptions, progress: Callable | None = None):
        self.robot, self.opt = robot, opt
        self.mount, self.kinds = session_mount(robot, opt)
        #: (2,) m, the CoP box (None: held in a gantry, no sole needed)
        if self.mount != "gantry" and opt.hang_height is not None:
            raise OptionError("hang_height", "a hang height goes with a robot held in a gantry")
        #: the candidates, and the (2,) m CoP box (None: held in a gantry, no sole needed)
        self.cand, self.half = session_candidates(robot, self.mount, opt, opt.seed, progress)
        self.basis, self.design, self.min_rows = self._design(self.kinds)

    def _design(self, kinds: Kinds) -> tuple[np.ndarray, SequentialDesign, int]:
        """(basis, sequential design, fewest poses that determine it) for ``kinds``."""
        q = self.cand.q
        if kinds == (COP,):
            basis = identifiable_basis(self.robot, q)
            design = SequentialDesign(projected_regressor(self.robot, q, basis), self.opt.near)
            return basis, design, 0
        spec = design_kinds(self.robot, kinds, self.opt.cop_noise, self.opt.tau_noise)
        torques = TorqueRows(self.robot, q, spec)
        basis = kind_basis(self.robot, q, spec, torques=torques)
        rows = block_rows(self.robot, q, spec, basis, torques)
        need = min_block_poses(spec.rows, basis.shape[1], spec.n_nuisance)
        return basis, SequentialDesign(rows, self.opt.near), need

    def measured_kinds(self, cop: bool, tau: bool, pose: str) -> Kinds:
        """The kinds a measurement gives for this session (``auto``: all of them); DataError
        when it lacks what the session was asked for."""
        asked = self.opt.kinds  # as the options spell it, for the messages
        planned = None if asked == "auto" else parse_kinds(asked)
        if not cop and not tau:
            raise DataError(
                f"pose {pose}: the robot reports neither a loaded foot sensor (the CoP) nor "
                "joint torques (tau_<joint> columns): a session measures one of them"
            )
        if planned is not None and COP in planned and not cop:
            raise DataError(
                f"pose {pose}: the adapter logs no loaded foot sensor, but the session was asked "
                f"to plan for the CoP (--kinds {asked}); with joint torques use --kinds tau or auto"
            )
        if planned is not None and TORQUE in planned and not tau:
            raise DataError(
                f"pose {pose}: the adapter logs no joint torques (tau_<joint> columns), but the "
                f"session was asked to plan for them (--kinds {asked})"
            )
        return kinds_of(cop, tau) if planned is None else planned


def unsafe_pose(
    robot: Robot,
    q: np.ndarray,
    half: np.ndarray | None,
    r_est: np.ndarray | None,
    held: bool = False,
) -> str:
    """Why ``q`` must not be commanded ('' when it is within limits and statically stable).

    Stable: the model's CoP, and once every identifiable combination is determined the current
    estimate's CoP too, strictly inside the stability box ``half`` around the sole's centre; a
    robot ``held`` in a gantry has no balance to keep (its candidates already clear the floor
    and themselves).
    """
    try:
        check_limits(robot, q[None], "command")
    except DataError as exc:
        return str(exc)
    if held or half is None:
        return ""
    for what, r in (("model", None), ("identified", r_est)):
        if what == "identified" and r is None:
            continue
        cop = robot.cop(q[None], r)[0]
        if np.any(np.abs(cop - robot.sole_centre) >= half):
            return (
                f"unstable: {what} CoP ({cop[0] * 1e3:.1f}, {cop[1] * 1e3:.1f}) mm outside "
                f"±({half[0] * 1e3:.1f}, {half[1] * 1e3:.1f}) mm; not commanded"
            )
    return ""
