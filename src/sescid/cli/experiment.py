"""``sescid experiment``: the virtual bench (kinematic or MuJoCo) measures planned poses into a
raw log."""

from __future__ import annotations

from typing import Any, Literal

import click
import numpy as np

from sescid.base import OutputSet
from sescid.bench import (
    NO_POSE_MEASURED,
    Engine,
    ExperimentConfig,
    MujocoBenchConfig,
    TorqueConfig,
    check_limits,
    run_experiment,
)
from sescid.cli import common
from sescid.cli.flags import flags, record
from sescid.errors import DataError, OptionError
from sescid.robot import DOUBLE, Robot
from sescid.sensors import default_sensors_path, load_sensors, pose_list_ids
from sescid.stance import stance_labels, support_column
from sescid.tables import read_poses, read_table, write_table


def torque_options(f: Any) -> Any:
    """The joint torque sensors of a bench's real robot (experiment, session)."""
    f = flags(TorqueConfig, "noise", "offset", "gain", "friction", "approach")(f)
    return click.option(
        "--torques",
        default="none",
        show_default=True,
        help="Joints with a torque sensor: all, none, or a comma-separated list; they log "
        "tau_<joint> [N·m] and the pose's approach side.",
    )(f)


#: the parameters of ``torque_options`` that describe the torque sensors (idle without them)
TORQUE_FLAGS = ("torque_noise", "torque_offset", "torque_gain", "friction", "approach")


def torque_config(opts: dict) -> TorqueConfig:
    """The typed torque options from the flags of ``torque_options``."""
    spec = opts["torques"].strip()
    joints: tuple[str, ...] | Literal["all"]
    if spec == "all":
        joints = "all"
    elif spec in ("", "none"):
        joints = ()
    else:
        joints = tuple(j.strip() for j in spec.split(",") if j.strip())
    common.refuse_idle(TORQUE_FLAGS, bool(joints),
                       "without --torques (no joint torque is measured)")  # fmt: skip
    return record(TorqueConfig, opts, joints=joints, friction=tuple(opts["friction"]))


def bench_sensors(sensors_file, profile, torques: TorqueConfig, mount: str = "stand"):
    """The foot-sensor layout, or None for a robot with torque sensors and no layout (or one
    balancing on a line, which stands on no foot)."""
    if sensors_file is None and (
        mount == "line" or (profile.sensors_file is None and torques.joints)
    ):
        return None
    if sensors_file is None:
        default_sensors_path(profile)  # the one-line error naming the robot
    return load_sensors(sensors_file, profile)


@click.command()
@common.robot_options
@common.file_option(
    "--poses", "Pose list (joint columns in radians; optional 'pose' id column).", "poses_file",
    required=True,
)  # fmt: skip
@common.number_option("--samples", 100, 1, 1_000_000, "Sensor readings per pose.")
@common.seed_option
@common.file_option("--out", "Raw log CSV.", required=True)
@common.file_option(
    "--truth",
    "Also write the truth (true SESC vectors, actual poses, true CoPs and torques) as JSON.",
)
@common.sensors_option
@flags(ExperimentConfig, "extra_mass_fraction", "backlash_deg", "fsr_noise", "fsr_bias", "fsr_gain",
       "double_support", "registers", "mount", "imu_noise_deg", "imu_link")  # fmt: skip
@torque_options
@common.choice_option(
    "--engine",
    Engine,
    "kinematic",
    "kinematic: rigid statics (CoP at the CoM's ground projection); mujoco: a physics "
    "bench (servos hold each pose on a compliant floor; logs grav_x/y/z and the IMU too).",
)
@flags(MujocoBenchConfig, "weld_foot", "kp")
@flags(ExperimentConfig, "tilt_deg")
@common.force_option
def experiment(**opts):
    """Virtual bench experiment: a "real" robot (unmodelled mass, backlash, noisy biased FSRs,
    optional joint torque sensors) stands (or hangs) in each pose of the list; writes the raw
    sensor log that `sescid measure` reads."""
    out, truth = opts["out"], opts["truth"]
    inputs = [opts["poses_file"], opts["sensors_file"], common.model_input(opts["robot_name"])]
    outs = OutputSet([out, truth], inputs, force=opts["force"])
    robot = common.load(opts["robot_name"], opts["support"])
    cfg = experiment_config(opts)
    bench = mujoco_bench(opts, cfg)
    sensors = bench_sensors(opts["sensors_file"], robot.profile, cfg.torque, cfg.mount)
    table = read_table(opts["poses_file"])
    stance = DOUBLE if cfg.double_support else robot.support  # carried through measure
    rows = plan_rows(table, robot, stance, opts["poses_file"])
    q = read_poses(table, robot.joint_names, robot.profile.servo)[rows]
    check_limits(robot, q, str(opts["poses_file"]))
    ids, samples, seed = pose_list_ids(table)[rows], opts["samples"], opts["seed"]
    try:
        if bench is not None:
            from sescid.bench import run_mujoco_experiment

            ex = run_mujoco_experiment(robot, q, sensors, samples, seed, cfg, bench).relabel(ids)
        else:
            ex = run_experiment(robot, q, sensors, samples, seed, cfg, pose_ids=ids)
    except DataError as exc:
        if str(exc).startswith(NO_POSE_MEASURED):  # about the pose list: name its file
            raise DataError(f"{opts['poses_file']}: {exc}") from None
        raise
    with outs:
        write_table(
            outs.path(out), ex.columns | {"support": np.full(len(ex.columns["pose"]), stance)}
        )
        if truth:
            ex.truth.save(outs.path(truth))
    _report(ex, len(q), opts, pads=sensors is not None)


def plan_rows(table, robot: Robot, stance: str, poses_file) -> np.ndarray:
    """The rows of a pose list the bench measures in its ``stance`` (the robot's support, or
    "double"): every row, unless the list's ``support`` column names stances — then the rows
    planned for this one (each planned stance is measured in its own run); an error when none
    is, naming the flags that stand the robot as planned."""
    column = support_column(table)
    if column is None or column not in table.text:
        return np.arange(table.n)
    cells = [v.strip() for v in table.text[column]]

    def at(name: str) -> str:  # the first row of a spelling, as an error names it
        return f"{poses_file}: {table.where(cells.index(name))}, column '{column}'"

    if "" in cells:  # the spellings read before it are checked first, as the rows are read
        stance_labels(cells[: cells.index("")], robot, at)
        raise DataError(f"{at('')} is empty (name the stance of every row, or of none)")
    labels, planned = stance_labels(cells, robot, at)  # stances of this model, any spelling
    flags = {
        label: "--double-support" if st.mount == "double"
        else f"--mount gantry --support {st.support}" if st.mount == "gantry"
        else f"--support {st.support}"
        for label, st in planned.items()
    }  # fmt: skip
    rows = np.flatnonzero(labels == stance)
    if rows.size == 0:
        raise DataError(
            f"{poses_file}: its poses were planned for {', '.join(repr(p) for p in flags)} "
            f"(column '{column}'), not for '{stance}' the bench stands on: run experiment "
            f"with {' / '.join(flags.values())} (once per stance)"
        )
    if len(flags) > 1:
        rest = [f"'{p}' ({f})" for p, f in flags.items() if p != stance]
        click.echo(
            f"{poses_file}: measuring the {rows.size} poses planned for '{stance}'; its "
            f"{table.n - rows.size} others are for {', '.join(rest)}: run experiment again for "
            "each, into another --out",
            err=True,
        )
    return rows


def experiment_config(opts: dict) -> ExperimentConfig:
    """The real robot and its sensors' errors from the flags (an error for a flag that does
    nothing: foot-sensor settings on a robot held in a gantry, a gantry without torques)."""
    torque = torque_config(opts)
    if opts["mount"] == "gantry":
        if not torque.joints:
            raise OptionError(
                "mount", "a robot held in a gantry loads no foot: nothing is measured without "
                "--torques (the joints with a torque sensor)",
            )  # fmt: skip
        feet = ("fsr_noise", "fsr_bias", "fsr_gain", "registers", "sensors_file")
        common.refuse_idle(feet, False, "on a robot held in a gantry (no foot carries its weight)")
    if opts["mount"] == "double":  # on both feet: the bench's double support, labelled so
        return record(ExperimentConfig, opts, torque=torque, mount="stand", double_support=True)
    return record(ExperimentConfig, opts, torque=torque)


def mujoco_bench(opts: dict, cfg: ExperimentConfig):
    """The physics bench's settings for ``--engine mujoco``, None for the kinematic bench;
    OptionError for a flag of the other engine."""
    engine, weld, kp = opts["engine"], opts["weld_foot"], opts["kp"]  # the physics bench's
    if engine == "mujoco" and cfg.mount == "line":
        raise OptionError("engine", "--mount line runs on --engine kinematic")
    if engine == "kinematic":
        if weld or kp is not None:
            raise OptionError("engine", "--weld-foot and --kp need --engine mujoco")
        return None
    if opts["tilt_deg"] > 0:
        raise OptionError(
            "tilt_deg", "--tilt-deg is for --engine kinematic (the MuJoCo foot tilts by itself)"
        )
    return record(MujocoBenchConfig, opts, double_support=cfg.double_support)


def _report(ex, n: int, opts, pads: bool) -> None:
    """The log's summary line: the real robot and the errors of the sensors it logged (foot
    pads only when ``pads``: a torque-only log has no FSR columns)."""
    t = ex.truth
    tau = "" if t.torque is None else f"torques on {len(t.torque.joints)} joints"
    sensors = (
        f"IMU noise {opts['imu_noise_deg']:g}°"
        if t.mount == "line"
        else f"FSR noise {opts['fsr_noise']:g} N, bias {opts['fsr_bias']:g} N, gain error "
        f"{opts['fsr_gain']:g}"
        if pads
        else ""
    )
    mount = "double support" if opts["double_support"] or opts["mount"] == "double" else t.mount
    logged = ", ".join(x for x in (sensors, tau) if x)
    click.echo(
        f"wrote {opts['out']}: {n - len(ex.skipped)} poses × {opts['samples']} samples "
        f"({mount}); real robot {t.true_mass:.4f} kg (model {t.model_mass:.4f} kg), "
        f"backlash ±{opts['backlash_deg']:g}°, {logged}"
    )
    for pose, why in ex.skipped:
        click.echo(f"  pose {pose} skipped: {why}", err=True)
    if opts["truth"]:
        click.echo(
            f"wrote {opts['truth']} (the truth: true SESC vectors, actual poses, "
            + ("balancing tilts" if t.mount == "line" else "true CoPs")
            + (" and torques)" if t.torque is not None else ")")
        )
