"""``sescid measure`` (alias ``fsr``): a raw log reduced to one measurement per pose."""

from __future__ import annotations

import copy
import functools
from collections.abc import Callable, Iterable, Iterator

import click
import numpy as np

from sescid.base import G0, OutputSet, listed
from sescid.cli import common
from sescid.errors import DataError
from sescid.report import mm
from sescid.robot import DOUBLE, Robot
from sescid.sensors import REASONS, fsr_chunks, fsr_stances, load_sensors, pose_list_ids
from sescid.stance import data_stance, stance_labels, support_column
from sescid.tables import SUPPORT_COLUMN, Table, iter_table, pose_ids, read_table, write_table


def _log_stances(
    raw: str, robot: Robot, support: str | None, plan=None
) -> tuple[list[str], dict[str, str]]:
    """The stances of a raw log (its ``support`` column in any case, in order of appearance;
    empty without the column) as their labels (``Stance.label``), each passing the one stance
    check (``data_stance``), and the spellings that are not their label (``gantry:TRUNK``)
    → label. Errors name the row: an empty cell, a pose whose samples switch stance, a pose the
    plan (``plan``: the pose list, with its own ``support`` column) puts on another stance; and
    a log of one stance unlike ``--support``."""
    names: dict[str, str] = {}  # stance label → where it first appears
    rename: dict[str, str] = {}  # spelling → its label, where they differ
    # pose id → (stance, where: its row's name, made only for an error — a row number scans
    # the file up to it)
    first: dict[str, tuple[str, Callable[[], str]]] = {}
    for table in iter_table(raw):
        column = support_column(table)
        if column is None or column not in table.text:
            break
        labels = np.array([v.strip() for v in table.text[column]])
        empty = np.flatnonzero(labels == "")
        if empty.size:
            raise DataError(
                f"{raw}: {table.where(int(empty[0]))}, column '{column}' is empty (the stance of "
                "each sample)"
            )
        for name in dict.fromkeys(labels.tolist()):
            if name not in names and name not in rename:
                at = f"{raw}: {table.where(int(np.flatnonzero(labels == name)[0]))}"
                label = data_stance(robot, name, (), f"{at}, column '{column}'")[0].label
                names.setdefault(label, at)
                if label != name:
                    rename[name] = label
        if rename:
            labels = np.array([rename.get(v, v) for v in labels.tolist()])
        if "pose" not in table.names():
            continue
        ids = pose_ids(table)
        pairs, at = np.unique(np.char.add(np.char.add(ids, "\x1f"), labels), return_index=True)
        order = np.argsort(at)  # in file order: the first stance seen is the first named
        for pair, i in zip(pairs[order].tolist(), at[order].tolist(), strict=True):
            pose, stance = pair.split("\x1f")
            seen = first.setdefault(pose, (stance, functools.partial(table.rows.where, i)))
            if seen[0] != stance:
                raise DataError(
                    f"{raw}: pose {pose} switches stance between its samples ('{seen[0]}' at "
                    f"{seen[1]()}, '{stance}' at {table.where(i)}): one pose is measured in one "
                    "stance; give the samples of the other another pose id, or fix the column"
                )
    if plan is not None:
        _check_plan(raw, plan, first, robot)
    stances = list(names)
    if len(stances) == 1 and support is not None and stances[0] not in (support, DOUBLE):
        raise DataError(
            f"{raw}: the log was measured on '{stances[0]}' (its '{SUPPORT_COLUMN}' column), not "
            f"on --support {support}"
        )
    return stances, rename


def _relabelled(tables: Iterable[Table], rename: dict[str, str]) -> Iterator[Table]:
    """The tables with their ``support`` cells spelled as labels (``rename``: spelling → label)."""
    for table in tables:
        column = support_column(table)
        if rename and column is not None and column in table.text:
            table = copy.copy(table)
            table.text = {
                **table.text,
                column: [rename.get(v.strip(), v) for v in table.text[column]],
            }
        yield table


def _check_plan(
    raw: str, plan, measured: dict[str, tuple[str, Callable[[], str]]], robot: Robot
) -> None:
    """DataError for a pose the log measured in another stance than the plan (``plan``, the
    pose list, with a ``support`` column, in any spelling of a stance) put it on."""
    column = support_column(plan)
    if column is None or column not in plan.text or not measured:
        return
    spelled = [v.strip() for v in plan.text[column]]
    labels, _ = stance_labels(spelled, robot, lambda _: f"{plan.path}, column '{column}'")
    planned = dict(zip(pose_list_ids(plan).tolist(), labels.tolist(), strict=True))
    for pose, (stance, at) in measured.items():
        want = planned.get(pose)
        if want is not None and want != stance:
            raise DataError(
                f"{raw}: {at()}: pose {pose} was measured on '{stance}', but {plan.path} plans it "
                f"on '{want}' (its '{column}' column): the bench stood it otherwise; measure "
                "it again as planned, or give the plan it followed"
            )


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
    pose_list = read_table(poses_file) if poses_file is not None else None
    stances, rename = _log_stances(raw, common.load(robot_name, support), support, pose_list)
    one = stances[0] if len(stances) == 1 else None
    robot = common.load(robot_name, support or (None if one in (None, DOUBLE) else one))
    config = _sensors(sensors_file, robot.profile)
    if len(stances) > 1:  # each stance's samples reduced in its own frame
        robots = {st: robot.stance(st) for st in stances}
        res, unmeasured, labels = fsr_stances(
            robots, lambda: _relabelled(iter_table(raw), rename), config, min_samples,
            pose_list, imu_link, whole=lambda: next(_relabelled([read_table(raw)], rename)),
        )  # fmt: skip
    else:
        res, unmeasured = fsr_chunks(
            robot,
            lambda: iter_table(raw),
            config,
            min_samples,
            pose_list,
            imu_link,
            whole=lambda: read_table(raw),
        )  # fmt: skip  (one stance: its cells are not read again)
        labels = np.full(len(res.pose), one) if one is not None else None
    columns = res.columns(robot.joint_names)
    if labels is not None:  # the stance each pose was measured in, for identify to pool
        columns[SUPPORT_COLUMN] = labels
    with outs:
        write_table(outs.path(out), columns)
    total, d = res.rejected.sum(axis=0), res.data
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
            f"x {mm(float(np.mean(d.cop_se[:, 0])))}, y {mm(float(np.mean(d.cop_se[:, 1])))}"
        )
    if d.tau is not None and d.tau_se is not None:
        side = "" if d.approach is None else ", approach side per pose"
        click.echo(
            f"  torques of {len(d.tau_joints)} joints: mean standard error "
            f"{float(np.mean(d.tau_se)):.4g} N·m{side}"
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
