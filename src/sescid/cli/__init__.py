"""The ``sescid`` command line: a thin shell over the Python API.

Each command parses its options, calls the API, prints. Every error a user can cause is one
line ``sescid: error: …`` with exit code 2; outputs are written atomically. Commands live in one
module per command (``cli/<command>.py``) and are imported only when run, so ``--help`` and
``--version`` answer without loading scipy, matplotlib or the compiled kernels (the ``sescid``
script answers ``--version`` alone before it loads anything: ``_sescid_launch``).
"""

import importlib
from typing import Any, NamedTuple

import click

from sescid.base import VERSION_MESSAGE
from sescid.cli.common import fail, run_guarded, usage_message


class Command(NamedTuple):
    """A command: its line in ``sescid --help``, and where it lives (``cli/<module>.py``, its
    function; both default to the command's name)."""

    help: str
    module: str | None = None
    function: str | None = None

    def where(self, name: str) -> tuple[str, str]:
        """(module, function) of the command called ``name``."""
        return self.module or name, self.function or name


COMMANDS: dict[str, Command] = {
    "simulate": Command("Simulate poses and their CoP, joint torques or balance."),
    "demo": Command("Reproduce the paper's §3 simulation study (the OP2's CoP)."),
    "info": Command("Print the robot's bodies, masses, joints and limits."),
    "identify": Command("Identify masses and CoMs from CoPs, joint torques or balance."),
    "predict": Command("Predict the CoP (or balancing tilt) and CoM at poses from a fit."),
    "export": Command("Write the model file with identified masses and CoMs.", None, "export_cmd"),
    "poses": Command("Plan stable, collision-free, informative poses (any stances)."),
    "experiment": Command("Virtual bench: a raw log of foot sensors, torques or an IMU."),
    "bag": Command("Read a ROS bag into the raw log (joints, torques, foot sensors)."),
    "measure": Command("Reduce a raw log to one CoP and torques per pose.", "fsr", "fsr"),
    "fsr": Command("The same as measure (its former name)."),
    "calibrate": Command("Foot-pad gains and offsets, estimated with the masses."),
    "report": Command("Figures and one HTML page from a fit and what was measured."),
    "truth": Command("Compare a fit with a virtual experiment's truth file."),
    "audit": Command("Score candidate model files against measurements; rank them."),
    "compare": Command(
        "What changed between fits of one robot (bodies, CoM, mass).", "audit", "compare_cmd"
    ),  # fmt: skip
    "session": Command("Guided session: the next-best pose (and stance) until converged."),
    "precompile": Command("Compile the numba kernels now (pip install does it)."),
}


class LazyGroup(click.Group):
    """A group whose commands are imported on first use; errors become one line."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return list(COMMANDS)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name not in COMMANDS:
            return None
        module, function = COMMANDS[name].where(name)
        return getattr(importlib.import_module(f"{__name__}.{module}"), function)

    def format_commands(self, ctx: click.Context, formatter: Any) -> None:
        rows = [(name, c.help) for name, c in COMMANDS.items()]
        with formatter.section("Commands"):
            formatter.write_dl(rows)

    def invoke(self, ctx: click.Context) -> Any:
        return run_guarded(super().invoke, ctx)

    def make_context(self, info_name, args, parent=None, **extra) -> click.Context:
        """The group's own options parsed; a mistyped one is one line (``run_guarded``)."""
        try:
            return super().make_context(info_name, args, parent=parent, **extra)
        except click.UsageError as exc:
            if type(exc).__name__ == "NoArgsIsHelpError":
                raise
            fail(usage_message(exc))
            raise  # unreachable: fail exits


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="sescid", message=VERSION_MESSAGE)
def cli() -> None:
    r"""Identify a humanoid robot's mass distribution (its bodies' masses and centres of mass)
    from what it measures while held still: the centre of pressure (CoP) under its feet, its
    joint torques, or its balance on a line (a wheel axle, an edge). Measurements made in
    several stances (either foot, both feet, held in a gantry) pool into one fit.

    \b
    A bench session: poses → experiment (or the robot) → measure → identify → report.
    Try it: sescid demo; each command's options: sescid COMMAND --help.
    """


def main() -> None:
    """Run the command line. The ``sescid`` script enters through ``_sescid_launch.main``, which
    pins BLAS before numpy loads; here, numpy loaded, only libraries loaded later (scipy's
    BLAS) follow the thread variables (``sescid.base.threads``)."""
    from sescid.base import pin_process

    pin_process()
    cli(prog_name="sescid")


__all__ = ["COMMANDS", "Command", "cli", "main"]
