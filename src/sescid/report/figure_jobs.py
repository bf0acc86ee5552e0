"""The report's figures for the kinds of data at hand: names, captions and the jobs that draw
them (run on two cores by ``parallel.run_figures``).

Always: the SESC magnitudes (paper Fig. 6), the CoM height (Fig. 8) and a side view; with a
CoP: the CoP per pose (Fig. 7) and its residuals; with joint torques: the residual map per pose
and joint, and the support leg's torques across the poses.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sescid.report.figures import (
    plot_com_height,
    plot_cop_comparison,
    plot_r_magnitudes,
    plot_residuals,
    plot_side_view,
)
from sescid.report.inputs import ReportContent, ReportOptions
from sescid.report.numbers import CAD, IDENTIFIED
from sescid.report.text import in_mm
from sescid.report.torque_figures import plot_leg_torques, plot_torque_residuals


@dataclass(frozen=True)
class FigureJob:
    """One PNG of the report: its file name, caption, and the call that draws it."""

    name: str
    caption: str
    draw: Callable[[], object]


def com_caveat(c: ReportContent) -> str:
    """One sentence: how much of the identified CoM height the prior model decided."""
    frac, from_prior = c.com.prior_fraction, c.com.from_prior
    return (
        f"{np.mean(frac):.0%} of the CoM-height regressor row is outside the identifiable "
        f"subspace: {in_mm(float(np.mean(from_prior)), 1)} mm of the identified height comes from "
        "the prior model"
    )


def _cop_jobs(c: ReportContent, out: Path, idx: np.ndarray) -> list[FigureJob]:
    cop = c.cop
    if cop is None:
        return []
    pred = {"manufacturer model": cop.predicted[CAD], "identified": cop.predicted[IDENTIFIED]}
    fig7 = "CoP per pose: measured vs manufacturer vs identified (paper Fig. 7)"
    return [
        FigureJob(
            "fig7_cop.png",
            fig7,
            lambda: plot_cop_comparison(
                idx, cop.measured, pred, out / "fig7_cop.png", title=fig7, labels=c.labels
            ),
        ),
        FigureJob(
            "residuals.png",
            "CoP residuals, measured − predicted",
            lambda: plot_residuals(idx, cop.measured, pred, out / "residuals.png", labels=c.labels),
        ),
    ]


def _torque_jobs(c: ReportContent, out: Path, idx: np.ndarray) -> list[FigureJob]:
    t = c.tau
    if t is None:
        return []
    leg = list(c.leg)
    names = [t.columns[j] for j in leg]
    pred = {label: t.predicted[label][:, leg] for label in (CAD, IDENTIFIED)}
    caption = (
        "Torques of the support leg's joints per pose: measured vs predicted, each model with "
        "its own sensor offsets (and friction bands)"
        if c.leg_is_chain
        else f"Torques of the {len(leg)} joints whose torque varies most: measured vs "
        "predicted, each model with its own sensor offsets (and friction bands)"
    )
    return [
        FigureJob(
            "torque_residuals.png",
            "Joint-torque residuals, measured − predicted, per pose and joint; right: each "
            "joint's residual RMS",
            lambda: plot_torque_residuals(
                idx, t.columns, t.residual, out / "torque_residuals.png", labels=c.labels
            ),
        ),
        FigureJob(
            "torque_support_leg.png",
            caption,
            lambda: plot_leg_torques(
                idx,
                names,
                t.measured[:, leg],
                pred,
                out / "torque_support_leg.png",
                labels=c.labels,
            ),
        ),
    ]


def figure_jobs(c: ReportContent, out: Path, options: ReportOptions) -> list[FigureJob]:
    """The figures for this content, in the order the page shows them."""
    fit, n = c.fit, c.data.n
    idx = np.arange(n)  # positions; the axes are labelled with the files' pose ids
    pick = np.unique(np.linspace(0, n - 1, min(options.n_side, n)).round().astype(int))
    fig6 = "R_i = |r_i|: manufacturer model vs identified ±1σ (paper Fig. 6)"
    cop_pick = None if c.cop is None else c.cop.measured[pick]
    coms = {"identified": c.com.fit[pick], "manufacturer": c.com.prior[pick]}
    jobs = [
        FigureJob(
            "fig6_r_magnitudes.png",
            fig6,
            lambda: plot_r_magnitudes(fit, out / "fig6_r_magnitudes.png", title=fig6),
        ),
        *_cop_jobs(c, out, idx),
        FigureJob(
            "fig8_com_height.png",
            "CoM height per pose (paper Fig. 8)",
            lambda: plot_com_height(
                idx,
                c.com,
                out / "fig8_com_height.png",
                caveat=com_caveat(c),
                labels=c.labels,
            ),
        ),
        *_torque_jobs(c, out, idx),
        FigureJob(
            "side_view.png",
            "Side view of a few poses with CoM" + ("" if c.cop is None else " and CoP"),
            lambda: plot_side_view(
                fit.robot,
                c.data.q[pick],
                cop_pick,
                coms,
                out / "side_view.png",
                labels=[c.labels[i] for i in pick],
            ),
        ),
    ]
    return jobs
