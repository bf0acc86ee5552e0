"""The stance: how the robot was held when it was measured, typed once, parsed from every spelling.

A stance is standing on one sole (``stand``: the robot rooted at that frame), on both feet
(``double``: rooted at the reference robot's support foot, the CoP of the whole robot in its
frame) or held by a link in a gantry (``gantry``: a trunk, where the mass splits, loads no foot).
Users write it as ``<frame>`` (standing on that sole; a trunk is held), ``double``,
``stand:<frame>`` or ``gantry:<frame>`` — on the command line (``--stances``, ``--support``,
``FILE@FRAME``), in a file's ``support`` column (any case of the header), a bag's stance topic,
a pose plan — and ``parse_stance`` is the one parser of them all. Data carry it typed
(``Measurements.support``: a ``Stance`` once resolved, its own support's too); ``data_stance``
resolves and checks every measurement's stance once, where the data meet the reference robot: a
frame of the model, whose stance can measure what the data hold (no CoP under a held trunk, no
joint torques on both feet). Text is its ``label`` (the frame, or ``double``) only where it is
written out: a file's column, a fit's stances, messages.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Literal, NoReturn, get_args

import numpy as np

from sescid.errors import DataError, ModelError, OptionError
from sescid.kinds import Kind
from sescid.model.sole import splits_at_support
from sescid.robot import DOUBLE, Robot
from sescid.tables import SUPPORT_COLUMN, Table

#: what gave a stance, for its errors: text, or a function that makes it (a file's row number
#: costs a scan of the file up to that row: made only when an error names it)
Where = str | Callable[[], str]

__all__ = [
    "MOUNTS",
    "Mount",
    "Stance",
    "data_stance",
    "held_trunk",
    "own_stance",
    "parse_stance",
    "parse_stances",
    "stance_labels",
    "stance_robot",
    "support_column",
]

#: how a robot is held in a stance: on one sole, on both feet, by a link in a gantry
Mount = Literal["stand", "gantry", "double"]
MOUNTS: tuple[Mount, ...] = get_args(Mount)
#: what each mount cannot measure, and why
_CANNOT: dict[Mount, dict[Kind, str]] = {
    "gantry": {
        "cop": "a robot held there in a gantry loads no foot: it has no centre of pressure "
        "(a CoP is measured under a standing foot: name the sole it stood on)",
        "balance": "a robot held there in a gantry does not balance on a line",
    },
    "double": {
        "tau": "joint torques on both feet: the floor's forces under two feet are not "
        "determined by statics, so the torques cannot be fitted (measure them on one foot or "
        "in a fixture)",
    },
}


@dataclass(frozen=True)
class Stance:
    """One stance: the frame the robot is rooted at (double: the reference foot) and how it is
    held there."""

    support: str
    mount: Mount  #: "stand", "double" or "gantry"

    @property
    def label(self) -> str:
        """Its name in data (``Measurements.support``, a file's ``support`` column): the
        frame, or ``double`` (``sescid.robot.DOUBLE``)."""
        return DOUBLE if self.mount == "double" else self.support

    def describe(self) -> str:
        """One phrase: on which foot, or held by which link."""
        if self.mount == "double":
            return f"on both feet (CoP in {self.support}'s frame)"
        if self.mount == "gantry":
            return f"held by {self.support} in a gantry"
        return f"standing on {self.support}"

    def cannot(self, kind: Kind) -> str | None:
        """Why this stance cannot measure ``kind``, or None."""
        return _CANNOT.get(self.mount, {}).get(kind)


def own_stance(robot: Robot) -> Stance:
    """The stance of ``robot``'s own support: held there in a gantry when its mass splits at
    that body (``held_trunk``), else standing on it."""
    return Stance(robot.support, "gantry" if held_trunk(robot) else "stand")


def stance_robot(reference: Robot, stance: Stance) -> Robot:
    """The reference robot rooted at the stance's frame (on both feet: the reference itself;
    ``Robot.stance``)."""
    return reference.stance(stance.label)


def held_trunk(robot: Robot) -> bool:
    """True when the robot's mass splits at its support body (a trunk or pelvis: several heavy
    branches leave it), False at the end of a limb (a foot)."""
    cache = robot.__dict__.setdefault("_held_trunk", [])
    if not cache:
        cache.append(splits_at_support([b.parent for b in robot.model.bodies], robot.masses))
    return bool(cache[0])


def parse_stance(text: str, reference: Robot, where: Where = "--stances") -> Stance:
    """The stance ``text`` spells: ``<frame>`` (standing on that sole; a frame where the mass
    splits, a trunk, is held in a gantry), ``double`` (both feet, ``reference``'s support as
    the reference foot), ``stand:<frame>`` or ``gantry:<frame>``. ``where`` names what gave it
    (an option, a file and row) in the errors: OptionError when it starts with ``--`` (an
    option), else DataError; for an empty text, an unknown prefix or a frame the model lacks."""
    item = str(text).strip()
    mount, sep, frame = item.partition(":")
    if not sep:
        mount, frame = "", item
    frame = frame.strip()
    if not frame:
        _refuse(where, "a stance is empty: name a sole frame, double, stand:<frame> or gantry:…")
    if frame == DOUBLE and not sep:
        return Stance(reference.support, "double")
    if mount.strip() not in ("", "stand", "gantry"):
        _refuse(
            where, f"'{item}': a stance is a sole frame, double, stand:<frame> or gantry:<frame>"
        )
    try:
        robot = reference.stance(frame)
    except ModelError as exc:
        _refuse(where, str(exc))
    how: Mount = "gantry" if mount == "gantry" or held_trunk(robot) else "stand"
    return Stance(frame, how)


def parse_stances(spec: str | Sequence[str], reference: Robot) -> tuple[Stance, ...]:
    """The stances of ``spec``: a comma-separated list (or a sequence) of ``parse_stance``
    spellings, to plan or run a session over. OptionError naming ``--stances`` for an empty
    list, an unknown prefix, a frame the model lacks, a stance named twice or one balancing on
    a line (planned alone)."""
    items = [s.strip() for s in spec.split(",")] if isinstance(spec, str) else list(spec)
    items = [s for s in items if s]
    if not items:
        raise OptionError("stances", "name at least one stance (a sole frame, double, gantry:…)")
    out: list[Stance] = []
    for item in items:
        st = parse_stance(item, reference, "--stances")
        if reference.stance(st.label).line is not None:  # balance rows: no stance of a plan
            raise OptionError(
                "stances",
                f"'{item}': the robot balances on a line there (a wheel axle, an edge): plan it "
                "alone (--support FRAME --line …, without --stances); --stances plans soles, "
                "both feet and held links",
            )
        if any(s.label == st.label for s in out):
            raise OptionError("stances", f"'{st.label}' is named twice")
        out.append(st)
    return tuple(out)


def data_stance(
    reference: Robot,
    given: Stance | str | None,
    kinds: Iterable[Kind] = (),
    where: Where = "data",
) -> tuple[Stance, Robot]:
    """The stance of data measured in ``given`` (a ``Stance``, any ``parse_stance`` spelling;
    None: the reference's own support) after the one check every measurement's stance passes: a
    frame of the model, and a stance that can measure the data's ``kinds``. Returns the stance
    (``own_stance`` for any of the reference's own support) and the robot rooted there.
    ``where`` (a file and row, an option ``--…``) starts each error: DataError, or OptionError
    for an option."""
    label = given.label if isinstance(given, Stance) else given
    if label is None or label == reference.support:
        return own_stance(reference), reference
    stance = given if isinstance(given, Stance) else parse_stance(label, reference, where)
    for kind in kinds:
        why = stance.cannot(kind)
        if why is not None:
            _refuse(where, f"'{stance.label}': {why}")
    if stance.label == reference.support:
        return own_stance(reference), reference
    return stance, stance_robot(reference, stance)


def _refuse(where: Where, message: str) -> NoReturn:
    """Raise the error of ``message`` at ``where``: OptionError for an option, else DataError."""
    where = where() if callable(where) else where
    if where.startswith("--"):
        raise OptionError(where.lstrip("-").replace("-", "_"), message)
    raise DataError(f"{where}: {message}")


def support_column(table: Table) -> str | None:
    """The header of the table's stance column: ``SUPPORT_COLUMN`` in any case ("Support",
    "SUPPORT"); None without one; DataError for two such headers (which one is meant?)."""
    if SUPPORT_COLUMN in table.columns or SUPPORT_COLUMN in table.text:
        found = [SUPPORT_COLUMN]
    else:
        found = []
    found += [c for c in table.names() if c != SUPPORT_COLUMN and c.lower() == SUPPORT_COLUMN]
    if len(found) > 1:
        raise DataError(
            f"{table.path}: columns {', '.join(repr(c) for c in found)} both name each row's "
            f"stance: keep one, named '{SUPPORT_COLUMN}'"
        )
    return found[0] if found else None


def stance_labels(
    cells: Sequence[str], reference: Robot, where: Callable[[str], Where]
) -> tuple[np.ndarray, dict[str, Stance]]:
    """Each cell of a stance column (any ``parse_stance`` spelling, parsed once per distinct
    spelling; an error at ``where(spelling)``) as its stance's label, an empty cell as "", and
    the stance of each label found."""
    found = {v: parse_stance(v, reference, where(v)) for v in dict.fromkeys(cells) if v}
    labels = np.array([found[v].label if v else "" for v in cells])
    return labels, {s.label: s for s in found.values()}
