"""``sescid predict``: CoP and CoM at poses from a fit, with intervals."""

from __future__ import annotations

import click
import numpy as np

from sescid.base import OutputSet
from sescid.cli import common
from sescid.estimation import (
    com_interval,
    for_support,
    load_fit,
)
from sescid.io import (
    read_poses,
    read_table,
    write_table,
)


@click.command()
@click.argument("fit_file", type=common.FILE)
@click.argument("poses", type=common.FILE)
@common.file_option("--out", "Output CSV.", required=True)
@click.option(
    "--level",
    type=click.FloatRange(0, 1, min_open=True, max_open=True),
    default=None,
    help="Add <col>_lower/<col>_upper interval columns at this confidence (e.g. 0.95). "
    "The CoM-z interval omits the error of its prior-filled part (com_z_from_prior).",
)
@click.option(
    "--support",
    "stance",
    default=None,
    help="Predict in another stance of a fit pooled over stances (the other foot, a held "
    "link): its frame name (default: the fit's support).",
)
@common.imu_link_option
@common.force_option
def predict(fit_file, poses, out, level, stance, imu_link, force):
    """Predict CoP (x, y) and CoM (x, y, z) in metres at the poses of a CSV (radians).

    With columns grav_x, grav_y, grav_z (or imu_roll, imu_pitch of the IMU link) the CoP is
    projected along that gravity direction; its interval then includes the CoM-height
    uncertainty through g_xy/g_z. For a robot balancing on a line (a fit made with --line):
    balance_tilt [rad], the tilt about the line that balances the robot at each pose (the
    IMU's pitch for an axle along y), with its standard error, instead of the CoP.
    """
    from sescid.estimation import balance_interval, cop_interval
    from sescid.sensors import table_gravity

    outs = OutputSet([out], [fit_file, poses], force=force)
    fit = load_fit(fit_file)
    if stance is not None:
        fit = for_support(fit, stance)
    table = read_table(poses)
    q = read_poses(table, fit.robot.joint_names, fit.robot.profile.servo)
    line = fit.robot.line is not None  # no CoP on a line: the tilt that balances instead
    gravity = None if line else table_gravity(fit.robot, table, q, imu_link)
    com = fit.predict_com(q)
    std = fit.predict_std(q)
    cols: dict[str, np.ndarray] = {}
    if line:
        cols["balance_tilt"] = fit.predict_balance(q)
        cols["balance_tilt_std"] = fit.predict_balance_std(q)
    else:
        cop = fit.predict_cop(q, gravity)
        cols |= {"cop_x": cop[:, 0], "cop_y": cop[:, 1]}
    cols |= {
        "com_x": com[:, 0],
        "com_y": com[:, 1],
        "com_z": com[:, 2],
        "com_x_std": std[:, 0],
        "com_y_std": std[:, 1],
        "com_z_std": std[:, 2],
        "com_z_from_prior": fit.com_z_from_prior(q),
    }
    if level is not None:
        iv = com_interval(fit, q, level)  # CoP = CoM x, y
        for j, name in enumerate(("com_x", "com_y", "com_z")):
            cols[f"{name}_lower"], cols[f"{name}_upper"] = iv.lower[:, j], iv.upper[:, j]
        if line:
            biv = balance_interval(fit, q, level)
            cols["balance_tilt_lower"], cols["balance_tilt_upper"] = biv.lower, biv.upper
        else:
            civ = cop_interval(fit, q, level, gravity=gravity)  # with g_xy/g_z · CoM-height
            for j, name in enumerate(("cop_x", "cop_y")):
                cols[f"{name}_lower"], cols[f"{name}_upper"] = civ.lower[:, j], civ.upper[:, j]
    with outs:
        write_table(outs.path(out), cols)
    lost = int(np.sum(np.isnan(std[:, 0])))
    if lost:
        click.echo(
            f"sescid: warning: at {lost} of {len(q)} poses the fit's data do not determine the "
            f"CoP (rank {fit.rank}): their std and interval columns are nan (not determined)",
            err=True,
        )
    for w in fit.warnings:
        click.echo(f"sescid: warning: {fit_file}: {w}", err=True)
    if fit.payload is not None:
        click.echo(f"predictions include the {fit.payload.summary().splitlines()[0]}")
    click.echo(f"wrote {out}: {len(q)} poses")
