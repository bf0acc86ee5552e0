"""``sescid info``: the robot's bodies, masses, SESC vectors, joints and limits."""

from __future__ import annotations

import click
import numpy as np

from sescid.cli.common import load, robot_options


@click.command()
@robot_options
def info(robot_name, support):
    """Print the robot's bodies, masses, joints and limits."""
    robot = load(robot_name, support)
    click.echo(repr(robot))
    click.echo(f"model file: {robot.model_path}")
    for note in robot.model.notes:
        click.echo(f"note: {note}")
    click.echo("bodies (index 0 = support body):")
    r = robot.sesc_vectors()
    for i, (b, m) in enumerate(zip(robot.body_names, robot.masses, strict=True)):
        rr = " ".join(f"{v * 1e3:8.3f}" for v in r[i])
        click.echo(f"  {i:2d} {b:24s} {m:8.4f} kg   r = [{rr}] mm")
    click.echo("joints (column order of q; limits in degrees):")
    for name, (lo, hi) in zip(robot.joint_names, np.degrees(robot.joint_limits), strict=True):
        click.echo(f"  {name:24s} [{lo:8.1f}, {hi:8.1f}]")
