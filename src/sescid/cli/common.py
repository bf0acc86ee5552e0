"""What every command shares: one-line errors, the robot options and the robot as an input.

Lengths are printed by ``sescid.report.mm`` (the one home of number wording).
"""

from __future__ import annotations

import contextlib
import sys
from typing import Any, get_args

import click

from sescid.base import SEED_HELP
from sescid.cli.flags import FieldOption, flag
from sescid.errors import MissingExtraError, OptionError, SescidError, choices
from sescid.estimation import IdentifyOptions

#: CLI spelling of API parameters that are no flag of the same name, for errors about options
#: (a flag made from an options record's field is found by its field: ``option_message``)
FLAG = {
    "n": "--count",
    "count": "--count",
    "range_deg": "--range-deg",
    "noise": "--noise",
    "rtol": "--rtol",
    "seed": "--seed",
    "samples": "--samples",
    "method": "--method",
    "format": "--format",
}


def fail(message: str) -> None:
    """Print ``sescid: error: message`` and exit with code 2."""
    click.echo(f"sescid: error: {message}", err=True)
    sys.exit(2)


def run_guarded(invoke: Any, ctx: click.Context) -> Any:
    """Run a command; turn usage errors, library errors, OS errors and Ctrl-C into one line
    and exit 2."""
    try:
        return invoke(ctx)
    except click.UsageError as exc:
        if type(exc).__name__ == "NoArgsIsHelpError":  # bare `sescid`: the help
            raise
        fail(usage_message(exc, ctx))
    except OptionError as exc:
        fail(option_message(exc, _invoked(ctx)))
    except MissingExtraError as exc:
        fail(str(exc))
    except SescidError as exc:
        fail(str(exc))
    except BrokenPipeError:  # the reader left (`| head`): stop quietly
        import os

        with contextlib.suppress(OSError, ValueError, AttributeError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        sys.exit(141)
    except OSError as exc:
        name = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        fail(f"{name}{exc.strerror or exc}")
    except KeyboardInterrupt:
        click.echo("sescid: interrupted (no output written)", err=True)
        sys.exit(130)
    except MemoryError:
        fail("not enough memory for this size (use fewer poses or samples)")
    except (click.exceptions.Exit, click.exceptions.Abort, click.ClickException):
        raise
    except Exception as exc:  # a bug, not the input: one line all the same
        import os

        if os.environ.get(TRACEBACK_ENV):
            raise
        what = " ".join(str(exc).split())
        click.echo(
            f"sescid: internal error: {type(exc).__name__}: {what} (a bug in sescid: please "
            f"report it with the command; {TRACEBACK_ENV}=1 shows the traceback)",
            err=True,
        )
        sys.exit(INTERNAL_ERROR)


#: the environment variable that lets an internal error's traceback through
TRACEBACK_ENV = "SESCID_TRACEBACK"
#: exit code of an internal error (a bug; bad input exits 2)
INTERNAL_ERROR = 1


def _invoked(ctx: click.Context) -> click.Command | None:
    """The sub-command a group's context is running (None when unknown)."""
    name = ctx.invoked_subcommand
    group = ctx.command
    if name is None or not isinstance(group, click.Group):
        return None
    return group.get_command(ctx, name)


def option_message(exc: OptionError, command: click.Command | None) -> str:
    """An API parameter's error in the CLI's words: the flag that sets it named first."""
    rest = str(exc)[len(exc.name) + 2 :]
    if rest.startswith("--"):
        return rest  # the message names its flags itself
    params = [
        p for p in (command.params if command is not None else ()) if isinstance(p, click.Option)
    ]
    named = [p for p in params if p.name == exc.name]  # else a flag made from a record's field
    named = named or [p for p in params if isinstance(p, FieldOption) and p.field == exc.name]
    flag = max(named[0].opts, key=len) if named else FLAG.get(exc.name)
    return f"{flag}: {rest}" if flag else str(exc)


def usage_message(exc: click.UsageError, group_ctx: click.Context | None = None) -> str:
    """A usage error (a mistyped command or option, a missing or bad value) as one line,
    with the closest command or option suggested; ``group_ctx`` (the group's context) names
    the command when the error carries no context of its own."""
    import difflib

    ctx = exc.ctx
    name = ctx.info_name if ctx is not None and ctx.parent is not None else None
    command = ctx.command if ctx is not None else None
    if ctx is None and group_ctx is not None and group_ctx.invoked_subcommand:
        name, command = group_ctx.invoked_subcommand, _invoked(group_ctx)
    where = f"{name}: " if name else ""
    help_hint = f"sescid {name} --help" if name else "sescid --help"
    text = " ".join(exc.format_message().split())
    unknown = getattr(exc, "option_name", None)
    if isinstance(exc, click.NoSuchOption) and unknown and command is not None:
        names = [o for p in command.params for o in [*p.opts, *p.secondary_opts]]
        near = difflib.get_close_matches(unknown, names, n=1, cutoff=0.5)
        hint = f"did you mean {near[0]}?" if near else f"{help_hint} lists them"
        return f"{where}no option {unknown} ({hint})"
    name = getattr(exc, "command_name", None) or _no_such_command(text)
    if name is not None and isinstance(command, click.Group):
        near = difflib.get_close_matches(name, command.list_commands(ctx), n=1, cutoff=0.4)  # type: ignore[arg-type]
        hint = f"did you mean {near[0]}?" if near else f"{help_hint} lists them"
        return f"{where}no command '{name}' ({hint})"
    return f"{where}{text.rstrip('.')} (see {help_hint})"


def _no_such_command(text: str) -> str | None:
    """The name in click's "No such command 'X'." (older click has no NoSuchCommand)."""
    import re

    m = re.match(r"No such command '(.*)'\.", text)
    return m.group(1) if m else None


def given(name: str) -> bool:
    """True when the running command's parameter ``name`` was set on the command line (or
    by its environment variable), not left at its default."""
    from click.core import ParameterSource

    ctx = click.get_current_context(silent=True)
    if ctx is None:
        return False
    source = ctx.get_parameter_source(name)
    return source in (ParameterSource.COMMANDLINE, ParameterSource.ENVIRONMENT)


def refuse_idle(names: Any, acts: bool, why: str) -> None:
    """OptionError for a parameter of ``names`` given on the command line while it does
    nothing (``acts`` False), e.g. ``--friction`` without ``--torques``; ``why`` ends the
    message ("without --torques: no joint torque is measured")."""
    if acts:
        return
    for name in [names] if isinstance(names, str) else names:
        if given(name):
            raise OptionError(name, f"does nothing {why}")


def _keep_line(ctx: click.Context, _param: Any, value: str | None) -> None:
    """Keep --line for ``load`` (every command that loads a robot takes it)."""
    ctx.meta["sescid.line"] = value


def robot_options(f: Any) -> Any:
    """--robot/--support/--line, shared by every command that loads a robot."""
    f = click.option(
        "--line",
        default=None,
        expose_value=False,
        callback=_keep_line,
        help="The support is a line through the support frame's origin (a wheel axle, an "
        "edge) with this direction in that frame: x, y, z, -y, … or ax,ay,az. Default: the "
        "profile's, else none (a sole or a held link).",
    )(f)
    f = click.option(
        "--support",
        default=None,
        help="Support frame the robot stands on (a sole link, foot link or site). "
        "Default: the profile's (r_sole for op2).",
    )(f)
    f = click.option(
        "--robot",
        "robot_name",
        default="op2",
        show_default=True,
        help="Embedded robot name (op2), an example model shipped with sescid "
        "(wheeled_humanoid, humanoid) or a URDF/MJCF file.",
    )(f)
    return f


#: a file argument or flag: a path that is not a folder
FILE = click.Path(dir_okay=False)


def file_option(flag: str, help: str, param: str | None = None, *, required: bool = False) -> Any:  # noqa: A002
    """A flag naming a file (not a folder); ``param``: the handler's name for it."""
    names = [flag] if param is None else [flag, param]
    return click.option(*names, required=required, default=None, type=FILE, help=help)


def folder_option(flag: str, help: str, default: str | None = None, *, required: bool = False):  # noqa: A002
    """A flag naming a folder (not a file), its default shown."""
    kind = click.Path(file_okay=False)
    return click.option(flag, default=default, show_default=default is not None,
                        required=required, type=kind, help=help)  # fmt: skip


def choice_option(flag: str, values: Any, default: Any, help: str) -> Any:  # noqa: A002
    """A flag taking one of ``values`` (a ``Literal`` alias: its choices, or a sequence)."""
    allowed = choices(values) if get_args(values) else values
    kind = click.Choice([str(v) for v in allowed])
    return click.option(
        flag, type=kind, default=default, show_default=default is not None, help=help
    )


def number_option(flag: str, default: float, low: float | None, high: float | None, help: str):  # noqa: A002
    """A number flag within [low, high] (None: unbounded), an integer when ``default`` is."""
    kind: Any = click.IntRange if isinstance(default, int) else click.FloatRange
    return click.option(flag, default=default, show_default=True, type=kind(low, high), help=help)


def seed_option(f: Any) -> Any:
    """--seed: a non-negative integer."""
    return click.option(
        "--seed", default=0, show_default=True, type=click.IntRange(min=0), help=SEED_HELP
    )(f)


class FormerName(click.Option):
    """An option whose later names are former ones: accepted, not shown by ``--help``."""

    def get_help_record(self, ctx: click.Context) -> tuple[str, str] | None:
        """The help line with the current name only."""
        names = self.opts
        self.opts = names[:1]
        try:
            return super().get_help_record(ctx)
        finally:
            self.opts = names

    def get_error_hint(self, ctx: click.Context | None) -> str:
        """The current name in error messages."""
        return f"'{self.opts[0]}'"


def study_options(poses: int, range_deg: float, noise: float) -> Any:
    """--count, --range-deg, --noise of a simulated study (paper §3), with these defaults
    (``--poses`` N, the count's former name, is still read: elsewhere --poses names a file)."""

    def wrap(f: Any) -> Any:
        f = click.option(
            "--noise", default=noise, show_default=True, help="CoP noise standard deviation [m]."
        )(f)
        f = click.option(
            "--range-deg",
            default=range_deg,
            show_default=True,
            help="Joints uniform in ±range [degrees].",
        )(f)
        return click.option(
            "--count",
            "--poses",
            "poses",
            cls=FormerName,
            default=poses,
            show_default=True,
            type=click.IntRange(min=1),
            help="Number of random poses.",
        )(f)

    return wrap


def imu_link_option(f: Any) -> Any:
    """--imu-link: the link whose IMU roll/pitch columns give gravity (no grav_x/y/z), as
    identify's (``IdentifyOptions.imu_link``)."""
    return flag(IdentifyOptions, "imu_link")(f)


def force_option(f: Any) -> Any:
    """--force: replace write-protected output files (inputs, devices and folders never)."""
    return click.option("--force", is_flag=True, help="Replace write-protected output files.")(f)


def load(robot_name: str, support: str | None) -> Any:
    """The robot named on the command line."""
    from sescid.robot import load_robot

    ctx = click.get_current_context(silent=True)
    line = None if ctx is None else ctx.meta.get("sescid.line")
    return load_robot(robot_name, support, line)


def model_input(robot_name: str) -> str | None:
    """The robot option as an input of a command: the model file it names (an example model's
    shipped file for its name), or None for an embedded robot (``--robot op2`` beside a folder
    called op2 names the robot, not the folder, so outputs may go into that folder)."""
    from sescid.robots import EMBEDDED, EXAMPLES

    if robot_name in EMBEDDED:
        return None
    return str(EXAMPLES[robot_name]) if robot_name in EXAMPLES else robot_name


def echo_model_change(fit: Any, fit_file: str) -> None:
    """The warnings of a fit read back (its model file changed since it was made, an older
    file format), on stderr."""
    from sescid.estimation import MODEL_CHANGED, OLD_FORMAT

    for w in fit.warnings:
        if w.startswith((MODEL_CHANGED, OLD_FORMAT)):
            click.echo(f"sescid: warning: {fit_file}: {w}", err=True)


def sensors_option(f: Any) -> Any:
    """--sensors: the foot-sensor file (default: the robot profile's)."""
    return file_option(
        "--sensors",
        "Foot-sensor configuration JSON (default: the robot profile's; for op2 a hypothesis).",
        "sensors_file",
    )(f)


def min_samples_option(f: Any) -> Any:
    """--min-samples: usable samples a pose needs."""
    return click.option(
        "--min-samples",
        default=5,
        show_default=True,
        type=click.IntRange(min=1),
        help="Usable samples per pose.",
    )(f)
