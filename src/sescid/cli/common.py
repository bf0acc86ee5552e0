"""What every command shares: one-line errors, the robot options and the robot as an input.

Lengths are printed by ``sescid.report.mm`` (the one home of number wording).
"""

from __future__ import annotations

import sys
from typing import Any, get_args

import click

from sescid.base import SEED_HELP
from sescid.cli.flags import FieldOption, flag
from sescid.errors import MissingExtraError, OptionError, SescidError, choices
from sescid.estimation import IdentifyOptions

#: CLI spelling of API parameters that are no flag of the same name, for errors about options
#: (a flag made from an options record's field is found by its name: ``_flag_of``)
FLAG = {
    "n": "--poses",
    "format": "--format",
}


def _flag_of(ctx: click.Context, name: str) -> str | None:
    """The flag of the running command whose parameter, or whose options record's field
    (``FieldOption``), is ``name`` (else ``FLAG``'s)."""
    sub = ctx.invoked_subcommand
    group = ctx.command
    cmd = group.get_command(ctx, sub) if sub and isinstance(group, click.Group) else None
    params = [p for p in (cmd.params if cmd is not None else ()) if isinstance(p, click.Option)]
    for p in params:
        if p.name == name:
            return p.opts[0]
    for p in params:
        if isinstance(p, FieldOption) and p.field == name:
            return p.opts[0]
    return FLAG.get(name)


def fail(message: str) -> None:
    """Print ``sescid: error: message`` and exit with code 2."""
    click.echo(f"sescid: error: {message}", err=True)
    sys.exit(2)


def run_guarded(invoke: Any, ctx: click.Context) -> Any:
    """Run a command; turn library errors, OS errors and Ctrl-C into one line and exit 2."""
    try:
        return invoke(ctx)
    except OptionError as exc:
        flag = _flag_of(ctx, exc.name)
        msg = str(exc)
        fail(f"{flag}{msg[len(exc.name) :]}" if flag else msg)
    except MissingExtraError as exc:
        fail(str(exc))
    except SescidError as exc:
        fail(str(exc))
    except OSError as exc:
        name = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        fail(f"{name}{exc.strerror or exc}")
    except KeyboardInterrupt:
        click.echo("sescid: interrupted (no output written)", err=True)
        sys.exit(130)
    except MemoryError:
        fail("not enough memory for this size (use fewer poses or samples)")


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
        help="Embedded robot name (op2) or a URDF/MJCF file.",
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


def study_options(poses: int, range_deg: float, noise: float) -> Any:
    """--poses, --range-deg, --noise of a simulated study (paper §3), with these defaults."""

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
        return click.option("--poses", default=poses, show_default=True, help="Number of poses.")(f)

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
    """The robot option as an input of a command: the model file it names, or None for an
    embedded robot (``--robot op2`` beside a folder called op2 names the robot, not the folder,
    so outputs may go into that folder)."""
    from sescid.robots import EMBEDDED

    return None if robot_name in EMBEDDED else robot_name


def echo_model_change(fit: Any, fit_file: str) -> None:
    """The warning of a fit whose model file changed since it was made, on stderr."""
    from sescid.estimation import MODEL_CHANGED

    for w in fit.warnings:
        if w.startswith(MODEL_CHANGED):
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
