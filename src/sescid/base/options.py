"""Options written once: a field of an options record carries its default, its range and its
help text (``option``); the record checks its ranges where it is made (``check_ranges``), and
the command line builds its flags from the same fields (``sescid.cli.flags``), so a default, a
range or a help text cannot drift between the API and the CLI.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from sescid.errors import OptionError

#: the key of a field's ``OptionSpec`` in its metadata
SPEC = "sescid.option"
#: the help of every random seed
SEED_HELP = "Random seed: the same seed gives the same numbers."


@dataclass(frozen=True)
class OptionSpec:
    """What a field of an options record tells a user: its help (meaning and unit), its range
    (``low``/``high``, open or closed; None: unbounded; a tuple field: each element), the CLI
    flag when it is not ``--<field-name>``, the phrase of the range in errors (``what``;
    default: the range itself) and the metavar of a flag taking several values."""

    help: str
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    flag: str | None = None
    what: str | None = None
    metavar: str | None = None

    @property
    def bounded(self) -> bool:
        """True when the field has a range to check."""
        return self.low is not None or self.high is not None

    def contains(self, value: float) -> bool:
        """True for a finite number inside the range."""
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            return False
        if not math.isfinite(value):
            return False
        lo, hi = self.low, self.high
        if lo is not None and (value < lo or (self.low_open and value == lo)):
            return False
        return not (hi is not None and (value > hi or (self.high_open and value == hi)))

    def describe(self) -> str:
        """The range in words: "> 0", "≥ 1", "in (0, 1]", or ``what``."""
        if self.what is not None:
            return self.what
        lo, hi = self.low, self.high
        if lo is not None and hi is not None:
            left, right = "(" if self.low_open else "[", ")" if self.high_open else "]"
            return f"in {left}{lo:g}, {hi:g}{right}"
        if lo is not None:
            return f"{'>' if self.low_open else '≥'} {lo:g}"
        return f"{'<' if self.high_open else '≤'} {hi:g}"


def option(default: Any = dataclasses.MISSING, help: str = "", **spec: Any) -> Any:  # noqa: A002
    """A dataclass field with its default and its ``OptionSpec`` (help, and ``spec``'s range,
    flag, ``what``, metavar)."""
    return dataclasses.field(default=default, metadata={SPEC: OptionSpec(help, **spec)})


def option_like(cls: type, name: str) -> Any:
    """A field with the default and ``OptionSpec`` of field ``name`` of ``cls`` (the same
    option in another record: written once)."""
    default, spec = option_spec(cls, name)
    return dataclasses.field(default=default, metadata={SPEC: spec})


def option_spec(cls: type, name: str) -> tuple[Any, OptionSpec]:
    """The default and the ``OptionSpec`` of field ``name`` of the record class ``cls``."""
    for f in dataclasses.fields(cls):
        if f.name == name and SPEC in f.metadata:
            return f.default, f.metadata[SPEC]
    raise KeyError(f"{cls.__name__}.{name} is not an option field")


def option_names(cls: type) -> list[str]:
    """The fields of ``cls`` that carry an ``OptionSpec``, in their order."""
    return [f.name for f in dataclasses.fields(cls) if SPEC in f.metadata]


def check_ranges(record: Any, names: Iterable[str] | None = None) -> None:
    """OptionError naming the first option field of ``record`` (or of ``names``) whose value,
    or an element of a tuple value, lies outside its range; None passes (an optional field)."""
    wanted = None if names is None else set(names)
    for f in dataclasses.fields(record):
        spec = f.metadata.get(SPEC)
        if spec is None or not spec.bounded or (wanted is not None and f.name not in wanted):
            continue
        value = getattr(record, f.name)
        for v in value if isinstance(value, tuple) else (value,):
            if v is not None and not spec.contains(v):
                raise OptionError(f.name, f"must be {spec.describe()}, got {v!r}")
