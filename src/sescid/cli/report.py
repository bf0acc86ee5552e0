"""``sescid report``: figures and one self-contained HTML page from a fit and its data."""

from __future__ import annotations

from pathlib import Path

import click

from sescid.base import OutputSet, TerminalProgress
from sescid.cli import common
from sescid.errors import DataError, OptionError
from sescid.estimation import for_support, load_fit
from sescid.report import (
    KIND_TITLES,
    KindNumbers,
    ReportOptions,
    in_unit,
    read_report_data,
    with_unit,
    write_report,
)
from sescid.stance import data_stance


def _residual_line(k: KindNumbers, n: int) -> str:
    """One kind's residuals, measured − predicted, of both models (the CoP's mean per axis)."""

    def model(name: str) -> str:
        s = k.stats[name]
        mean = ""
        if k.kind == "cop":
            mean = f"mean ({in_unit(s[0].mean, 'm')}, {in_unit(s[1].mean, 'm')}) mm, "
        return f"{mean}RMS {with_unit(s[-1].rms, k.unit)}"

    fitted = k.total()
    return (
        f"{KIND_TITLES[k.kind]} residual, measured − predicted, over {n} poses "
        f"({fitted.n_rows} rows): manufacturer model {model('manufacturer model')}; "
        f"identified {model('identified')}, MAE {with_unit(fitted.mae, k.unit)}"
    )


@click.command()
@click.argument("fit_file", type=common.FILE)
@click.argument("measured", type=common.FILE)
@common.folder_option("--out-dir", "Folder for report.html and the figures.", "report")
@click.option(
    "--support",
    "stance",
    default=None,
    help="Report a fit pooled over stances in another of them (its frame name): the file's "
    "rows of that stance (its 'support' column). Default: the fit's support.",
)
@common.imu_link_option
@common.force_option
def report(fit_file, measured, out_dir, stance, imu_link, force):
    """Figures and one self-contained HTML page from a fit and what was measured (never
    re-fits): CoP (cop_x, cop_y), joint torques (tau_<joint>, approach) or both.

    With grav_x/y/z (or IMU) columns the predictions use that gravity. A file with a support
    column is reported for the rows of one stance (--support).
    """
    outs = OutputSet([], [fit_file, measured], folders=[out_dir], force=force)
    fit = load_fit(fit_file)
    rows = None  # the stance of the rows reported: the fit's own support by default
    if stance is not None:
        rows, _ = data_stance(fit.robot, stance, (), "--support")  # one stance check
        try:
            fit = for_support(fit, rows.label)  # both feet: the fit's own frame
        except DataError as exc:
            raise OptionError("support", f"{stance}: {fit_file}: {exc}") from None
    common.echo_model_change(fit, fit_file)
    data, ids = read_report_data(measured, fit, imu_link, rows)
    options = ReportOptions(pose_ids=ids, progress=TerminalProgress("report files"))
    with outs:
        res = write_report(fit, data, outs.folder(out_dir), options)
    for k in (res.content.cop, res.content.tau):
        if k is not None:
            click.echo(_residual_line(k, data.n))
    click.echo(f"wrote {Path(out_dir) / res.html.name} and {len(res.figures)} figures")
