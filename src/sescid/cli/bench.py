"""Commands of a bench session: poses, experiment, fsr, report."""

from __future__ import annotations

import json

import click
import numpy as np

from sescid.base.files import OutputSet
from sescid.base.progress import TerminalProgress
from sescid.bench import ExperimentConfig, run_experiment
from sescid.cli.common import (
    force_option,
    imu_link_option,
    load,
    min_samples_option,
    mm,
    robot_options,
    seed_option,
    sensors_option,
)
from sescid.errors import DataError, MissingExtraError, OptionError, SescidError
from sescid.estimation import load_fit, min_poses
from sescid.io import read_cop, read_cop_se, read_poses, read_table, write_table
from sescid.planning import (
    DEFAULT_CLEARANCE,
    cop_half_extents,
    design_curve,
    free_sole,
    plan_poses,
    sampling_limits,
)
from sescid.planning import paper_convention as robot_paper_convention
from sescid.report import design_figure, write_report
from sescid.sensors import fsr as run_fsr
from sescid.sensors import load_sensors, pose_list_ids
from sescid.sensors.pads import REASONS
from sescid.simulation import PAPER_NOISE

_EXP = ExperimentConfig()


@click.command()
@click.argument("raw", type=click.Path(dir_okay=False))
@robot_options
@sensors_option
@click.option(
    "--poses",
    "poses_file",
    default=None,
    type=click.Path(dir_okay=False),
    help="Pose list: every pose id in the log must be in it (its 'pose' column or row number).",
)
@min_samples_option
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Output CSV.")
@imu_link_option
@force_option
def fsr(raw, robot_name, support, sensors_file, poses_file, min_samples, out, imu_link, force):
    """Reduce a raw foot-sensor log to one CoP per pose (support frame, m) with its error.

    Writes pose, joint columns (mean read-backs, rad), cop_x, cop_y, cop_se_x, cop_se_y (m),
    n_used, n_rejected, reject_reasons, and force_n (mean total force, N) when forces are logged.
    """
    outs = OutputSet([out], [raw, poses_file, sensors_file, robot_name], force=force)
    robot = load(robot_name, support)
    config = load_sensors(sensors_file, robot.profile)
    pose_list = read_table(poses_file) if poses_file is not None else None
    res, unmeasured = run_fsr(robot, read_table(raw), config, min_samples, pose_list, imu_link)
    with outs:
        write_table(outs.path(out), res.columns(robot.joint_names))
    total = res.rejected.sum(axis=0)
    why = ", ".join(f"{r} {int(c)}" for r, c in zip(REASONS, total, strict=True) if c) or "none"
    click.echo(
        f"{len(res.pose)} poses from {res.mode}: {int(res.n_used.sum())} samples used "
        f"(median {int(np.median(res.n_used))} per pose), rejected: {why}"
    )
    if res.mode == "forces":
        click.echo(
            f"  mean measured weight {np.mean(res.force) / 9.80665:.4f} kg "
            f"(model {robot.total_mass:.4f} kg); mean CoP standard error "
            f"x {mm(float(np.mean(res.cop_se[:, 0])))}, y {mm(float(np.mean(res.cop_se[:, 1])))}"
        )
    for pose, reason in res.dropped:
        click.echo(f"  pose {pose} has no CoP: {reason}", err=True)
    if unmeasured:
        more = f" (and {len(unmeasured) - 5} more)" if len(unmeasured) > 5 else ""
        click.echo(
            f"  {len(unmeasured)} poses of the list were not measured: "
            f"{', '.join(unmeasured[:5])}{more}",
            err=True,
        )
    click.echo(f"wrote {out}")


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


@click.command()
@click.argument("fit_file", type=click.Path(dir_okay=False))
@click.argument("measured", type=click.Path(dir_okay=False))
@click.option("--out-dir", default="report", show_default=True, type=click.Path(file_okay=False))
@imu_link_option
@force_option
def report(fit_file, measured, out_dir, imu_link, force):
    """Figures and one self-contained HTML page from a fit and measured CoPs (never re-fits).

    With grav_x/y/z (or IMU) columns the predicted CoPs are projected along that gravity.
    """
    from sescid.sensors.imu import table_gravity

    outs = OutputSet([], [fit_file, measured], folders=[out_dir], force=force)
    fit = load_fit(fit_file)
    table = read_table(measured)
    q = read_poses(table, fit.robot.joint_names, fit.robot.profile.servo)
    gravity = table_gravity(fit.robot, table, q, imu_link)
    cop = read_cop(table)
    se = read_cop_se(table)
    with outs:
        res = write_report(
            fit,
            q,
            cop,
            outs.folder(out_dir),
            cop_se=se,
            pose_ids=pose_list_ids(table),
            progress=TerminalProgress("report files"),
            gravity=gravity,
        )
    b, a = res["before"], res["after"]
    click.echo(
        f"CoP offset predicted − measured over {len(q)} poses: manufacturer model mean "
        f"{mm(b['mean'])} (x {mm(b['mean_x'])}, y {mm(b['mean_y'])}), RMS {mm(b['rms'])}; "
        f"identified mean {mm(a['mean'])}, RMS {mm(a['rms'])}"
    )
    html = f"{out_dir}/{res['html'].name}"
    click.echo(f"wrote {html} and {len(res['figures'])} figures")


def _sole_notes(robot, capsules) -> list[str]:
    """Where the soles came from and what the floor check left out (any robot)."""
    from sescid.planning.ground import ground_checks

    out = [s.note for s in (robot.sole, robot.free_sole) if s is not None and s.derived]
    if robot.sole is None:
        out.append("no sole: no profile sole size and no geometry on the support body")
    if capsules is not None:
        out += ground_checks(robot, capsules).notes
    return out


@click.command()
@robot_options
@click.option(
    "--count",
    default=38,
    show_default=True,
    type=click.IntRange(min=1),
    help="Number of poses K to choose.",
)
@click.option(
    "--select",
    type=click.Choice(["d-optimal", "random"]),
    default="d-optimal",
    show_default=True,
    help="D-optimal (greedy + exchange) or K random candidates.",
)
@seed_option
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Pose list CSV.")
@click.option(
    "--candidates",
    "n_candidates",
    default=None,
    type=click.IntRange(min=1, max=10_000_000),
    help="Stable, collision-free candidate poses to choose from "
    "[default: 20000 for uniform draws (op2), 5000 with the adjusted sampler].",
)
@click.option(
    "--test-poses",
    default=2_000,
    show_default=True,
    type=click.IntRange(min=1, max=10_000_000),
    help="Held-out poses for the error.",
)
@click.option(
    "--cop-box",
    default=None,
    type=float,
    help="Stability: model CoP within ±this of the sole centre in x and y [m] "
    "(default: the robot profile's; op2 the paper's 0.023).",
)
@click.option(
    "--margin",
    default=None,
    type=float,
    help="Stability: CoP inside the sole rectangle shrunk by this [m] (instead of --cop-box).",
)
@click.option(
    "--sole-size",
    nargs=2,
    type=float,
    default=None,
    help="Sole rectangle length and width [m] for --margin (default: the profile's).",
)
@click.option(
    "--clearance",
    default=DEFAULT_CLEARANCE,
    show_default=True,
    help="Free sole corners above the ground by at least this [m].",
)
@click.option(
    "--range-deg", default=None, type=float, help="Also limit every joint to ±this [degrees]."
)
@click.option(
    "--urdf-limits", is_flag=True, help="Sample within the model's limits, not the paper's."
)
@click.option(
    "--noise",
    default=PAPER_NOISE,
    show_default=True,
    help="CoP noise σ for the expected error [m].",
)
@click.option(
    "--figure",
    default=None,
    type=click.Path(dir_okay=False),
    help="Also write a PNG: expected CoP error vs K, D-optimal vs random.",
)
@click.option(
    "--paper-convention",
    is_flag=True,
    help="Add <joint>_paper_deg columns (the paper's Table 2 angle convention; op2).",
)
@force_option
def poses(
    robot_name,
    support,
    count,
    select,
    seed,
    out,
    n_candidates,
    test_poses,
    cop_box,
    margin,
    sole_size,
    clearance,
    range_deg,
    urdf_limits,
    noise,
    figure,
    paper_convention: bool,
    force: bool,
):
    """Plan stable, collision-free poses for the bench experiment (paper §4), chosen to be
    informative, ordered to keep consecutive poses close.

    Columns: pose (id), one per joint in radians (servo convention), <joint>_deg,
    <joint>_ticks (when the robot profile knows its servo), cop_x, cop_y (model CoP, m).
    """
    outs = OutputSet([out, figure], [robot_name], force=force)
    robot = load(robot_name, support)
    if n_candidates is None:
        n_candidates = 20_000 if robot.profile.pose_sampler == "uniform" else 5_000
    need = min_poses(robot)
    if count < need:
        raise OptionError("count", f"{count}: at least {need} poses are needed on {robot.name}")
    if n_candidates < count:
        raise OptionError("count", f"must not exceed --candidates ({n_candidates})")
    if not noise > 0 or not clearance >= 0:
        raise OptionError("noise", "must be > 0 and --clearance ≥ 0 (metres)")
    pc = robot_paper_convention(robot)
    if paper_convention and pc is None:
        raise OptionError("paper_convention", "--paper-convention: this robot's profile has none")
    half = cop_half_extents(robot, cop_box, margin, sole_size)
    limits = sampling_limits(robot, paper=not urdf_limits, range_deg=range_deg)
    plan = plan_poses(
        robot,
        count,
        select,
        seed,
        n_candidates=n_candidates,
        n_test=test_poses,
        sigma=noise,
        limits=limits,
        half_extents=half,
        clearance=clearance,
        progress=TerminalProgress("candidates"),
    )
    capsules = plan.candidates.capsules
    notes = list(capsules.notes) if capsules is not None else []
    notes += _sole_notes(robot, capsules)
    cols: dict[str, np.ndarray] = {"pose": np.arange(count)}
    names = robot.joint_names
    cols |= {j: plan.q[:, k] for k, j in enumerate(names)}
    cols |= {f"{j}_deg": np.degrees(plan.q[:, k]) for k, j in enumerate(names)}
    servo = robot.profile.servo
    if servo is not None:
        try:
            ticks = servo.to_ticks(plan.q)
            cols |= {f"{j}_ticks": ticks[:, k] for k, j in enumerate(names)}
        except SescidError:
            notes.append(f"no _ticks columns: some angles are outside the {servo.name} range")
    if paper_convention and pc is not None:
        qp = np.degrees(pc.to_paper(plan.q))
        cols |= {f"{j}_paper_deg": qp[:, k] for k, j in enumerate(names)}
    cols |= {"cop_x": plan.cop[:, 0], "cop_y": plan.cop[:, 1]}
    echo = click.echo
    cand = plan.candidates
    echo(f"candidates: {cand.summary()}")
    free = free_sole(robot)
    n_pairs = len(capsules.pairs) if capsules is not None else 0
    echo(
        f"  stability: CoP within ±{half[0] * 1e3:.1f} mm (x) ±{half[1] * 1e3:.1f} mm (y); "
        + (f"{free} corners ≥ {clearance * 1e3:g} mm above ground; " if free else "")
        + f"{n_pairs} capsule pairs checked"
    )
    for note in notes:
        echo(f"  note: {note}")
    echo(f"identifiable subspace: p = {plan.rank}; chose {count} poses ({select})")
    echo(
        f"expected noise-free CoP error on fresh poses (σ = {noise * 1e3:g} mm): "
        f"chosen {mm(plan.expected_error)}, {count} random {mm(plan.random_error)} (median)"
    )
    echo(
        f"joint-space path from the zero pose: {plan.path_unordered:.2f} rad in selection "
        f"order → {plan.path_ordered:.2f} rad ordered"
    )
    curve = None
    if figure:
        ks = [need, 25, 30, 38, 50, 70, 100, 150, 200, count]
        ks = sorted({k for k in ks if need <= k <= min(n_candidates, max(200, count))})
        curve = design_curve(
            plan.a_pool, plan.c_test, ks, noise, seed, progress=TerminalProgress("figure: K values")
        )
    with outs:
        write_table(outs.path(out), cols)
        if curve is not None:
            design_figure(curve, outs.path(figure), title=f"{robot.name}: pose selection")
    echo(f"wrote {out}: {count} poses ({len(cols)} columns)")
    if curve is not None:
        echo(f"wrote {figure}")
