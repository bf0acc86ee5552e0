"""``sescid predict``: CoP and CoM at poses from a fit, with intervals."""

from __future__ import annotations

import click
import numpy as np

from sescid.base import OutputSet
from sescid.cli import common
from sescid.errors import DataError, OptionError
from sescid.estimation import (
    com_interval,
    for_support,
    load_fit,
)
from sescid.stance import data_stance, own_stance, support_column
from sescid.tables import read_poses, read_table, write_table


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
    outs = OutputSet([out], [fit_file, poses], force=force)
    fit = load_fit(fit_file)
    table = read_table(poses)
    q = read_poses(table, fit.robot.joint_names, fit.robot.profile.servo)
    line = fit.robot.line is not None  # no CoP on a line: the tilt that balances instead
    cols: dict[str, np.ndarray] = {}
    lost, lost_rank = 0, fit.rank
    for seen, rows in _stances(fit, table, stance, line, (poses, fit_file)):
        part = _columns(seen, table, q, rows, line, level, imu_link)
        for name, values in part.items():
            cols.setdefault(name, np.full(len(q), np.nan))[rows] = values
        n_lost = int(np.sum(np.isnan(part["com_x_std"])))
        lost, lost_rank = lost + n_lost, seen.rank if n_lost else lost_rank
    with outs:
        write_table(outs.path(out), cols)
    if lost:
        click.echo(
            f"sescid: warning: at {lost} of {len(q)} poses the fit's data do not determine the "
            f"CoP (rank {lost_rank}): their std and interval columns are nan (not determined)",
            err=True,
        )
    for w in fit.warnings:
        click.echo(f"sescid: warning: {fit_file}: {w}", err=True)
    if fit.payload is not None:
        click.echo(f"predictions include the {fit.payload.summary().splitlines()[0]}")
    click.echo(f"wrote {out}: {len(q)} poses")


def _stances(fit, table, stance, line, files):
    """(the fit seen in a stance, the table's rows in it): ``--support`` for every row (its
    column, if any, must agree), else each row's ``support`` column, else the fit's own
    support. Each stance passes the one stance check (``data_stance``): a frame of the model
    where the CoP predicted is measurable (not a held trunk)."""
    poses, fit_file = files
    kinds = () if line else ("cop",)
    column = support_column(table)
    labels = None
    if column is not None and column in table.text:
        labels = np.array([v.strip() for v in table.text[column]])
    if stance is not None:
        given, _ = data_stance(fit.robot, stance, kinds, "--support")
        if labels is not None:
            for name in dict.fromkeys(labels.tolist()):
                row = table.where(int(np.flatnonzero(labels == name)[0]))
                said, _ = data_stance(fit.robot, name, kinds, f"{poses}: {row}, column '{column}'")
                if said != given:
                    raise OptionError(
                        "support",
                        f"{stance}, but {poses}: {row}, column '{column}' says "
                        f"'{name}': drop --support (each row is predicted in its own stance) "
                        "or fix the column",
                    )
        groups = {given: np.arange(table.n)}
        where = {given: "--support"}
    elif labels is not None:
        groups, where = {}, {}
        for name in dict.fromkeys(labels.tolist()):
            rows = np.flatnonzero(labels == name)
            at = f"{poses}: {table.where(int(rows[0]))}, column '{column}'"
            if not name:
                raise DataError(f"{at} is empty (name the stance of every row, or of none)")
            st, _ = data_stance(fit.robot, name, kinds, at)
            groups.setdefault(st, []).append(rows)
            where.setdefault(st, at)
        groups = {k: np.sort(np.concatenate(v)) for k, v in groups.items()}
    else:
        groups, where = {own_stance(fit.robot): np.arange(table.n)}, {}
    for st, rows in groups.items():
        label = st.label
        try:
            yield for_support(fit, label), rows
        except DataError as exc:
            at = where.get(st, "")
            if at == "--support":
                raise OptionError("support", f"{label}: {fit_file}: {exc}") from None
            raise DataError(f"{at}: '{label}': {fit_file}: {exc}") from None


def _columns(fit, table, q, rows, line, level, imu_link) -> dict[str, np.ndarray]:
    """The predicted columns of the poses ``q[rows]`` by ``fit`` (in its stance)."""
    from sescid.estimation import balance_interval, cop_interval
    from sescid.sensors import table_gravity

    gravity = None if line else table_gravity(fit.robot, table, q, imu_link)
    q = q[rows]
    gravity = None if gravity is None else gravity[rows]
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
    return cols
