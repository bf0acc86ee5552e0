"""The ``sescid`` command line: a thin shell over the Python API.

Each command parses its options, calls the API, prints. Every error a user can cause is one
line ``sescid: error: …`` with exit code 2; outputs are written atomically. Commands live in one
module per command (``cli/<command>.py``) and are imported only when run, so ``--help`` and
``--version`` answer without loading scipy, matplotlib or the compiled kernels (the ``sescid``
script answers ``--version`` alone before it loads anything: ``_sescid_launch``).
"""

import importlib
from typing import Any

import click

from _sescid_launch import VERSION_MESSAGE
from sescid.cli.common import fail, run_guarded, usage_message

#: command → (module, function, one-line help shown by ``sescid --help``)
COMMANDS: dict[str, tuple[str, str, str]] = {
    "simulate": (
        "simulate",
        "simulate",
        "Simulate poses and what they give: CoP, joint torques (paper §3).",
    ),
    "demo": ("demo", "demo", "Reproduce the paper's §3 simulation study."),
    "info": ("info", "info", "Print the robot's bodies, masses, joints and limits."),
    "identify": (
        "identify",
        "identify",
        "Identify the SESC vectors from poses with CoPs and/or joint torques.",
    ),
    "predict": ("predict", "predict", "Predict CoP and CoM at poses from a fit."),
    "export": ("export", "export_cmd", "Write the model file with identified masses and CoMs."),
    "poses": ("poses", "poses", "Plan stable, collision-free, informative bench poses."),
    "experiment": ("experiment", "experiment", "Virtual bench experiment: a raw sensor log."),
    "bag": (
        "bag",
        "bag",
        "Read a ROS bag into the raw log: foot sensors, joint torques (mapping file).",
    ),
    "measure": ("fsr", "fsr", "Reduce a raw log to one measurement (CoP, torques) per pose."),
    "fsr": ("fsr", "fsr", "The same as measure (its former name)."),
    "calibrate": (
        "calibrate",
        "calibrate",
        "Foot-pad gains and offsets estimated with the masses from raw sessions.",
    ),
    "report": ("report", "report", "Figures and one self-contained HTML page from a fit."),
    "truth": ("truth", "truth", "Compare a fit with a virtual experiment's truth file."),
    "session": ("session", "session", "Guided identification: next-best pose until converged."),
    "precompile": (
        "precompile",
        "precompile",
        "Compile the numba kernels into numba's cache now (pip install does it).",
    ),
}


class LazyGroup(click.Group):
    """A group whose commands are imported on first use; errors become one line."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return list(COMMANDS)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name not in COMMANDS:
            return None
        module, attr, _ = COMMANDS[name]
        return getattr(importlib.import_module(f"{__name__}.{module}"), attr)

    def format_commands(self, ctx: click.Context, formatter: Any) -> None:
        rows = [(name, short) for name, (_, _, short) in COMMANDS.items()]
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
    """Identify a humanoid robot's mass distribution from what it measures while held still:
    the centre of pressure under its foot and/or its joint torques."""


def main() -> None:
    """Run the command line. The ``sescid`` script enters through ``_sescid_launch.main``, which
    pins BLAS before numpy loads; here, numpy loaded, only libraries loaded later (scipy's
    BLAS) follow the thread variables (``sescid.base.threads``)."""
    from sescid.base import pin_process

    pin_process()
    cli(prog_name="sescid")


__all__ = ["COMMANDS", "cli", "main"]
