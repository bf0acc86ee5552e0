"""``sescid session``: a guided identification session (plan, command, measure, stop)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import click
import numpy as np

from sescid.cli import common
from sescid.cli.experiment import TORQUE_FLAGS, bench_sensors, torque_config, torque_options
from sescid.cli.flags import flags, record
from sescid.errors import MissingExtraError, OptionError
from sescid.planning import parse_stances, stance_robot
from sescid.report import mm
from sescid.robot import Robot
from sescid.session import SessionOptions, session_mount


class _Printer:
    """Progress on the terminal: one line per pose (printed whether or not it is a TTY)."""

    def __init__(self, budget: int):
        self.budget = budget

    def planned(self, step_no, pose, q, q_current):
        pass

    def finished_pose(self, step, steps):
        k = len(steps)
        head = f"[{k}/{self.budget}] pose {step.pose} (candidate {step.candidate}, "
        head += f"{math.degrees(step.distance):.0f}° away)"
        if step.status != "measured":
            click.echo(f"{head}: skipped — {step.reason}")
            return
        std = (
            "not yet (rank " + str(step.rank) + ")"
            if not math.isfinite(step.cop_std)
            else mm(step.cop_std)
        )
        what = []
        if step.cop is not None:
            pred = ""
            if step.cop_predicted is not None:
                d = float(np.linalg.norm(step.cop_predicted - step.cop))
                pred = f", predicted − measured {mm(d)}"
            what.append(f"CoP ({step.cop[0] * 1e3:.2f}, {step.cop[1] * 1e3:.2f}) mm{pred}")
        if step.tau is not None:
            what.append(f"{len(step.tau)} joint torques")
        click.echo(
            f"{head}: {', '.join(what)}; predicted {step.quantity} std {std}"
            + (" — converged" if step.converged else "")
        )

    def stance(self, step_no, label, describe):
        click.echo(f"stance change before pose {step_no}: put the robot {describe} [{label}]")

    def stopped(self, result):
        pass


class _CopView:
    """The live view, shown the poses that measured a CoP (it draws the measured CoP)."""

    def __init__(self, view):
        self.view = view

    def planned(self, *a):
        self.view.planned(*a)

    def finished_pose(self, step, steps):
        if step.status != "measured" or step.cop is not None:
            self.view.finished_pose(step, steps)

    def stopped(self, *a):
        self.view.stopped(*a)

    def stance(self, *a):
        pass


class _Both:
    """Every event told to each of the observers in turn."""

    def __init__(self, *observers):
        self.observers = [o for o in observers if o is not None]

    def _tell(self, event: str, args: tuple) -> None:
        for o in self.observers:
            getattr(o, event)(*args)

    def planned(self, *a):
        self._tell("planned", a)

    def finished_pose(self, *a):
        self._tell("finished_pose", a)

    def stopped(self, *a):
        self._tell("stopped", a)

    def stance(self, *a):
        self._tell("stance", a)


@click.command()
@common.robot_options
@click.option(
    "--adapter",
    default="mujoco",
    show_default=True,
    help="mujoco (the physics bench), kinematic (rigid statics), replay (a recorded session: "
    "--replay), or python:MODULE:CLASS / python:FILE.py:CLASS (your robot, constructed as "
    "CLASS(robot)).",
)
@click.option("--replay", "replay_path", type=click.Path(exists=True),
              help="replay: a session folder (raw.csv + poses.csv) or a raw log file.")  # fmt: skip
@common.folder_option(
    "--out-dir",
    "Output folder; each pose is journaled there as it is measured, and running again with "
    "the same folder and options resumes an interrupted session.",
    required=True,
)
@flags(SessionOptions, "budget", "samples", "n_candidates", "seed", "near", "window", "tol",
       "target_std", "kinds", "tau_noise", "mount")  # fmt: skip
@click.option(
    "--stances",
    default=None,
    help="Choose poses over these stances, comma-separated: sole frames, double (both feet), "
    "gantry:<link>; the session asks for a stance change when a pose of another stance is "
    "worth it (--stance-cost). One stance: as --support/--mount.",
)
@flags(SessionOptions, "stance_cost", "hang_height", "total_mass", "allow_missing_meshes")
@click.option(
    "--foot-sensors/--no-foot-sensors",
    default=True,
    show_default=True,
    help="mujoco, kinematic: whether the robot logs its foot sensors; --no-foot-sensors: a "
    "robot that reports joint torques only (with --torques). Other adapters log what they log.",
)
@common.sensors_option
@torque_options
@click.option("--no-view", is_flag=True, help="No live 3-D view (the session runs the same).")
@common.number_option("--view-port", 8080, 1, 65535, "Live view: port on 127.0.0.1.")
@common.number_option(
    "--view-linger", 0.0, 0, 3600,
    "Live view: keep serving this many seconds after the session ends [s].",
)  # fmt: skip
@common.force_option
def session(**opts):
    """Guided identification: plan the next-best pose, command it, measure, update the estimate;
    stop when the predicted CoP error (the CoM's, with joint torques) has converged or the
    budget is spent. The poses are chosen for what the robot reports: its CoP, its joint
    torques, or both.

    Writes OUT_DIR/poses.csv, raw.csv, measured.csv, fit.json (as the step-by-step path) and
    session.json (the decisions); OUT_DIR/journal.jsonl keeps every pose as it is measured
    (an interrupted session resumes when run again with the same folder and options; --force
    starts over). Progress is printed per pose; the live view (viser, the 'view' extra) serves
    http://127.0.0.1:PORT while the session runs.
    """
    from sescid.base import TerminalProgress
    from sescid.session import Journal, check_options, run_session

    _refuse_idle(opts)
    robot = common.load(opts["robot_name"], opts["support"])
    out_dir = opts["out_dir"]
    stances = parse_stances(opts["stances"], robot) if opts["stances"] is not None else ()
    if stances and opts["mount"] is not None:
        raise OptionError("mount", "--stances names each stance's mount (gantry:<link>, double)")
    held = [s for s in stances if s.mount == "gantry"]
    if held and opts["adapter"] in ("mujoco", "kinematic") and not torque_config(opts).joints:
        raise OptionError(
            "stances",
            f"'gantry:{held[0].support}': a robot held in a gantry loads no foot: the bench "
            "measures nothing there without --torques (the joints with a torque sensor)",
        )
    if len(stances) == 1:  # one stance: as --support and --mount
        robot, opts["mount"], stances = stance_robot(robot, stances[0]), stances[0].mount, ()
    opts["stances"] = tuple(s.label if s.mount != "gantry" else f"gantry:{s.support}"
                            for s in stances)  # fmt: skip
    opt = session_options(opts)
    check_options(robot, opt)
    try:
        bot, sensors, header = _adapter(robot, opts, opt)
    except MissingExtraError as exc:
        if opts["adapter"] != "mujoco":
            raise
        raise MissingExtraError(
            f"--adapter mujoco ({exc.what})", exc.extra,
            "run the rigid-statics bench without it: --adapter kinematic",
        ) from None  # fmt: skip
    defaults = dataclasses.asdict(SessionOptions())
    journal = Journal.open(out_dir, header, restart=opts["force"], defaults=defaults)
    if journal.finished:
        click.echo(f"{journal.path}: the session finished ({journal.finished}); replaying it")
    elif journal.entries:
        click.echo(f"resuming {journal.path}: {len(journal.entries)} poses journaled")
    view = None
    try:
        if not opts["no_view"]:
            from sescid.report import LiveView

            try:
                view = LiveView(robot, port=opts["view_port"])
            except MissingExtraError as exc:
                raise MissingExtraError(exc.what, exc.extra, "run without it: --no-view") from None
            click.echo(f"live view: {view.url} (Ctrl-C stops the session)")
        res = run_session(
            robot, bot, sensors, opt,
            _Both(_Printer(opt.budget), None if view is None else _CopView(view)),
            TerminalProgress("candidates"), journal,
        )  # fmt: skip
    except BaseException:
        if view is not None:
            view.close()
        journal.discard_if_empty()  # a session that measured nothing leaves nothing behind
        raise
    _write(res, robot, out_dir, view, opts)
    journal.finish(res.stop_reason)


def _refuse_idle(opts: dict) -> None:
    """An error for flags that would do nothing: the bench's sensors with your own adapter,
    the live view's settings with --no-view."""
    # a replay may repeat the recorded session's command line: its bench flags are kept
    bench = opts["adapter"] in ("mujoco", "kinematic", "replay")
    why = f"with --adapter {opts['adapter']} (your robot logs what it logs)"
    common.refuse_idle(("torques", *TORQUE_FLAGS, "foot_sensors"), bench, why)
    common.refuse_idle(("view_port", "view_linger"), not opts["no_view"], "with --no-view")


def session_options(opts: dict) -> SessionOptions:
    """The session's typed options from the flags (at least one candidate per commanded pose)."""
    n_candidates = max(opts["candidates"], opts["budget"])
    return record(
        SessionOptions, opts, n_candidates=n_candidates, stances=tuple(opts["stances"] or ())
    )


def _adapter(robot: Robot, opts, opt):
    """The robot adapter, the sensor layout and the journal header; the outputs checked."""
    from sescid.base import check_outputs
    from sescid.io import SESSION_FILES
    from sescid.sensors import load_sensors

    adapter, replay_path, out_dir = opts["adapter"], opts["replay_path"], opts["out_dir"]
    inputs = [
        common.model_input(opts["robot_name"]),
        opts["sensors_file"],
        *_replay_files(adapter, replay_path),
    ]
    if Path(out_dir).exists() and not Path(out_dir).is_dir():
        raise OptionError("out_dir", f"{out_dir}: exists and is not a folder")
    outputs: list[str | Path | None] = [Path(out_dir) / name for name in SESSION_FILES]
    check_outputs(outputs, inputs, force=opts["force"], folders=[out_dir])
    bench = adapter in ("mujoco", "kinematic")
    if bench:
        sensors = bench_sensors(opts["sensors_file"], robot.profile, torque_config(opts))
    else:
        sensors = load_sensors(opts["sensors_file"], robot.profile)
    bot = _bot(robot, opts, sensors, opt)
    header = {
        "robot": robot.source,
        "support": robot.support,
        "adapter": adapter if adapter != "replay" else f"replay:{Path(replay_path).resolve()}",
        "sensors": sensors.source if sensors is not None else None,
        "torques": opts["torques"],
        "foot_sensors": opts["foot_sensors"],
        "options": dataclasses.asdict(opt),
    }
    return bot, sensors, header


def _replay_files(adapter: str, replay_path: str | None) -> tuple[Path | None, Path | None]:
    """The replayed raw log and its pose list (a session folder's raw.csv and poses.csv, or
    the raw log given); (None, None) for another adapter."""
    if adapter != "replay":
        if replay_path is not None:
            raise OptionError("adapter", "--replay needs --adapter replay")
        return None, None
    if replay_path is None:
        raise OptionError("adapter", "--adapter replay needs --replay FOLDER_OR_RAW_LOG")
    rp = Path(replay_path)
    if not rp.is_dir():
        return rp, None
    return rp / "raw.csv", rp / "poses.csv" if (rp / "poses.csv").exists() else None


def _bot(robot: Robot, opts, sensors, opt: SessionOptions):
    """The robot the session commands: a bench, a recorded session, or the user's class."""
    from sescid.io import read_session_reasons
    from sescid.session import KinematicAdapter, MujocoAdapter, ReplayAdapter, load_adapter_class
    from sescid.tables import read_table

    adapter = opts["adapter"]
    if adapter in ("mujoco", "kinematic"):
        from sescid.bench import ExperimentConfig

        mount = "stand" if opt.stances else session_mount(robot, opt)[0]
        cfg = ExperimentConfig(torque=torque_config(opts), mount="stand" if mount == "double"
                               else mount, double_support=mount == "double")  # fmt: skip
        cls = MujocoAdapter if adapter == "mujoco" else KinematicAdapter
        return cls(robot, sensors, cfg, seed=opt.seed, feet=opts["foot_sensors"])
    if adapter == "replay":
        raw_file, poses_file = _replay_files(adapter, opts["replay_path"])
        assert raw_file is not None
        poses = read_table(poses_file) if poses_file is not None else None
        rp = Path(opts["replay_path"])
        reasons = read_session_reasons(rp) if rp.is_dir() else {}
        return ReplayAdapter(
            read_table(raw_file), robot.joint_names, poses, robot.profile.servo, reasons
        )
    if adapter.startswith("python:"):
        return load_adapter_class(adapter[len("python:") :])(robot)
    raise OptionError("adapter", f"'{adapter}': mujoco, kinematic, replay or python:MODULE:CLASS")


def _write(res, robot: Robot, out_dir, view, opts) -> None:
    from sescid.io import write_session

    written = write_session(res, robot, out_dir)
    click.echo(
        f"stopped: {res.stop_reason}; {res.n_measured} of {len(res.steps)} commanded poses "
        f"measured ({' and '.join(res.kinds)}), predicted {res.quantity} std "
        f"{mm(res.cop_std)}, "
        f"rank {res.fit.rank}"
    )
    if res.rejected:
        click.echo(f"  {len(res.rejected)} planned poses were unsafe and never commanded")
    click.echo(f"wrote {', '.join(str(p) for p in written.values())}")
    if view is not None:
        linger = opts["view_linger"]
        if linger > 0:
            click.echo(f"live view stays up {linger:g} s at {view.url}")
        view.close(linger=linger)
