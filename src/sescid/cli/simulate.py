"""``sescid simulate``: random poses and the CoP they give, with noise (paper §3)."""

from __future__ import annotations

import click
import numpy as np

from sescid.base.files import OutputSet
from sescid.cli.common import force_option, load, robot_options, seed_option
from sescid.simulation import PAPER_NOISE, PAPER_POSES, PAPER_RANGE_DEG


@click.command()
@robot_options
@click.option("--poses", default=PAPER_POSES, show_default=True, help="Number of poses.")
@click.option(
    "--range-deg",
    default=PAPER_RANGE_DEG,
    show_default=True,
    help="Joints uniform in ±range [degrees].",
)
@click.option(
    "--noise", default=PAPER_NOISE, show_default=True, help="CoP noise standard deviation [m]."
)
@seed_option
@click.option(
    "--clip/--no-clip",
    default=None,
    help="Clip the poses to the joint limits [default: clip, except for a robot whose profile "
    "carries the paper's convention (op2: the paper's ±30° study is unclipped)].",
)
@click.option("--stable", is_flag=True, help="Keep only poses whose CoP is inside the sole.")
@click.option(
    "--tilt-deg",
    default=0.0,
    show_default=True,
    type=click.FloatRange(0, 30),
    help="Tilt the support per pose by a random roll and pitch of this standard deviation "
    "[degrees]; writes grav_x, grav_y, grav_z.",
)
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Output CSV.")
@force_option
def simulate(
    robot_name, support, poses, range_deg, noise, seed, clip, stable, tilt_deg, out, force
):
    """Simulate poses and CoP measurements (paper §3) into a CSV.

    Columns: one per joint (radians), cop_x, cop_y (noisy, m), cop_x_true, cop_y_true (m);
    with --tilt-deg also grav_x, grav_y, grav_z (gravity direction in the support frame).
    """
    import math

    from sescid.io import write_table
    from sescid.simulation import simulate as run_simulate

    outs = OutputSet([out], [robot_name], force=force)
    robot = load(robot_name, support)
    if clip is None:
        clip = robot.profile.paper_limits_file is None
    sim = run_simulate(
        robot, poses, range_deg, noise, seed, clip, stable=stable, tilt=math.radians(tilt_deg)
    )
    cols = {name: sim.q[:, j] for j, name in enumerate(robot.joint_names)}
    cols |= {"cop_x": sim.cop[:, 0], "cop_y": sim.cop[:, 1]}
    cols |= {"cop_x_true": sim.cop_true[:, 0], "cop_y_true": sim.cop_true[:, 1]}
    if sim.gravity is not None:
        cols |= {f"grav_{a}": sim.gravity[:, i] for i, a in enumerate("xyz")}
    with outs:
        write_table(outs.path(out), cols)
    click.echo(f"wrote {out}: {poses} poses of {robot.name}, noise {noise} m")
    if clip:
        click.echo(f"  clipped to the joint limits: {sim.n_clipped} of {poses} poses")
    else:
        lim = robot.joint_limits
        out_of = int(np.sum(np.any((sim.q < lim[:, 0]) | (sim.q > lim[:, 1]), axis=1)))
        click.echo(f"  not clipped: {out_of} of {poses} poses exceed a joint limit")
    if stable:
        click.echo(
            f"  --stable: {sim.n_drawn - poses} of {sim.n_drawn} draws rejected "
            f"(CoP outside the sole {robot.sole.size[0]:.3f} x {robot.sole.size[1]:.3f} m)"
        )
