"""``sescid info``: the robot's bodies, masses, SESC vectors, joints and limits."""

from __future__ import annotations

import click
import numpy as np

from sescid.cli import common
from sescid.robot import Robot


@click.command()
@common.robot_options
def info(robot_name, support):
    """Print the robot's bodies, masses, joints and limits, and, for a model file without
    --support, its support candidates (its feet, found from the tree and the geometry)."""
    from sescid.errors import MissingExtraError
    from sescid.robots import EMBEDDED

    feet, unread = None, None
    if support is None and robot_name not in EMBEDDED:
        from sescid.model import root_frame, support_candidates

        root, _ = root_frame(robot_name)
        robot = common.load(robot_name, root)
        try:
            feet = support_candidates(robot_name)
        except MissingExtraError as exc:
            feet, unread = [], str(exc)
    else:
        robot = common.load(robot_name, support)
    try:
        mesh_notes = robot.geometry_notes
    except MissingExtraError as exc:
        mesh_notes, unread = [], str(exc)
    click.echo(repr(robot))
    click.echo(f"model file: {robot.model_path}")
    if feet is not None:
        click.echo(f"no --support: rooted at the model's root '{robot.support}'")
        _echo_feet(feet, unread, bool(mesh_notes))
    elif unread:
        click.echo(f"mesh geometry not read: {unread}")
    for note in [*robot.model.notes, *mesh_notes]:
        click.echo(f"note: {note}")
    click.echo("bodies (index 0 = support body):")
    r = robot.sesc_vectors()
    for i, (b, m) in enumerate(zip(robot.body_names, robot.masses, strict=True)):
        rr = " ".join(f"{v * 1e3:8.3f}" for v in r[i])
        click.echo(f"  {i:2d} {b:24s} {m:8.4f} kg   r = [{rr}] mm")
    _echo_inertias(robot)
    click.echo("joints (column order of q; limits in degrees):")
    for name, (lo, hi) in zip(robot.joint_names, np.degrees(robot.joint_limits), strict=True):
        click.echo(f"  {name:24s} [{lo:8.1f}, {hi:8.1f}]")


def _echo_feet(feet, unread: str | None = None, lost: bool = False) -> None:
    """The support candidates, one foot a line, best frame first; ``unread``: why the mesh
    geometry they are found from could not be read; ``lost``: some mesh files were not."""
    if unread:
        click.echo(f"support candidates: unknown: {unread}")
        return
    if not feet:
        why = (
            "mesh files not found or unreadable: see the notes"
            if lost
            else "no body with a flat face near the floor"
        )
        click.echo(f"support candidates: no foot found ({why})")
        return
    click.echo("support candidates (feet from the tree and the geometry; the first frame of each")
    click.echo("  is the one to give as --support: level, on the sole plane if one is):")
    for f in feet:
        click.echo(f"  {f.describe()}")


def _echo_inertias(robot: Robot) -> None:
    """Every link whose CAD inertia tensor is a point mass's or not physical, by how much."""
    from sescid.model import inertia_problems

    problems = inertia_problems(robot.model)
    if not problems:
        click.echo("inertia tensors: every link with mass has a physical one")
        return
    click.echo(
        f"inertia tensors: {len(problems)} link(s) with mass whose tensor is not positive "
        "definite or breaks the triangle inequality (export --repair-inertia repairs them):"
    )
    for p in problems:
        click.echo(f"  {p.text()}")
