"""What a report is made from and what it gives back: typed records, and the numbers it shows.

``ReportOptions`` (pose labels, poses in the side view, a progress callback); ``read_report_data``
reads a measurement file (any kinds: CoP and/or joint torques, gravity or IMU columns) with its
pose ids; ``report_content`` computes everything the page shows, once (``ReportContent``);
``ReportResult`` is what ``write_report`` returns.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sescid.errors import DataError
from sescid.estimation import Fit, Measurements
from sescid.estimation.data.measurements import concatenate
from sescid.report.coverage import Coverage, coverage
from sescid.report.numbers import (
    KindNumbers,
    MassRow,
    cop_numbers,
    mass_rows,
    support_leg_joints,
    torque_numbers,
)
from sescid.stance import Stance


@dataclass(frozen=True)
class ReportOptions:
    """``pose_ids``: a label per pose (None: 0, 1, …); ``n_side``: poses drawn in the side view;
    ``progress(done, total)``: called after each file written."""

    pose_ids: Sequence[str] | None = None
    n_side: int = 4
    progress: Callable[[int, int], None] | None = None


@dataclass(frozen=True)
class ComNumbers:
    """The CoM per pose (n, 3) m of both models, the identified height's standard error (n,) m
    (identified directions only), and how much of that height the prior decided."""

    prior: np.ndarray
    fit: np.ndarray
    std_z: np.ndarray
    from_prior: np.ndarray  #: (n,) m of the identified height taken from the prior model
    prior_fraction: np.ndarray  #: (n,) share of the height's regressor row the data do not see


@dataclass(frozen=True)
class ReportContent:
    """Everything the page shows, computed once from a fit and validated data."""

    fit: Fit
    data: Measurements
    labels: tuple[str, ...]  #: one per pose
    cop: KindNumbers | None
    tau: KindNumbers | None
    leg: tuple[int, ...]  #: torque columns drawn in the support-leg figure
    leg_is_chain: bool  #: those are the joints between the support and the trunk
    coverage: tuple[Coverage, ...]
    masses: tuple[MassRow, ...] | None
    com: ComNumbers


@dataclass(frozen=True)
class ReportResult:
    """What ``write_report`` wrote and the numbers its page quotes."""

    html: Path
    figures: tuple[Path, ...]
    content: ReportContent


def as_measurements(fit: Fit, data: Measurements | Iterable[Measurements]) -> Measurements:
    """One validated ``Measurements`` for the fit's robot from one or consecutive chunks."""
    parts = [data] if isinstance(data, Measurements) else list(data)
    if not parts:
        raise DataError("report: no poses")
    checked = [p.checked(fit.robot) for p in parts]
    return concatenate(checked)


def report_content(fit: Fit, data: Measurements, options: ReportOptions) -> ReportContent:
    """The page's numbers for validated ``data`` (``as_measurements``)."""
    n = data.n
    labels = tuple(str(p) for p in (options.pose_ids if options.pose_ids is not None else range(n)))
    if len(labels) != n:
        raise DataError(f"report: {len(labels)} pose ids for {n} poses")
    tau = torque_numbers(fit, data)
    leg, chain = ((), False) if tau is None else support_leg_joints(fit, tau.columns, tau.measured)
    rows = mass_rows(fit)
    com = ComNumbers(
        prior=fit.robot.com(data.q, fit.r_prior),
        fit=fit.predict_com(data.q),
        std_z=fit.predict_std(data.q, rows=(2,))[:, 0],
        from_prior=fit.com_z_from_prior(data.q),
        prior_fraction=fit.com_z_prior_fraction(data.q),
    )
    return ReportContent(
        fit=fit,
        data=data,
        labels=labels,
        cop=cop_numbers(fit, data),
        tau=tau,
        leg=leg,
        leg_is_chain=chain,
        coverage=coverage(fit, data),
        masses=None if rows is None else tuple(rows),
        com=com,
    )


def read_report_data(
    path: str | Path, fit: Fit, imu_link: str | None = None, stance: Stance | None = None
) -> tuple[Measurements, tuple[str, ...]]:
    """A measurement file's data for the fit's robot (any kinds it holds: ``cop_x``/``cop_y``,
    ``tau_<joint>``, ``approach``, gravity or IMU columns) and its pose ids (``pose`` column,
    else row numbers). A file with a ``support`` column gives the rows of ``stance`` (default:
    the fit's support), its cells in any spelling of a stance. Errors name the file and the
    column."""
    from sescid.io.measurements import measurements_of
    from sescid.sensors import pose_list_ids
    from sescid.stance import stance_labels, support_column
    from sescid.tables import read_table

    table = read_table(path)
    data = measurements_of(table, fit.robot, imu_link)
    ids = pose_list_ids(table)
    column = support_column(table)
    want = fit.robot.support if stance is None else stance.label
    if column in table.text:  # the rows of that stance (the others: --support)
        cells = [v.strip() for v in table.text[column]]
        labels, _ = stance_labels(cells, fit.robot, lambda _: f"{path}, column '{column}'")
        mine = np.flatnonzero(labels == want)
        if mine.size == 0:
            names = sorted(set(labels.tolist()))
            raise DataError(
                f"{path}: no row of the stance '{want}' (column '{column}' names "
                f"{', '.join(names)}): report the fit in one of those (--support "
                f"{' / '.join(names)})"
            )
        data, ids = data.take(mine), ids[mine]
    return data.checked(fit.robot), tuple(str(i) for i in ids)
