"""``sescid session``: a guided identification session (plan, command, measure, stop)."""

from __future__ import annotations

import math
import time
from pathlib import Path

import click
import numpy as np

from sescid.cli.common import load, mm, robot_options, seed_option, sensors_option
from sescid.errors import OptionError


class _Printer:
    """Progress on the terminal: one line per pose (printed whether or not it is a TTY)."""

    def __init__(self, budget: int):
        self.budget = budget
        self.t0 = time.perf_counter()

    def planned(self, step_no, pose, q, q_current):
        pass

    def finished_pose(self, step, steps):
        k = len(steps)
        head = f"[{k}/{self.budget}] pose {step.pose} (candidate {step.candidate}, "
        head += f"{math.degrees(step.distance):.0f}° away)"
        if step.status != "measured":
            click.echo(f"{head}: skipped — {step.reason}")
            return
        assert step.cop is not None
        std = (
            "not yet (rank " + str(step.rank) + ")"
            if not math.isfinite(step.cop_std)
            else mm(step.cop_std)
        )
        pred = ""
        if step.cop_predicted is not None:
            pred = (
                f", predicted − measured {mm(float(np.linalg.norm(step.cop_predicted - step.cop)))}"
            )
        click.echo(
            f"{head}: CoP ({step.cop[0] * 1e3:.2f}, {step.cop[1] * 1e3:.2f}) mm{pred}; "
            f"predicted CoP std {std}" + (" — converged" if step.converged else "")
        )

    def stopped(self, result):
        pass


class _Both:
    def __init__(self, *observers):
        self.observers = [o for o in observers if o is not None]

    def planned(self, *a):
        for o in self.observers:
            o.planned(*a)

    def finished_pose(self, *a):
        for o in self.observers:
            o.finished_pose(*a)

    def stopped(self, *a):
        for o in self.observers:
            o.stopped(*a)


@click.command()
@robot_options
@click.option(
    "--adapter",
    default="mujoco",
    show_default=True,
    help="mujoco (the physics bench), replay (a recorded session: --replay), or "
    "python:MODULE:CLASS / python:FILE.py:CLASS (your robot, constructed as CLASS(robot)).",
)
@click.option(
    "--replay",
    "replay_path",
    default=None,
    type=click.Path(exists=True),
    help="replay: a session folder (raw.csv + poses.csv) or a raw log file.",
)
@click.option("--out-dir", required=True, type=click.Path(file_okay=False), help="Output folder.")
@click.option(
    "--budget",
    default=60,
    show_default=True,
    type=click.IntRange(min=1),
    help="Poses commanded at most (failed ones count).",
)
@click.option(
    "--samples",
    default=100,
    show_default=True,
    type=click.IntRange(min=2),
    help="Samples read per pose.",
)
@click.option(
    "--candidates",
    "n_candidates",
    default=5000,
    show_default=True,
    type=click.IntRange(min=1),
    help="Stable, collision-free candidate poses.",
)
@seed_option
@click.option(
    "--near",
    default=0.8,
    show_default=True,
    type=click.FloatRange(0, 1, min_open=True),
    help="Take the nearest candidate whose information gain is ≥ NEAR × the best.",
)
@click.option(
    "--window",
    default=10,
    show_default=True,
    type=click.IntRange(min=1),
    help="Convergence: poses looked back.",
)
@click.option(
    "--tol",
    default=0.05,
    show_default=True,
    type=click.FloatRange(0, 1, min_open=True, max_open=True),
    help="Convergence: the predicted CoP std fell by less than this over the window.",
)
@click.option(
    "--target-std",
    default=None,
    type=click.FloatRange(min=0, min_open=True),
    help="Also stop when the predicted CoP std reaches this [m].",
)
@sensors_option
@click.option("--no-view", is_flag=True, help="No live 3-D view (the session runs the same).")
@click.option(
    "--view-port",
    default=8080,
    show_default=True,
    type=click.IntRange(1, 65535),
    help="Live view: port on 127.0.0.1.",
)
@click.option(
    "--view-linger",
    default=0.0,
    show_default=True,
    type=click.FloatRange(0, 3600),
    help="Live view: keep serving this many seconds after the session ends [s].",
)
def session(
    robot_name,
    support,
    adapter,
    replay_path,
    out_dir,
    budget,
    samples,
    n_candidates,
    seed,
    near,
    window,
    tol,
    target_std,
    sensors_file,
    no_view,
    view_port,
    view_linger,
):
    """Guided identification: plan the next-best pose, command it, measure, update the estimate;
    stop when the predicted CoP error has converged or the budget is spent.

    Writes OUT_DIR/poses.csv, raw.csv, measured.csv, fit.json (as the step-by-step path) and
    session.json (the decisions). Progress is printed per pose; the live view (viser, the
    'view' extra) serves http://127.0.0.1:PORT while the session runs.
    """
    from sescid.base.progress import TerminalProgress
    from sescid.io import read_table
    from sescid.io.session_files import check_session_outputs, read_session_reasons, write_session
    from sescid.sensors import load_sensors
    from sescid.session.adapters import MujocoAdapter, ReplayAdapter, load_adapter_class
    from sescid.session.loop import SessionOptions, run_session

    inputs = [robot_name, sensors_file]
    raw_file = poses_file = None
    if adapter == "replay":
        if replay_path is None:
            raise OptionError("adapter", "--adapter replay needs --replay FOLDER_OR_RAW_LOG")
        rp = Path(replay_path)
        raw_file = rp / "raw.csv" if rp.is_dir() else rp
        poses_file = rp / "poses.csv" if rp.is_dir() and (rp / "poses.csv").exists() else None
        inputs += [raw_file, poses_file]
    elif replay_path is not None:
        raise OptionError("adapter", "--replay needs --adapter replay")
    check_session_outputs(out_dir, inputs)
    robot = load(robot_name, support)
    sensors = load_sensors(sensors_file, robot.profile)
    if adapter == "mujoco":
        bot = MujocoAdapter(robot, sensors, seed=seed)
    elif adapter == "replay":
        poses = read_table(poses_file) if poses_file is not None else None
        reasons = read_session_reasons(Path(replay_path)) if Path(replay_path).is_dir() else {}
        bot = ReplayAdapter(
            read_table(raw_file), robot.joint_names, poses, robot.profile.servo, reasons
        )
    elif adapter.startswith("python:"):
        bot = load_adapter_class(adapter[len("python:") :])(robot)
    else:
        raise OptionError("adapter", f"'{adapter}': mujoco, replay or python:MODULE:CLASS")
    opt = SessionOptions(
        budget=budget,
        samples=samples,
        n_candidates=max(n_candidates, budget),
        seed=seed,
        near=near,
        window=window,
        tol=tol,
        target_std=target_std,
    )
    view = None
    if not no_view:
        from sescid.report.live import LiveView

        view = LiveView(robot, port=view_port)
        click.echo(f"live view: {view.url} (Ctrl-C stops the session)")
    try:
        res = run_session(
            robot, bot, sensors, opt, _Both(_Printer(budget), view), TerminalProgress("candidates")
        )
    except BaseException:
        if view is not None:
            view.close()
        raise
    written = write_session(res, robot, out_dir)
    click.echo(
        f"stopped: {res.stop_reason}; {res.n_measured} of {len(res.steps)} commanded poses "
        f"measured, predicted CoP std "
        f"{mm(res.cop_std) if math.isfinite(res.cop_std) else 'not determined'}, "
        f"rank {res.fit.rank}"
    )
    if res.rejected:
        click.echo(f"  {len(res.rejected)} planned poses were unsafe and never commanded")
    click.echo(f"wrote {', '.join(str(p) for p in written.values())}")
    if view is not None:
        if view_linger > 0:
            click.echo(f"live view stays up {view_linger:g} s at {view.url}")
        view.close(linger=view_linger)
