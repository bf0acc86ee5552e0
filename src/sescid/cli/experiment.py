"""``sescid experiment``: the virtual bench (kinematic or MuJoCo) measures planned poses into a
raw log."""

from __future__ import annotations

import json

import click

from sescid.base.files import OutputSet
from sescid.bench import ExperimentConfig, run_experiment
from sescid.cli.common import (
    force_option,
    load,
    robot_options,
    seed_option,
    sensors_option,
)
from sescid.errors import DataError, MissingExtraError, OptionError, SescidError
from sescid.io import read_poses, read_table, write_table
from sescid.sensors import load_sensors, pose_list_ids

_EXP = ExperimentConfig()


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
    help="Also write the truth (true SESC vectors, actual poses, true CoPs) as JSON.",
)
@sensors_option
@click.option(
    "--extra-mass",
    default=_EXP.extra_mass_fraction,
    show_default=True,
    help="Unmodelled mass as a fraction of the model's mass.",
)
@click.option(
    "--backlash-deg",
    default=_EXP.backlash_deg,
    show_default=True,
    help="Joint play ±b [degrees].",
)
@click.option(
    "--fsr-noise", default=_EXP.fsr_noise, show_default=True, help="Per-sensor noise std [N]."
)
@click.option(
    "--fsr-bias", default=_EXP.fsr_bias, show_default=True, help="Per-sensor bias std [N]."
)
@click.option(
    "--fsr-gain",
    default=_EXP.fsr_gain,
    show_default=True,
    help="Per-pad gain error std (relative): a pad reads force / gain + bias.",
)
@click.option(
    "--double-support",
    is_flag=True,
    help="Both feet on the floor where the pose puts them there (plan with poses "
    "--double-support); the load splits over all their pads.",
)
@click.option(
    "--registers",
    type=click.Choice(["forces", "centroid", "both"]),
    default=_EXP.registers,
    show_default=True,
    help="Log the four forces, the centroid registers, or both.",
)
@click.option(
    "--engine",
    type=click.Choice(["kinematic", "mujoco"]),
    default="kinematic",
    show_default=True,
    help="kinematic: CoP at the CoM's ground projection; mujoco: a physics bench (the robot "
    "stands on its support foot, servos hold each pose; logs grav_x/y/z too).",
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
    default=0.0,
    show_default=True,
    type=click.FloatRange(0, 30),
    help="kinematic: the support stands tilted by a random roll and pitch of this standard "
    "deviation per pose [degrees]; the log gets grav_x, grav_y, grav_z.",
)
@force_option
def experiment(
    robot_name,
    support,
    poses_file,
    samples,
    seed,
    out,
    truth,
    sensors_file,
    extra_mass,
    backlash_deg,
    fsr_noise,
    fsr_bias,
    fsr_gain,
    double_support,
    registers,
    engine,
    weld_foot,
    kp,
    tilt_deg,
    force,
):
    """Virtual bench experiment: a "real" robot (unmodelled mass, backlash, noisy biased FSRs)
    stands in each pose of the list; writes the raw sensor log that `sescid fsr` reads."""
    outs = OutputSet([out, truth], [poses_file, sensors_file, robot_name], force=force)
    robot = load(robot_name, support)
    sensors = load_sensors(sensors_file, robot.profile)
    table = read_table(poses_file)
    q = read_poses(table, robot.joint_names, robot.profile.servo)
    ids = pose_list_ids(table)
    cfg = ExperimentConfig(
        extra_mass_fraction=extra_mass,
        backlash_deg=backlash_deg,
        fsr_noise=fsr_noise,
        fsr_bias=fsr_bias,
        fsr_gain=fsr_gain,
        double_support=double_support,
        registers=registers,
        tilt_deg=tilt_deg,
    )
    if engine == "kinematic" and (weld_foot or kp is not None):
        raise OptionError("engine", "--weld-foot and --kp need --engine mujoco")
    if engine == "mujoco" and tilt_deg > 0:
        raise OptionError(
            "tilt_deg", "--tilt-deg is for --engine kinematic (the MuJoCo foot tilts by itself)"
        )
    try:
        if engine == "mujoco":
            from sescid.bench.mujoco import MujocoBenchConfig, run_mujoco_experiment

            bench = MujocoBenchConfig(kp=kp, weld_foot=weld_foot, double_support=double_support)
            ex = run_mujoco_experiment(robot, q, sensors, samples, seed, cfg, bench, pose_ids=ids)
        else:
            ex = run_experiment(robot, q, sensors, samples, seed, cfg, pose_ids=ids)
    except (MissingExtraError, OptionError):
        raise
    except SescidError as exc:
        raise DataError(f"{poses_file}: {exc}") from None
    with outs:
        write_table(outs.path(out), ex.columns)
        if truth:
            with open(outs.path(truth), "w") as fh:
                json.dump(ex.truth, fh, indent=1)
                fh.write("\n")
    t = ex.truth
    n_logged = len(q) - len(ex.skipped)
    click.echo(
        f"wrote {out}: {n_logged} poses × {samples} samples; real robot {t['true_mass_kg']:.4f} kg "
        f"(model {t['model_mass_kg']:.4f} kg), backlash ±{backlash_deg:g}°, "
        f"FSR noise {fsr_noise:g} N, bias {fsr_bias:g} N, gain error {fsr_gain:g}"
    )
    for pose, why in ex.skipped:
        click.echo(f"  pose {pose} skipped: {why}", err=True)
    if truth:
        click.echo(f"wrote {truth} (the truth: true SESC vectors, actual poses, true CoPs)")
