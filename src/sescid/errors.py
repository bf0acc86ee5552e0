"""The exceptions sescid raises for input a user can act on; the CLI prints each as one line.

Every message names what is wrong and where (file, row, column, field, body or joint); none
speaks of command-line flags, which only the CLI knows. ``check_choice`` refuses a value outside
a ``Literal`` alias (the typed choices of every option), listing the alias's values.
"""

from __future__ import annotations

from typing import Any, get_args


class SescidError(ValueError):
    """Bad input a user can act on (file, row, column or field named in the message)."""


class ModelError(SescidError):
    """A robot model (URDF, MJCF, profile) that cannot be used as given."""


class DataError(SescidError):
    """Measurements, poses or tables that cannot be used as given."""


class OptionError(SescidError):
    """A parameter value outside its valid range; ``name`` is the API parameter."""

    def __init__(self, name: str, message: str):
        super().__init__(f"{name}: {message}")
        self.name = name


class SolverError(SescidError):
    """A numerical solver that stopped without a usable answer."""


class MissingExtraError(SescidError):
    """An optional dependency is not installed; ``extra`` names the sescid extra to install,
    ``instead`` (optional) how to do without it (``--no-view``)."""

    def __init__(self, what: str, extra: str, instead: str = ""):
        super().__init__(
            f"{what} needs the {extra} extra: pip install 'sescid[{extra}]' (in a clone of "
            f"the repository: pip install '.[{extra}]')" + (f"; or {instead}" if instead else "")
        )
        self.what = what
        self.extra = extra


def choices(alias: Any) -> tuple[Any, ...]:
    """The values a ``Literal`` alias allows (nested aliases and unions flattened, ``bool`` as
    True, False), in their order."""
    out: list[Any] = []
    for a in get_args(alias):
        out += [True, False] if a is bool else choices(a) if get_args(a) else [a]
    return tuple(out)


def check_choice(name: str, value: Any, alias: Any) -> None:
    """OptionError naming ``name`` unless ``value`` is one of the values of the ``Literal`` alias
    ``alias`` (the message lists them from the alias: one home for the choices)."""
    allowed = choices(alias)
    if not any(value == a and type(value) is type(a) for a in allowed):
        listed = ", ".join(repr(a) for a in allowed)
        raise OptionError(name, f"must be one of {listed}, got {value!r}")


__all__ = [
    "DataError",
    "MissingExtraError",
    "ModelError",
    "OptionError",
    "SescidError",
    "SolverError",
    "check_choice",
    "choices",
]
