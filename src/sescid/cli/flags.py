"""Flags made from the options records: each ``--flag`` of a record's field takes its default,
range, help text and choices from the field (``sescid.base.option``), so none is written twice.

``flags(Record, "a", "b")`` adds the flags of fields ``a`` and ``b`` (in that order) to a
command; the handler receives each under its flag's name (``--tau-noise`` → ``tau_noise``: the
field's name unless the field names another flag), and ``record(Record, opts)`` makes the record
from them. An error about a field names its flag (``FieldOption.field``).
"""

from __future__ import annotations

import types
import typing
from collections.abc import Callable
from typing import Any, Literal, TypeVar, get_args, get_origin

import click

from sescid.base import OptionSpec, option_names, option_spec
from sescid.errors import choices

_T = TypeVar("_T")


def _hint(cls: type, name: str) -> Any:
    """The annotation of field ``name`` of ``cls``, resolved."""
    return typing.get_type_hints(cls)[name]


def _without_none(hint: Any) -> Any:
    """``X | None`` → ``X`` (a union of several others stays a union)."""
    if get_origin(hint) in (typing.Union, types.UnionType):
        rest = [a for a in get_args(hint) if a is not type(None)]
        return rest[0] if len(rest) == 1 else typing.Union[tuple(rest)]  # noqa: UP007
    return hint


def _is_literal(hint: Any) -> bool:
    """A ``Literal`` or a union of them (an alias such as ``PriorChoice``)."""
    if get_origin(hint) is Literal:
        return True
    args = get_args(hint)
    return (
        bool(args)
        and get_origin(hint) in (typing.Union, types.UnionType)
        and all(_is_literal(a) for a in args)
    )


def _number_type(kind: type, spec: OptionSpec) -> Any:
    """Int or float, as a click range where the field has one."""
    if not spec.bounded:
        return kind
    cls: Any = click.IntRange if kind is int else click.FloatRange
    lo, hi = (None if v is None else int(v) if float(v).is_integer() else v
              for v in (spec.low, spec.high))  # fmt: skip
    return cls(lo, hi, min_open=spec.low_open, max_open=spec.high_open)


class FieldOption(click.Option):
    """A flag made from field ``field`` of an options record (an ``OptionError`` about the
    field is reported under the flag)."""

    def __init__(self, *args: Any, field: str, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.field = field


def param_name(cls: type, name: str) -> str:
    """The name a handler receives field ``name`` of ``cls`` under: its flag's."""
    flag = option_spec(cls, name)[1].flag
    return name if flag is None else flag[2:].replace("-", "_")


def flag_kwargs(cls: type, name: str) -> tuple[str, dict[str, Any]]:
    """The declaration (``--name``) and ``click.option`` keywords of field ``name``."""
    default, spec = option_spec(cls, name)
    hint = _without_none(_hint(cls, name))
    decl = spec.flag or "--" + name.replace("_", "-")
    kw: dict[str, Any] = {"default": default, "help": spec.help}
    if hint is bool:
        if default:
            decl = f"{decl}/--no-{decl[2:]}"
        else:
            kw["is_flag"] = True
    elif _is_literal(hint):
        kw["type"] = click.Choice([str(c) for c in choices(hint)])
    elif hint in (int, float):
        kw["type"] = _number_type(hint, spec)
    elif get_origin(hint) is tuple and get_args(hint) and Ellipsis not in get_args(hint):
        items = get_args(hint)
        kw["nargs"] = len(items)
        if items[0] in (int, float):
            kw["type"] = _number_type(items[0], spec)
    if spec.metavar is not None:
        kw["metavar"] = spec.metavar
    kw["show_default"] = default is not None and not kw.get("is_flag", False)
    return decl, kw


def flag(cls: type, name: str) -> Callable[[Any], Any]:
    """The ``click.option`` of field ``name`` of the options record ``cls``."""
    decl, kw = flag_kwargs(cls, name)
    return click.option(decl, param_name(cls, name), cls=FieldOption, field=name, **kw)


def help_of(cls: type, name: str) -> str:
    """The help text of field ``name`` of ``cls`` (a flag written by hand: a tri-state, a unit
    the command line converts)."""
    return option_spec(cls, name)[1].help


def flags(cls: type, *names: str) -> Callable[[Any], Any]:
    """The flags of fields ``names`` of ``cls``, listed in that order."""

    def wrap(f: Any) -> Any:
        for name in reversed(names):
            f = flag(cls, name)(f)
        return f

    return wrap


def record(cls: type[_T], opts: dict, **given: Any) -> _T:
    """The options record ``cls`` from a handler's flags: each option field of ``cls`` that is
    a flag of the command, and the ``given`` values (which win)."""
    keys = {n: param_name(cls, n) for n in option_names(cls) if n not in given}
    values = {n: opts[k] for n, k in keys.items() if k in opts}
    return cls(**values, **given)


class SectionedCommand(click.Command):
    """A command whose ``--help`` lists its options under titles (click has no option groups):
    ``sections`` maps each title to its parameters' names, in order; an option no section names
    is listed in the last one."""

    def __init__(self, *args: Any, sections: dict[str, tuple[str, ...]], **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.sections = sections

    def format_options(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """Each section's options under its title (click's: all under "Options")."""
        rows = {p.name: p.get_help_record(ctx) for p in self.get_params(ctx)}
        rows = {n: r for n, r in rows.items() if r is not None and n is not None}
        named = {n for names in self.sections.values() for n in names}
        *_, last = self.sections
        for title, names in self.sections.items():
            shown = [rows[n] for n in names if n in rows]
            if title == last:
                shown += [r for n, r in rows.items() if n not in named]
            if shown:
                with formatter.section(title):
                    formatter.write_dl(shown)
