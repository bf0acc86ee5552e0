"""``sescid measure`` (alias ``fsr``): a raw log reduced to one measurement per pose."""

from __future__ import annotations

import click
import numpy as np

from sescid.base import OutputSet
from sescid.cli import common
from sescid.errors import DataError
from sescid.io import iter_table, read_table, write_table
from sescid.report import mm
from sescid.robot import DOUBLE
from sescid.sensors import REASONS, fsr_chunks, load_sensors


def _log_stance(raw: str, support: str | None) -> str | None:
    """The stance of a raw log (its ``support`` column, one value for the whole log), None
    without the column; an error for a log of several stances or one unlike ``--support``."""
    first = next(iter(iter_table(raw)), None)
    if first is None or "support" not in first.text:
        return None
    names = {v.strip() for v in first.text["support"]}
    for table in iter_table(raw):
        names |= {v.strip() for v in table.text.get("support", [])}
    if len(names) != 1:
        raise DataError(
            f"{raw}: the log's 'support' column names several stances ({', '.join(sorted(names))})"
            ": measure each stance's log on its own"
        )
    (stance,) = names
    if support is not None and support != stance and stance != DOUBLE:
        raise DataError(
            f"{raw}: the log was measured on '{stance}' (its 'support' column), not on "
            f"--support {support}"
        )
    return stance


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
    logged. A log with torques and no foot sensors needs no sensor file.
    """
    outs = OutputSet(
        [out], [raw, poses_file, sensors_file, common.model_input(robot_name)], force=force
    )
    stance = _log_stance(raw, support)
    robot = common.load(robot_name, support or (None if stance in (None, DOUBLE) else stance))
    config = _sensors(sensors_file, robot.profile)
    pose_list = read_table(poses_file) if poses_file is not None else None
    res, unmeasured = fsr_chunks(
        robot, lambda: iter_table(raw), config, min_samples, pose_list, imu_link,
        whole=lambda: read_table(raw),
    )  # fmt: skip
    columns = res.columns(robot.joint_names)
    if stance is not None:  # the stance the log was measured in, for identify to pool
        columns["support"] = np.full(len(res.pose), stance)
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
            f"  mean measured weight {np.mean(res.force) / 9.80665:.4f} kg "
            f"(model {robot.total_mass:.4f} kg); mean CoP standard error "
            f"x {mm(float(np.mean(res.cop_se[:, 0])))}, y {mm(float(np.mean(res.cop_se[:, 1])))}"
        )
    if res.tau is not None and res.tau_se is not None:
        side = "" if res.approach is None else ", approach side per pose"
        click.echo(
            f"  torques of {len(res.tau_joints)} joints: mean standard error "
            f"{float(np.mean(res.tau_se)):.4g} N·m{side}"
        )
    for pose, reason in res.dropped:
        what = "CoP" if res.cop is not None else "measurement"
        click.echo(f"  pose {pose} has no {what}: {reason}", err=True)
    if unmeasured:
        more = f" (and {len(unmeasured) - 5} more)" if len(unmeasured) > 5 else ""
        click.echo(
            f"  {len(unmeasured)} poses of the list were not measured: "
            f"{', '.join(unmeasured[:5])}{more}",
            err=True,
        )
    click.echo(f"wrote {out}")
