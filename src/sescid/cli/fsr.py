"""``sescid fsr``: a raw foot-sensor log reduced to one CoP per pose."""

from __future__ import annotations

import click
import numpy as np

from sescid.base.files import OutputSet
from sescid.cli.common import (
    force_option,
    imu_link_option,
    load,
    min_samples_option,
    mm,
    robot_options,
    sensors_option,
)
from sescid.io import read_table, write_table
from sescid.sensors import fsr as run_fsr
from sescid.sensors import load_sensors
from sescid.sensors.pads import REASONS


@click.command()
@click.argument("raw", type=click.Path(dir_okay=False))
@robot_options
@sensors_option
@click.option(
    "--poses",
    "poses_file",
    default=None,
    type=click.Path(dir_okay=False),
    help="Pose list: every pose id in the log must be in it (its 'pose' column or row number).",
)
@min_samples_option
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Output CSV.")
@imu_link_option
@force_option
def fsr(raw, robot_name, support, sensors_file, poses_file, min_samples, out, imu_link, force):
    """Reduce a raw foot-sensor log to one CoP per pose (support frame, m) with its error.

    Writes pose, joint columns (mean read-backs, rad), cop_x, cop_y, cop_se_x, cop_se_y (m),
    n_used, n_rejected, reject_reasons, and force_n (mean total force, N) when forces are logged.
    """
    outs = OutputSet([out], [raw, poses_file, sensors_file, robot_name], force=force)
    robot = load(robot_name, support)
    config = load_sensors(sensors_file, robot.profile)
    pose_list = read_table(poses_file) if poses_file is not None else None
    res, unmeasured = run_fsr(robot, read_table(raw), config, min_samples, pose_list, imu_link)
    with outs:
        write_table(outs.path(out), res.columns(robot.joint_names))
    total = res.rejected.sum(axis=0)
    why = ", ".join(f"{r} {int(c)}" for r, c in zip(REASONS, total, strict=True) if c) or "none"
    click.echo(
        f"{len(res.pose)} poses from {res.mode}: {int(res.n_used.sum())} samples used "
        f"(median {int(np.median(res.n_used))} per pose), rejected: {why}"
    )
    if res.mode == "forces":
        click.echo(
            f"  mean measured weight {np.mean(res.force) / 9.80665:.4f} kg "
            f"(model {robot.total_mass:.4f} kg); mean CoP standard error "
            f"x {mm(float(np.mean(res.cop_se[:, 0])))}, y {mm(float(np.mean(res.cop_se[:, 1])))}"
        )
    for pose, reason in res.dropped:
        click.echo(f"  pose {pose} has no CoP: {reason}", err=True)
    if unmeasured:
        more = f" (and {len(unmeasured) - 5} more)" if len(unmeasured) > 5 else ""
        click.echo(
            f"  {len(unmeasured)} poses of the list were not measured: "
            f"{', '.join(unmeasured[:5])}{more}",
            err=True,
        )
    click.echo(f"wrote {out}")
