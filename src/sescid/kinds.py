"""The measurement kinds, one vocabulary: what one measurement is (``Kind``: the CoP, joint
torques, or the balance of a robot on a line) and what a plan, a session or a simulation
measures (``Kinds``: some of them, in ``KINDS`` order).

Users spell a plan's kinds as one kind or ``both`` (the CoP and joint torques:
``sescid poses --kinds both``, ``plan_poses(kinds="both")``); ``parse_kinds`` is the one parser
of those spellings (and of kinds listed with commas, ``cop,tau``), ``kinds_label`` the one
formatter that writes them back (``both``) where text shows them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal, get_args

from sescid.errors import OptionError, check_choice, choices

__all__ = [
    "BALANCE",
    "BOTH",
    "COP",
    "KINDS",
    "TORQUE",
    "DesignKind",
    "Kind",
    "Kinds",
    "kinds_label",
    "parse_kinds",
]

#: a measurement kind, as named in fits, files and options: the CoP, joint torques, or the
#: balance of a robot on a support line
Kind = Literal["cop", "tau", "balance"]
COP: Kind = "cop"
TORQUE: Kind = "tau"
BALANCE: Kind = "balance"
KINDS: tuple[Kind, ...] = get_args(Kind)
#: what a plan, a session or a simulation measures: kinds in ``KINDS`` order, each once
Kinds = tuple[Kind, ...]
#: how users spell the CoP and joint torques together
BOTH = "both"
#: what a pose plan or a session measures, as users spell it (``--kinds``): one kind, or
#: ``both``; ``parse_kinds`` reads it
DesignKind = Literal["cop", "tau", "both"]


def _spelled(word: Any) -> Kinds:
    """The kinds one spelling names (``both``: the CoP and joint torques)."""
    return (COP, TORQUE) if word == BOTH else (word,)


def parse_kinds(
    value: str | Sequence[str], name: str = "kinds", spelled: Any = DesignKind
) -> Kinds:
    """The kinds ``value`` names, in ``KINDS`` order: one of the spellings of the ``Literal``
    alias ``spelled`` (a kind, or ``both``), kinds separated by commas (``cop,tau``), or kinds
    already parsed (a sequence); each set a spelling names, and no other (a spelling that names
    no kind, a session's "auto", is its caller's to read first). OptionError naming ``name``
    otherwise (``check_choice``'s, listing the spellings)."""
    allowed = choices(spelled)
    words = (
        value.split(",") if isinstance(value, str)
        else list(value) if isinstance(value, tuple | list) else [value]
    )  # fmt: skip
    named = {k for w in words for k in _spelled(w.strip() if isinstance(w, str) else w)}
    out = tuple(k for k in KINDS if k in named)
    if len(named) != len(out) or out not in {_spelled(a) for a in allowed}:
        check_choice(name, value, spelled)  # its message, listing the spellings
        raise OptionError(name, f"{value!r} names no measurement kind")
    return out


def kinds_label(kinds: Kinds) -> str:
    """The spelling of ``kinds`` users read and write: a kind's name, ``both`` for the CoP and
    joint torques (``parse_kinds`` reads it back)."""
    return BOTH if kinds == (COP, TORQUE) else ",".join(kinds)
