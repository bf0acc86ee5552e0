"""Reports: the paper's figures (R_i, CoP per pose, CoM height), residuals, a side view, the
pose-selection curve, and one self-contained HTML page."""

from __future__ import annotations

from .figures import (
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
from .html import write_report

__all__ = [
    "body_labels",
    "cop_offset_stats",
    "design_figure",
    "paper_order",
    "plot_com_height",
    "plot_cop_comparison",
    "plot_r_magnitudes",
    "plot_residuals",
    "plot_side_view",
    "write_report",
]
