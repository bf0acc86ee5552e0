"""The exceptions sescid raises for input a user can act on; the CLI prints each as one line.

Every message names what is wrong and where (file, row, column, field, body or joint); none
speaks of command-line flags, which only the CLI knows.
"""

from __future__ import annotations


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
    """An optional dependency is not installed; ``extra`` names the sescid extra to install."""

    def __init__(self, what: str, extra: str):
        super().__init__(
            f"{what} needs the {extra} extra: pip install 'sescid[{extra}]' (in a clone of "
            f"the repository: pip install '.[{extra}]')"
        )
        self.extra = extra


__all__ = [
    "DataError",
    "MissingExtraError",
    "ModelError",
    "OptionError",
    "SescidError",
    "SolverError",
]
