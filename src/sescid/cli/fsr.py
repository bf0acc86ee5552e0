"""``sescid measure`` (alias ``fsr``): a raw log reduced to one measurement per pose."""

from __future__ import annotations

import click
import numpy as np

from sescid.base import G0, SUPPORT_COLUMN, OutputSet, listed
from sescid.cli import common
from sescid.errors import DataError, ModelError
from sescid.io import iter_table, read_table, write_table
from sescid.report import mm
from sescid.robot import DOUBLE
from sescid.sensors import REASONS, fsr_chunks, fsr_stances, load_sensors


def _log_stances(raw: str, support: str | None) -> list[str]:
    """The stances of a raw log (its ``support`` column, in order of appearance; empty without
    the column); an error for a log of one stance unlike ``--support``."""
    names: dict[str, None] = {}
    for table in iter_table(raw):
        if SUPPORT_COLUMN not in table.text:
            break
        names |= dict.fromkeys(v.strip() for v in table.text[SUPPORT_COLUMN])
    stances = list(names)
    if "" in names:
        raise DataError(f"{raw}: the log's '{SUPPORT_COLUMN}' column has empty cells")
    if len(stances) == 1 and support is not None and stances[0] not in (support, DOUBLE):
        raise DataError(
            f"{raw}: the log was measured on '{stances[0]}' (its '{SUPPORT_COLUMN}' column), not "
            f"on --support {support}"
        )
    return stances


def _stance_robot(robot, stance: str, raw: str):
    """The robot of one stance of a log ("double": the CoP of both feet in ``robot``'s
    frame); an unknown frame is an error naming the log."""
    try:
        return robot.stance(stance)
    except ModelError as exc:
        raise DataError(f"{raw}: column '{SUPPORT_COLUMN}': {exc}") from None


def _sensors(sensors_file, profile):
    """The given sensor file, else the profile's, else None (a log without foot sensors)."""
    if sensors_file is None and profile.sensors_file is None:
        return None
    return load_sensors(sensors_file, profile)


@click.command()
@click.argument("raw", type=common.FILE)
@common.robot_options
@common.sensors_option
@common.file_option(
    "--poses",
    "Pose list: every pose id in the log must be in it (its 'pose' column or row number).",
    "poses_file",
)
@common.min_samples_option
@common.file_option("--out", "Output CSV.", required=True)
@common.imu_link_option
@common.force_option
def fsr(raw, robot_name, support, sensors_file, poses_file, min_samples, out, imu_link, force):
    """Reduce a raw log to one measurement per pose: the CoP (support frame, m) from the foot
    sensors and the joint torques, each with its standard error.

    Writes pose, joint columns (mean read-backs, rad), cop_x, cop_y, cop_se_x, cop_se_y (m) when
    foot sensors are logged, tau_<joint> and tau_se_<joint> (N·m) and approach when torques are,
    n_used, n_rejected, reject_reasons, and force_n (mean total force, N) when forces are
    logged. A log with torques and no foot sensors needs no sensor file. A log's 'support'
    column (each sample's stance) is kept: each stance's poses are reduced in its own frame.
    """
    outs = OutputSet(
        [out], [raw, poses_file, sensors_file, common.model_input(robot_name)], force=force
    )
    stances = _log_stances(raw, support)
    one = stances[0] if len(stances) == 1 else None
    robot = common.load(robot_name, support or (None if one in (None, DOUBLE) else one))
    config = _sensors(sensors_file, robot.profile)
    pose_list = read_table(poses_file) if poses_file is not None else None
    if len(stances) > 1:  # each stance's samples reduced in its own frame
        robots = {st: _stance_robot(robot, st, raw) for st in stances}
        res, unmeasured, labels = fsr_stances(
            robots, lambda: iter_table(raw), config, min_samples, pose_list, imu_link,
            whole=lambda: read_table(raw),
        )  # fmt: skip
    else:
        res, unmeasured = fsr_chunks(
            robot, lambda: iter_table(raw), config, min_samples, pose_list, imu_link,
            whole=lambda: read_table(raw),
        )  # fmt: skip
        labels = np.full(len(res.pose), one) if one is not None else None
    columns = res.columns(robot.joint_names)
    if labels is not None:  # the stance each pose was measured in, for identify to pool
        columns[SUPPORT_COLUMN] = labels
    with outs:
        write_table(outs.path(out), columns)
    total = res.rejected.sum(axis=0)
    why = ", ".join(f"{r} {int(c)}" for r, c in zip(REASONS, total, strict=True) if c) or "none"
    dropped = f"; {len(res.dropped)} poses dropped (below)" if res.dropped else ""
    click.echo(
        f"{len(res.pose)} poses from {res.mode}: {int(res.n_used.sum())} samples used "
        f"(median {int(np.median(res.n_used))} per pose), rejected in these poses: {why}{dropped}"
    )
    if res.mode == "forces":
        click.echo(
            f"  mean measured weight {np.mean(res.force) / G0:.4f} kg "
            f"(model {robot.total_mass:.4f} kg); mean CoP standard error "
            f"x {mm(float(np.mean(res.cop_se[:, 0])))}, y {mm(float(np.mean(res.cop_se[:, 1])))}"
        )
    if res.tau is not None and res.tau_se is not None:
        side = "" if res.approach is None else ", approach side per pose"
        click.echo(
            f"  torques of {len(res.tau_joints)} joints: mean standard error "
            f"{float(np.mean(res.tau_se)):.4g} N·m{side}"
        )
    for note in res.notes:
        click.echo(f"  note: {note}", err=True)
    for pose, reason in res.dropped:
        click.echo(f"  pose {pose} dropped: {reason}", err=True)
    if unmeasured:
        click.echo(
            f"  {len(unmeasured)} poses of the list were not measured: "
            f"{listed(unmeasured, first=5)}",
            err=True,
        )
    click.echo(f"wrote {out}")
