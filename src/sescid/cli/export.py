"""``sescid export``: the model file with identified masses and CoMs."""

from __future__ import annotations

import click
import numpy as np

from sescid.base import OutputSet
from sescid.cli import common
from sescid.cli.flags import flag, record
from sescid.cli.options import consistent_options, echo_masses
from sescid.errors import OptionError
from sescid.estimation import ConsistentOptions, load_fit, to_consistent
from sescid.io import (
    FORMATS,
    check_inertias,
    export_model,
    model_files,
    repairs_summarised,
)


@click.command("export")
@click.argument("fit_file", type=common.FILE)
@common.file_option("--out", "Output model file.", required=True)
@click.option(
    "--format",
    "model_format",
    type=click.Choice(FORMATS),
    default=None,
    help="Output format (default: the model's own; URDF ↔ MJCF conversion is not supported).",
)
@click.option(
    "--over",
    "over",
    type=common.FILE,
    default=None,
    help="USD output: the robot's own USD file the layer overrides (bodies matched by prim "
    "name); without it the layer holds the body tree itself.",
)
@click.option(
    "--repair-inertia",
    is_flag=True,
    help="Repair CAD inertia tensors that are not physically consistent (point masses, the "
    "triangle inequality broken) with the smallest change, each reported; without it such a "
    "model is refused.",
)
@flag(ConsistentOptions, "total_mass")
@consistent_options
@common.force_option
def export_cmd(fit_file, out, model_format, over, repair_inertia, force, **opts):
    """Write the fit's URDF or MJCF with the identified masses and CoMs, or (--out *.usda,
    *.usdc, *.usd) a UsdPhysics layer; each body's inertia about its CoM stays CAD's (the
    consistent tensor closest to it, docs/export.md).

    A fit without masses (e.g. least squares) first goes through the consistent step with the
    --total-mass/--mass-floor/--symmetric/--box-margin/--cad-std options.
    """
    OutputSet([out], [fit_file], force=force)
    fit = load_fit(fit_file)
    common.echo_model_change(fit, fit_file)
    inputs = [fit_file, *model_files(fit.robot.model_path), *([over] if over else [])]
    outs = OutputSet([out], inputs, force=force)
    copts = record(ConsistentOptions, opts)
    check_inertias(fit.robot.model, fit.robot.model_path, repair_inertia)
    if fit.inertials is None:
        click.echo(f"{fit_file}: the {fit.method} fit has no masses; running the consistent step")
        fit = to_consistent(fit, copts)
        echo_masses(fit)
    elif copts != ConsistentOptions():
        raise OptionError(
            "consistent_options",
            f"{fit_file}: this fit already holds masses; the consistent options apply only to "
            "fits without (re-run identify --method consistent to change them)",
        )
    else:
        for note in fit.inertials.notes:
            click.echo(f"  note: {note}")
    from sescid.estimation import cad_violations

    assert fit.inertials is not None
    for line in cad_violations(fit.inertials, fit.robot.body_names):
        click.echo(f"  {line}")
    with outs:
        warnings = export_model(fit, outs.path(out), model_format, repair_inertia, over)
    for warning in repairs_summarised(warnings):
        click.echo(f"sescid: warning: {warning}", err=True)
    assert fit.inertials is not None
    total = float(np.sum(fit.inertials.masses))
    model = fit.robot.total_mass
    how = (
        "the given --total-mass" if copts.total_mass is not None
        else "the weighed mass the fit was given" if fit.mass_given
        else "the model's: weigh the robot and give --total-mass" if abs(total - model) < 1e-9
        else "from the fit"
    )  # fmt: skip
    click.echo(
        f"wrote {out}: {fit.robot.name} with identified masses (total {total:.4f} kg, {how})"
    )
