"""Reports: the paper's figures (R_i, CoP per pose, CoM height), residuals, a side view, the
pose-selection curve, one self-contained HTML page with a 3-D view of the poses (``view3d``),
and a guided session's live view (``live``, viser; imported on use). Several figures are drawn
on two cores where there are two (``parallel``)."""

from __future__ import annotations

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
from sescid.report.parallel import can_fork, run_figures
from sescid.report.view3d import scene_data, view3d_html

__all__ = [
    "LiveView",
    "body_labels",
    "can_fork",
    "cop_offset_stats",
    "design_figure",
    "paper_order",
    "plot_com_height",
    "plot_cop_comparison",
    "plot_r_magnitudes",
    "plot_residuals",
    "plot_side_view",
    "run_figures",
    "scene_data",
    "view3d_html",
    "write_report",
]


def __getattr__(name: str):
    if name == "LiveView":  # the live view (viser, the ``view`` extra): imported on first use
        from sescid.report.live import LiveView

        return LiveView
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
