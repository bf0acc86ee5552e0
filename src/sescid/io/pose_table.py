"""The pose list a bench reads (``sescid poses``, a session's ``poses.csv``): one table, one
column order, built here and only written or printed by its callers."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sescid.errors import OptionError, SescidError
from sescid.planning import PaperConvention, paper_convention
from sescid.robot import Robot
from sescid.tables import MODEL_COP_COLUMNS


@dataclass(frozen=True)
class PoseTable:
    """A pose list's columns (name → (n,) array, in file order) and what it left out."""

    columns: dict[str, np.ndarray]
    notes: list[str] = field(default_factory=list)


def pose_table(
    robot: Robot,
    q: np.ndarray,
    *,
    pose: np.ndarray | None = None,
    support: str | np.ndarray | None = None,
    paper: PaperConvention | None = None,
    cop: np.ndarray | None = None,
) -> PoseTable:
    """The pose list of poses ``q`` (n, nq) [rad]: ``pose`` (ids; default 0 … n − 1),
    ``support`` (each pose's stance: one label for all, or (n,) labels), one column per joint
    [rad], ``<joint>_deg``, ``<joint>_ticks`` (the profile's servo; left out, with a note, when an
    angle is beyond its range), ``<joint>_paper_deg`` (``paper``: ``required_paper_convention``)
    and ``cop_x_model``, ``cop_y_model`` (``MODEL_COP_COLUMNS``: ``cop`` (n, 2) [m], the
    model's CoP, a prediction)."""
    q = np.asarray(q, dtype=float)
    n = len(q)
    cols: dict[str, np.ndarray] = {"pose": np.arange(n) if pose is None else pose}
    if support is not None:
        cols["support"] = np.full(n, support) if isinstance(support, str) else support
    names = robot.joint_names
    cols |= {j: q[:, k] for k, j in enumerate(names)}
    cols |= {f"{j}_deg": np.degrees(q[:, k]) for k, j in enumerate(names)}
    notes = []
    servo = robot.profile.servo
    if servo is not None:
        try:
            ticks = servo.to_ticks(q)
            cols |= {f"{j}_ticks": ticks[:, k] for k, j in enumerate(names)}
        except SescidError:
            notes.append(f"no _ticks columns: some angles are outside the {servo.name} range")
    if paper is not None:
        qp = np.degrees(paper.to_paper(q))
        cols |= {f"{j}_paper_deg": qp[:, k] for k, j in enumerate(names)}
    if cop is not None:
        cols |= {MODEL_COP_COLUMNS[k]: cop[:, k] for k in range(2)}
    return PoseTable(cols, notes)


def required_paper_convention(robot: Robot) -> PaperConvention:
    """The profile's angle convention of the paper's Table 2 (``<joint>_paper_deg`` columns);
    OptionError when the profile has none."""
    pc = paper_convention(robot)
    if pc is None:
        raise OptionError("paper_convention", f"the profile of {robot.name} has none")
    return pc
