"""Reports: one self-contained HTML page (figures embedded, a 3-D view of the poses) from a fit
and its data, for any kinds of data (CoP, joint torques, both): residuals per kind in its own
unit, torque sensor offsets and friction bands, what each kind of data determines and what
pooling gives, identified masses and CoMs; the paper's figures (R_i, CoP per pose, CoM height);
the pose-selection curve; a guided session's live view (``live``, viser; imported on use).
Figures are drawn on two cores where there are two (``parallel``)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from sescid.base.lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover - for type checkers; at run time: _EXPORTS
    from sescid.report.coverage import Coverage, coverage
    from sescid.report.figures import (
        body_labels,
        cop_offset_stats,
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
    from sescid.report.numbers import KindNumbers, MassRow, ResidualStats, mass_rows, residual_stats
    from sescid.report.parallel import can_fork, run_figures
    from sescid.report.text import KIND_TITLES, in_unit, with_unit
    from sescid.report.torque_figures import plot_leg_torques, plot_torque_residuals
    from sescid.report.view3d import scene_data, view3d_html

__all__ = [
    "KIND_TITLES",
    "in_unit",
    "with_unit",
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
    "cop_offset_stats",
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

#: public name → the module that defines it, imported on first use (``base.lazy``)
_EXPORTS = {
    "coverage": "sescid.report.coverage",
    "LiveView": "sescid.report.live",
    "Coverage": "sescid.report.coverage",
    "KIND_TITLES": "sescid.report.text",
    "KindNumbers": "sescid.report.numbers",
    "MassRow": "sescid.report.numbers",
    "ReportContent": "sescid.report.inputs",
    "ReportOptions": "sescid.report.inputs",
    "ReportResult": "sescid.report.inputs",
    "ResidualStats": "sescid.report.numbers",
    "body_labels": "sescid.report.figures",
    "can_fork": "sescid.report.parallel",
    "cop_offset_stats": "sescid.report.figures",
    "design_figure": "sescid.report.figures",
    "in_unit": "sescid.report.text",
    "mass_rows": "sescid.report.numbers",
    "paper_order": "sescid.report.figures",
    "plot_com_height": "sescid.report.figures",
    "plot_cop_comparison": "sescid.report.figures",
    "plot_leg_torques": "sescid.report.torque_figures",
    "plot_r_magnitudes": "sescid.report.figures",
    "plot_residuals": "sescid.report.figures",
    "plot_side_view": "sescid.report.figures",
    "plot_torque_residuals": "sescid.report.torque_figures",
    "read_report_data": "sescid.report.inputs",
    "report_content": "sescid.report.inputs",
    "residual_stats": "sescid.report.numbers",
    "run_figures": "sescid.report.parallel",
    "scene_data": "sescid.report.view3d",
    "view3d_html": "sescid.report.view3d",
    "with_unit": "sescid.report.text",
    "write_report": "sescid.report.html",
}
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
