"""Flags made from the options records: each flag's default, range, choices and help are the
field's, the record made back from the flags equals the API's default, and an out-of-range
value is refused by the flag and by the record alike."""

from __future__ import annotations

import dataclasses
from typing import Literal

import click
import pytest
from click.testing import CliRunner

from sescid.base import OptionSpec, check_ranges, option, option_names, option_spec
from sescid.bench import ExperimentConfig, TorqueConfig
from sescid.cli import cli
from sescid.cli.flags import SectionedCommand, flag, flag_kwargs, flags, record
from sescid.errors import OptionError
from sescid.estimation import IdentifyOptions, MapOptions
from sescid.planning import PlanOptions
from sescid.session import SessionOptions


@dataclasses.dataclass(frozen=True)
class _Knobs:
    """A record of the kinds a flag is made from."""

    level: float = option(0.5, "A level [m].", low=0, high=1, low_open=True)
    count: int = option(3, "A count.", low=2)
    on: bool = option(False, "A switch.")
    kept: bool = option(True, "A switch that is on.")
    side: Literal["evidence", "cv"] = option("evidence", "A choice.", flag="--pick")
    band: tuple[float, float] = option((0.0, 1.0), "A band [N].", low=0, metavar="LO HI")
    note: str | None = option(None, "Free text.")
    plain: float = 2.0

    def __post_init__(self) -> None:
        check_ranges(self)


def _command():
    @click.command()
    @flags(_Knobs, "level", "count", "on", "kept", "side", "band", "note")
    def knobs(**opts):
        click.echo(repr(record(_Knobs, opts)))

    return knobs


def test_a_flag_takes_the_fields_default_type_range_and_help():
    decl, kw = flag_kwargs(_Knobs, "level")
    assert decl == "--level" and kw["default"] == 0.5 and kw["help"] == "A level [m]."
    t = kw["type"]
    assert isinstance(t, click.FloatRange) and (t.min, t.max, t.min_open) == (0, 1, True)
    assert isinstance(flag_kwargs(_Knobs, "count")[1]["type"], click.IntRange)
    assert flag_kwargs(_Knobs, "on")[1]["is_flag"] is True
    assert flag_kwargs(_Knobs, "kept")[0] == "--kept/--no-kept"
    decl, kw = flag_kwargs(_Knobs, "side")
    assert decl == "--pick" and list(kw["type"].choices) == ["evidence", "cv"]
    assert flag_kwargs(_Knobs, "band")[1]["nargs"] == 2
    assert flag_kwargs(_Knobs, "note")[1]["show_default"] is False
    with pytest.raises(KeyError, match="plain"):
        flag(_Knobs, "plain")


def test_the_record_made_from_the_flags_is_the_records_default_and_takes_given_values():
    runner = CliRunner()
    res = runner.invoke(_command(), [])
    assert res.exit_code == 0 and res.output.strip() == repr(_Knobs())
    res = runner.invoke(_command(), ["--pick", "cv", "--band", "0.1", "0.2", "--no-kept"])
    assert res.output.strip() == repr(_Knobs(side="cv", band=(0.1, 0.2), kept=False))


def test_out_of_range_values_are_refused_by_the_flag_and_by_the_record():
    res = CliRunner().invoke(_command(), ["--level", "0"])
    assert res.exit_code == 2 and "'--level'" in res.output
    for bad, match in (
        (dict(level=0.0), r"level: must be in \(0, 1\], got 0.0"),
        (dict(count=1), "count: must be ≥ 2, got 1"),
        (dict(band=(0.0, -1.0)), "band: must be ≥ 0, got -1.0"),
        (dict(level=float("nan")), "level: must be in"),
    ):
        with pytest.raises(OptionError, match=match):
            _Knobs(**bad)


def test_a_range_is_described_as_written():
    assert OptionSpec("", low=0, low_open=True).describe() == "> 0"
    assert OptionSpec("", low=1).describe() == "≥ 1"
    assert OptionSpec("", high=5, high_open=True).describe() == "< 5"
    assert OptionSpec("", low=0, high=1, high_open=True).describe() == "in [0, 1)"
    assert OptionSpec("", low=0, what="a level").describe() == "a level"
    assert not OptionSpec("").bounded and OptionSpec("", low=0).contains(0)


@pytest.mark.parametrize(
    "cls", [IdentifyOptions, MapOptions, PlanOptions, SessionOptions, ExperimentConfig,
            TorqueConfig],
)  # fmt: skip
def test_every_option_fields_default_lies_in_its_range(cls):
    """The API's defaults pass their own range checks (a record with defaults is valid)."""
    for name in option_names(cls):
        default, spec = option_spec(cls, name)
        for v in default if isinstance(default, tuple) else (default,):
            assert v is None or not spec.bounded or spec.contains(v), (cls.__name__, name)


def test_identify_help_lists_every_option_in_a_section():
    """identify --help groups its options (data, method, MAP, consistent, torques, output);
    every option is named by one section (the help option aside: it comes last)."""
    cmd = cli.get_command(click.Context(cli), "identify")
    assert isinstance(cmd, SectionedCommand)
    named = [n for names in cmd.sections.values() for n in names]
    ctx = click.Context(cmd)
    helps = cmd.get_help_option(ctx)  # listed last, under Output
    params = [p.name for p in cmd.get_params(ctx) if isinstance(p, click.Option) and p is not helps]
    assert sorted(named) == sorted(params) and len(named) == len(set(named))
    out = CliRunner().invoke(cli, ["identify", "--help"]).output
    titles = [t.split(" (")[0] for t in cmd.sections]
    assert titles == ["Data", "Method", "MAP", "Consistent masses", "Joint torques", "Payload",
                      "Output"]  # fmt: skip
    at = [out.index(f"\n{t}") for t in cmd.sections]
    assert at == sorted(at) and out.index("--prior-scale") > at[2] > out.index("--seed")


def test_the_help_says_what_sescid_measures_from():
    """sescid --help and identify --help name the CoP, joint torques, balance and stances."""
    top = " ".join(CliRunner().invoke(cli, ["--help"]).output.split())
    ident = " ".join(CliRunner().invoke(cli, ["identify", "--help"]).output.split())
    for text in (top, ident):
        for word in ("CoP", "joint torques", "balanc", "stance"):
            assert word in text, word
