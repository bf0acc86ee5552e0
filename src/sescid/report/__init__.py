"""Reports: one self-contained HTML page (figures embedded, a 3-D view of the poses) from a fit
and its data, for any kinds of data (CoP, joint torques, both): residuals per kind in its own
unit, torque sensor offsets and friction bands, what each kind of data determines and what
pooling gives, identified masses and CoMs; the paper's figures (R_i, CoP per pose, CoM height);
the pose-selection curve; a guided session's live view (``live``, viser; imported on use).
Figures are drawn on two cores where there are two (``parallel``)."""

from sescid.report.coverage import Coverage, coverage
from sescid.report.figures import (
    body_labels,
    design_figure,
    paper_order,
    plot_com_height,
    plot_cop_comparison,
    plot_r_magnitudes,
    plot_residuals,
    plot_side_view,
)
from sescid.report.html import write_report
from sescid.report.inputs import (
    ReportContent,
    ReportOptions,
    ReportResult,
    read_report_data,
    report_content,
)
from sescid.report.live import LiveView
from sescid.report.numbers import KindNumbers, MassRow, ResidualStats, mass_rows, residual_stats
from sescid.report.parallel import can_fork, run_figures
from sescid.report.text import KIND_TITLES, in_unit, mm, with_unit
from sescid.report.torque_figures import plot_leg_torques, plot_torque_residuals
from sescid.report.view3d import scene_data, view3d_html

__all__ = [
    "KIND_TITLES",
    "in_unit",
    "with_unit",
    "mm",
    "LiveView",
    "Coverage",
    "KindNumbers",
    "MassRow",
    "ReportContent",
    "ReportOptions",
    "ReportResult",
    "ResidualStats",
    "body_labels",
    "can_fork",
    "coverage",
    "design_figure",
    "mass_rows",
    "paper_order",
    "plot_com_height",
    "plot_cop_comparison",
    "plot_leg_torques",
    "plot_r_magnitudes",
    "plot_residuals",
    "plot_side_view",
    "plot_torque_residuals",
    "read_report_data",
    "report_content",
    "residual_stats",
    "run_figures",
    "scene_data",
    "view3d_html",
    "write_report",
]
