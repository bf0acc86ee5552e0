"""Commands that turn a robot's recordings into the raw log the ``fsr`` step reads: bag."""

from __future__ import annotations

import click
import numpy as np

from sescid.base import OutputSet
from sescid.cli import common
from sescid.errors import DataError
from sescid.io import read_bag
from sescid.sensors import pose_list_ids
from sescid.tables import SUPPORT_COLUMN, read_poses, read_table, write_table


@click.command()
@click.argument("bag", nargs=-1, required=True, type=click.Path())
@common.file_option(
    "--map",
    "Mapping file (YAML or JSON, sescid-bag-mapping/1): which topics hold the joints, the joint "
    "torques, each foot's force source and the pose ids (see docs/io.md).",
    "map_file",
    required=True,
)
@common.robot_options
@common.file_option(
    "--poses",
    "Planned pose list: stationary segments take the id of the nearest planned pose (within "
    "the mapping's match_deg), and its stance (its 'support' column); segments matching none "
    "are dropped.",
    "poses_file",
)
@common.file_option("--out", "Raw log for `sescid measure` (.csv, or .parquet).", required=True)
@common.force_option
def bag(bag, map_file, robot_name, support, poses_file, out, force):
    """Read a ROS bag (rosbag2 directory, sqlite3 or MCAP; or ROS 1 .bag files) into the raw log.

    Writes pose, t (s), the joint columns (rad), the joint torques the mapping names
    (tau_<joint>, N·m) and per foot the pad forces (<p>_fsr1..4, mN) or a CoP in its sole frame
    (<p>_cop_x, <p>_cop_y, m) with its normal force (<p>_fz, N). The output may not lie inside
    the recording. Needs the bags extra: pip install 'sescid[bags]' (in a clone: pip install
    '.[bags]').
    """
    outs = OutputSet(
        [out], [*bag, map_file, poses_file, common.model_input(robot_name)], force=force
    )
    robot = common.load(robot_name, support)
    poses = stances = None
    if poses_file is not None:
        table = read_table(poses_file)
        poses = (pose_list_ids(table), read_poses(table, robot.joint_names, robot.profile.servo))
        if SUPPORT_COLUMN in table.text:
            stances = np.array([v.strip() for v in table.text[SUPPORT_COLUMN]])
    paths = list(bag) if len(bag) > 1 else bag[0]
    res = read_bag(paths, map_file, robot=robot, poses=poses, pose_support=stances)
    name = ", ".join(bag)
    for note in res.notes:
        click.echo(f"  note: {note}", err=True)
    if res.n == 0:
        raise DataError(f"{name}: no sample kept (see the notes above)")
    with outs:
        write_table(outs.path(out), res.columns)
    click.echo(f"{name}: {len(res.segments)} pose segments")
    for g in res.segments:
        on = f", on {g.stance}" if g.stance else ""
        click.echo(f"  pose {g.pose}: {g.start:.3f}–{g.end:.3f} s, {g.samples} samples{on}")
    dropped = ", ".join(f"{k} {v}" for k, v in res.dropped.items() if v) or "none"
    click.echo(f"kept {res.n} samples, dropped: {dropped}")
    if SUPPORT_COLUMN in res.columns:
        counts = {}
        for g in res.segments:
            counts[g.stance] = counts.get(g.stance, 0) + 1
        said = ", ".join(f"{k} {v} poses" for k, v in counts.items())
        click.echo(f"stances ({SUPPORT_COLUMN} column): {said}")
    taus = [c for c in res.columns if c.startswith("tau_")]
    if taus:
        click.echo(f"joint torques of {len(taus)} joints (tau_<joint>, N·m)")
    click.echo(f"wrote {out}")
