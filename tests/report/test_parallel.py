"""Figures drawn in a forked child: the same files as drawn here, errors as without the child,
and a fixed layout that leaves every label inside its figure."""

from __future__ import annotations

import os

import numpy as np
import pytest

from sescid.report import figures, parallel, run_figures
from sescid.report.inputs import ComNumbers

needs_fork = pytest.mark.skipif(not parallel.can_fork(), reason="no fork or one core")


def _jobs(out, tag):
    """Two small real figures written under ``out`` with names ending in ``tag``."""
    idx = np.arange(1, 9)
    meas = np.column_stack([np.sin(idx), np.cos(idx)]) * 1e-2
    pred = {"model": meas + 1e-3 * np.cos(3 * idx)[:, None]}
    return [
        lambda: figures.plot_cop_comparison(idx, meas, pred, out / f"cop{tag}.png", title="t"),
        lambda: figures.plot_residuals(idx, meas, pred, out / f"res{tag}.png"),
    ]


@needs_fork
def test_child_draws_the_same_bytes(tmp_path):
    """Figures drawn by the forked child are byte for byte those drawn in this process."""
    done = []
    run_figures(_jobs(tmp_path, "_fork"), progress=done.append, fork=True)
    run_figures(_jobs(tmp_path, "_here"), fork=False)
    for name in ("cop", "res"):
        a, b = tmp_path / f"{name}_fork.png", tmp_path / f"{name}_here.png"
        assert a.read_bytes() == b.read_bytes() and a.stat().st_size > 10_000
    assert done[-1] == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        f"{n}_{t}.png" for n in ("cop", "res") for t in ("fork", "here")
    )  # no temporary left behind


@needs_fork
def test_child_failure_is_raised_here(tmp_path):
    """A job failing in the child runs again here and raises its own error."""
    pids = []

    def fail():
        pids.append(os.getpid())
        raise ValueError("figure job failed")

    with pytest.raises(ValueError, match="figure job failed"):
        run_figures([_jobs(tmp_path, "")[0], fail], fork=True)
    assert pids == [os.getpid()]  # the child's attempt left no trace in this process
    assert (tmp_path / "cop.png").is_file()


@needs_fork
def test_stuck_child_is_stopped_and_its_figure_drawn_here(tmp_path, monkeypatch):
    """A child still busy CHILD_TIMEOUT s after this process's share is killed and its job
    runs here instead."""
    import time

    monkeypatch.setattr(parallel, "CHILD_TIMEOUT", 0.5)
    parent, ran = os.getpid(), []

    def slow_in_child():
        if os.getpid() != parent:
            time.sleep(30)
        ran.append(os.getpid())

    start = time.monotonic()
    run_figures([lambda: None, slow_in_child], fork=True)
    assert ran == [parent] and time.monotonic() - start < 10


def test_no_fork_to_be_had_draws_everything_here(tmp_path, monkeypatch):
    """Where fork fails (process limits, a sandbox) every figure is drawn in this process."""

    def refuse():
        raise BlockingIOError("fork: resource temporarily unavailable")

    monkeypatch.setattr(os, "fork", refuse)
    done = []
    run_figures(_jobs(tmp_path, ""), progress=done.append, fork=True)
    assert (tmp_path / "cop.png").is_file() and (tmp_path / "res.png").is_file()
    assert done == [1, 2]


def test_fixed_layout_keeps_every_text_inside(monkeypatch, tmp_path):
    """With the fixed margins, every visible title, axis label, tick label and caveat of the
    report's figures lies inside its figure (on OP2-sized numbers and ten times larger)."""
    import sescid

    robot = sescid.load_robot("op2")
    q = np.random.default_rng(2).uniform(-0.3, 0.3, (12, robot.nq))
    saved = []
    real_save = figures.save_figure

    def keep(fig, path, *args, **kwargs):
        real_save(fig, path, *args, **kwargs)
        saved.append(fig)

    monkeypatch.setattr(figures, "save_figure", keep)
    idx = np.arange(1, 13)
    for scale in (1.0, 10.0):
        cop = robot.cop(q) * scale
        com = robot.com(q) * scale
        wobble = 1e-3 * np.sin(idx)[:, None]
        pred = {"manufacturer model": cop + wobble, "identified": cop - 0.5 * wobble}
        figures.plot_cop_comparison(idx, cop, pred, tmp_path / "a.png", title="title")
        z, note = com[:, 2], "22% of the CoM height comes from the prior model"
        heights = ComNumbers(com, com, z * 0.01, from_prior=z * 0, prior_fraction=z * 0)
        figures.plot_com_height(idx, heights, tmp_path / "b.png", caveat=note)
        figures.plot_residuals(idx, cop, pred, tmp_path / "c.png")
        figures.plot_side_view(robot, q[:4], cop[:4], {"identified": com[:4]}, tmp_path / "d.png")
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    assert len(saved) == 8
    for fig in saved:
        canvas = FigureCanvasAgg(fig)
        canvas.draw()  # as saved: the figure's own resolution
        box = fig.get_tightbbox(canvas.get_renderer())  # inches, every artist drawn
        w, h = fig.get_size_inches()
        assert box.x0 >= -0.01 and box.y0 >= -0.01, (box, fig.axes[0].get_title())
        assert box.x1 <= w + 0.01 and box.y1 <= h + 0.01, (box, fig.axes[0].get_title())
