"""``sescid report``: figures and one self-contained HTML page from a fit and its data."""

from __future__ import annotations

import click

from sescid.base.files import OutputSet
from sescid.base.progress import TerminalProgress
from sescid.cli.common import (
    force_option,
    imu_link_option,
    mm,
)
from sescid.estimation import load_fit
from sescid.io import read_cop, read_cop_se, read_poses, read_table
from sescid.report import write_report
from sescid.sensors import pose_list_ids


@click.command()
@click.argument("fit_file", type=click.Path(dir_okay=False))
@click.argument("measured", type=click.Path(dir_okay=False))
@click.option("--out-dir", default="report", show_default=True, type=click.Path(file_okay=False))
@imu_link_option
@force_option
def report(fit_file, measured, out_dir, imu_link, force):
    """Figures and one self-contained HTML page from a fit and measured CoPs (never re-fits).

    With grav_x/y/z (or IMU) columns the predicted CoPs are projected along that gravity.
    """
    from sescid.sensors import table_gravity

    outs = OutputSet([], [fit_file, measured], folders=[out_dir], force=force)
    fit = load_fit(fit_file)
    table = read_table(measured)
    q = read_poses(table, fit.robot.joint_names, fit.robot.profile.servo)
    gravity = table_gravity(fit.robot, table, q, imu_link)
    cop = read_cop(table)
    se = read_cop_se(table)
    with outs:
        res = write_report(
            fit,
            q,
            cop,
            outs.folder(out_dir),
            cop_se=se,
            pose_ids=pose_list_ids(table),
            progress=TerminalProgress("report files"),
            gravity=gravity,
        )
    b, a = res["before"], res["after"]
    click.echo(
        f"CoP offset predicted − measured over {len(q)} poses: manufacturer model mean "
        f"{mm(b['mean'])} (x {mm(b['mean_x'])}, y {mm(b['mean_y'])}), RMS {mm(b['rms'])}; "
        f"identified mean {mm(a['mean'])}, RMS {mm(a['rms'])}"
    )
    html = f"{out_dir}/{res['html'].name}"
    click.echo(f"wrote {html} and {len(res['figures'])} figures")
