"""``sescid experiment``: the virtual bench (kinematic or MuJoCo) measures planned poses into a
raw log."""

from __future__ import annotations

from typing import Any, Literal

import click
import numpy as np

from sescid.base import OutputSet
from sescid.bench import (
    NO_POSE_MEASURED,
    Approach,
    BenchMount,
    Engine,
    ExperimentConfig,
    Registers,
    TorqueConfig,
    check_limits,
    run_experiment,
)
from sescid.cli.common import (
    force_option,
    load,
    model_input,
    robot_options,
    seed_option,
    sensors_option,
)
from sescid.errors import DataError, OptionError, choices
from sescid.io import read_poses, read_table, write_table
from sescid.robot import DOUBLE
from sescid.sensors import default_sensors_path, load_sensors, pose_list_ids

_EXP = ExperimentConfig()
_TAU = TorqueConfig()


def torque_options(f: Any) -> Any:
    """The joint torque sensors of a bench's real robot (experiment, session)."""
    for opt in reversed(
        [
            click.option(
                "--torques",
                default="none",
                show_default=True,
                help="Joints with a torque sensor: all, none, or a comma-separated list; they "
                "log tau_<joint> [N·m] and the pose's approach side.",
            ),
            click.option("--torque-noise", default=_TAU.noise, show_default=True,
                         type=click.FloatRange(min=0), help="Torque noise per sample [N·m]."),
            click.option("--torque-offset", default=_TAU.offset, show_default=True,
                         type=click.FloatRange(min=0),
                         help="Std of the per-joint torque offsets [N·m]."),
            click.option("--torque-gain", default=_TAU.gain, show_default=True,
                         type=click.FloatRange(min=0),
                         help="Std of the per-joint torque gain errors (relative)."),
            click.option("--friction", nargs=2, type=click.FloatRange(min=0),
                         default=_TAU.friction, show_default=True, metavar="LO HI",
                         help="Static-friction band half-width f_j ~ U(LO, HI) per joint [N·m]: "
                         "a held pose reads τ ± f_j on the side it came from."),
            click.option("--approach", type=click.Choice(choices(Approach)),
                         default=_TAU.approach, show_default=True,
                         help="Side each pose is approached from (the approach column)."),
        ]
    ):  # fmt: skip
        f = opt(f)
    return f


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
    return TorqueConfig(
        joints=joints,
        noise=opts["torque_noise"],
        offset=opts["torque_offset"],
        gain=opts["torque_gain"],
        friction=tuple(opts["friction"]),
        approach=opts["approach"],
    )


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
@robot_options
@click.option(
    "--poses",
    "poses_file",
    required=True,
    type=click.Path(dir_okay=False),
    help="Pose list (joint columns in radians; optional 'pose' id column).",
)
@click.option(
    "--samples",
    default=100,
    show_default=True,
    type=click.IntRange(min=1, max=1_000_000),
    help="Sensor readings per pose.",
)
@seed_option
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Raw log CSV.")
@click.option(
    "--truth",
    default=None,
    type=click.Path(dir_okay=False),
    help="Also write the truth (true SESC vectors, actual poses, true CoPs and torques) as JSON.",
)
@sensors_option
@click.option("--extra-mass", default=_EXP.extra_mass_fraction, show_default=True,
              help="Unmodelled mass as a fraction of the model's mass.")  # fmt: skip
@click.option("--backlash-deg", default=_EXP.backlash_deg, show_default=True,
              help="Joint play ±b [degrees].")  # fmt: skip
@click.option("--fsr-noise", default=_EXP.fsr_noise, show_default=True,
              help="Per-sensor noise std [N].")  # fmt: skip
@click.option("--fsr-bias", default=_EXP.fsr_bias, show_default=True,
              help="Per-sensor bias std [N].")  # fmt: skip
@click.option(
    "--fsr-gain",
    default=_EXP.fsr_gain,
    show_default=True,
    help="Per-pad gain error std (relative): a pad reads force / gain + bias.",
)
@click.option(
    "--double-support",
    is_flag=True,
    help="Both feet on the floor where the pose puts them there; the load splits over all "
    "their pads.",
)
@click.option(
    "--registers",
    type=click.Choice(choices(Registers)),
    default=_EXP.registers,
    show_default=True,
    help="Log the four forces, the centroid registers, or both.",
)
@click.option(
    "--mount",
    type=click.Choice(choices(BenchMount)),
    default=_EXP.mount,
    show_default=True,
    help="stand: on the support foot; gantry: the support link (--support pelvis) held level "
    "in a fixture, the robot hanging free (no balance; the feet carry nothing); line: "
    "balancing on its support line (--support axle --line y: a wheel axle, an edge), each "
    "pose at the tilt that balances it, read by an IMU (kinematic engine).",
)
@click.option(
    "--imu-noise-deg",
    default=_EXP.imu_noise_deg,
    show_default=True,
    type=click.FloatRange(0, 20),
    help="line mount: IMU roll/pitch noise per sample [degrees].",
)
@click.option(
    "--imu-link",
    default=None,
    help="line mount: the link carrying the IMU (default: the profile's, else the support frame).",
)
@torque_options
@click.option(
    "--engine",
    type=click.Choice(choices(Engine)),
    default="kinematic",
    show_default=True,
    help="kinematic: rigid statics (CoP at the CoM's ground projection); mujoco: a physics "
    "bench (servos hold each pose on a compliant floor; logs grav_x/y/z and the IMU too).",
)
@click.option(
    "--weld-foot",
    is_flag=True,
    help="mujoco: fix the support foot level to the world (pads read an ideal F/T sensor).",
)
@click.option(
    "--kp",
    default=None,
    type=click.FloatRange(min=0, min_open=True),
    help="mujoco: servo stiffness [N·m/rad] (default: the robot profile's servo gains).",
)
@click.option(
    "--tilt-deg",
    default=_EXP.tilt_deg,
    show_default=True,
    type=click.FloatRange(0, 30),
    help="kinematic: the support stands tilted by a random roll and pitch of this standard "
    "deviation per pose [degrees]; the log gets grav_x, grav_y, grav_z.",
)
@force_option
def experiment(**opts):
    """Virtual bench experiment: a "real" robot (unmodelled mass, backlash, noisy biased FSRs,
    optional joint torque sensors) stands (or hangs) in each pose of the list; writes the raw
    sensor log that `sescid measure` reads."""
    out, truth = opts["out"], opts["truth"]
    outs = OutputSet(
        [out, truth], [opts["poses_file"], opts["sensors_file"], model_input(opts["robot_name"])],
        force=opts["force"],
    )  # fmt: skip
    robot = load(opts["robot_name"], opts["support"])
    cfg = experiment_config(opts)
    bench = mujoco_bench(opts, cfg)
    sensors = bench_sensors(opts["sensors_file"], robot.profile, cfg.torque, cfg.mount)
    table = read_table(opts["poses_file"])
    q = read_poses(table, robot.joint_names, robot.profile.servo)
    check_limits(robot, q, str(opts["poses_file"]))
    ids, samples, seed = pose_list_ids(table), opts["samples"], opts["seed"]
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
    stance = DOUBLE if cfg.double_support else robot.support  # carried through measure
    with outs:
        write_table(
            outs.path(out), ex.columns | {"support": np.full(len(ex.columns["pose"]), stance)}
        )
        if truth:
            ex.truth.save(outs.path(truth))
    _report(ex, len(q), opts)


def experiment_config(opts: dict) -> ExperimentConfig:
    """The real robot and its sensors' errors from the flags."""
    return ExperimentConfig(
        extra_mass_fraction=opts["extra_mass"],
        backlash_deg=opts["backlash_deg"],
        fsr_noise=opts["fsr_noise"],
        fsr_bias=opts["fsr_bias"],
        fsr_gain=opts["fsr_gain"],
        double_support=opts["double_support"],
        registers=opts["registers"],
        tilt_deg=opts["tilt_deg"],
        torque=torque_config(opts),
        mount=opts["mount"],
        imu_link=opts["imu_link"],
        imu_noise_deg=opts["imu_noise_deg"],
    )


def mujoco_bench(opts: dict, cfg: ExperimentConfig):
    """The physics bench's settings for ``--engine mujoco``, None for the kinematic bench;
    OptionError for a flag of the other engine."""
    engine, weld, kp = opts["engine"], opts["weld_foot"], opts["kp"]
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
    from sescid.bench import MujocoBenchConfig

    return MujocoBenchConfig(kp=kp, weld_foot=weld, double_support=cfg.double_support)


def _report(ex, n: int, opts) -> None:
    t = ex.truth
    tau = "" if t.torque is None else f", torques on {len(t.torque.joints)} joints"
    sensors = (
        f"IMU noise {opts['imu_noise_deg']:g}°"
        if t.mount == "line"
        else f"FSR noise {opts['fsr_noise']:g} N, bias {opts['fsr_bias']:g} N, gain error "
        f"{opts['fsr_gain']:g}"
    )
    click.echo(
        f"wrote {opts['out']}: {n - len(ex.skipped)} poses × {opts['samples']} samples "
        f"({t.mount}); real robot {t.true_mass:.4f} kg (model {t.model_mass:.4f} kg), "
        f"backlash ±{opts['backlash_deg']:g}°, {sensors}{tau}"
    )
    for pose, why in ex.skipped:
        click.echo(f"  pose {pose} skipped: {why}", err=True)
    if opts["truth"]:
        click.echo(
            f"wrote {opts['truth']} (the truth: true SESC vectors, actual poses, "
            + ("balancing tilts" if t.mount == "line" else "true CoPs")
            + (" and torques)" if t.torque is not None else ")")
        )
