"""Commands on simulated data and the model: simulate, demo, info."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from sescid.base.files import OutputSet
from sescid.cli.common import force_option, load, mm, robot_options, seed_option
from sescid.simulation import PAPER_MAE, PAPER_NOISE, PAPER_POSES, PAPER_RANGE_DEG


@click.command()
@robot_options
@click.option("--poses", default=PAPER_POSES, show_default=True, help="Number of poses.")
@click.option(
    "--range-deg",
    default=PAPER_RANGE_DEG,
    show_default=True,
    help="Joints uniform in ±range [degrees].",
)
@click.option(
    "--noise", default=PAPER_NOISE, show_default=True, help="CoP noise standard deviation [m]."
)
@seed_option
@click.option(
    "--clip/--no-clip",
    default=None,
    help="Clip the poses to the joint limits [default: clip, except for a robot whose profile "
    "carries the paper's convention (op2: the paper's ±30° study is unclipped)].",
)
@click.option("--stable", is_flag=True, help="Keep only poses whose CoP is inside the sole.")
@click.option(
    "--tilt-deg",
    default=0.0,
    show_default=True,
    type=click.FloatRange(0, 30),
    help="Tilt the support per pose by a random roll and pitch of this standard deviation "
    "[degrees]; writes grav_x, grav_y, grav_z.",
)
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Output CSV.")
@force_option
def simulate(
    robot_name, support, poses, range_deg, noise, seed, clip, stable, tilt_deg, out, force
):
    """Simulate poses and CoP measurements (paper §3) into a CSV.

    Columns: one per joint (radians), cop_x, cop_y (noisy, m), cop_x_true, cop_y_true (m);
    with --tilt-deg also grav_x, grav_y, grav_z (gravity direction in the support frame).
    """
    import math

    from sescid.io import write_table
    from sescid.simulation import simulate as run_simulate

    outs = OutputSet([out], [robot_name], force=force)
    robot = load(robot_name, support)
    if clip is None:
        clip = robot.profile.paper_limits_file is None
    sim = run_simulate(
        robot, poses, range_deg, noise, seed, clip, stable=stable, tilt=math.radians(tilt_deg)
    )
    cols = {name: sim.q[:, j] for j, name in enumerate(robot.joint_names)}
    cols |= {"cop_x": sim.cop[:, 0], "cop_y": sim.cop[:, 1]}
    cols |= {"cop_x_true": sim.cop_true[:, 0], "cop_y_true": sim.cop_true[:, 1]}
    if sim.gravity is not None:
        cols |= {f"grav_{a}": sim.gravity[:, i] for i, a in enumerate("xyz")}
    with outs:
        write_table(outs.path(out), cols)
    click.echo(f"wrote {out}: {poses} poses of {robot.name}, noise {noise} m")
    if clip:
        click.echo(f"  clipped to the joint limits: {sim.n_clipped} of {poses} poses")
    else:
        lim = robot.joint_limits
        out_of = int(np.sum(np.any((sim.q < lim[:, 0]) | (sim.q > lim[:, 1]), axis=1)))
        click.echo(f"  not clipped: {out_of} of {poses} poses exceed a joint limit")
    if stable:
        click.echo(
            f"  --stable: {sim.n_drawn - poses} of {sim.n_drawn} draws rejected "
            f"(CoP outside the sole {robot.sole.size[0]:.3f} x {robot.sole.size[1]:.3f} m)"
        )


@click.command()
@robot_options
@click.option("--out-dir", default="demo_out", show_default=True, type=click.Path(file_okay=False))
@click.option("--poses", default=PAPER_POSES, show_default=True)
@click.option("--range-deg", default=PAPER_RANGE_DEG, show_default=True, help="[degrees]")
@click.option("--noise", default=PAPER_NOISE, show_default=True, help="[m]")
@seed_option
@force_option
def demo(robot_name, support, out_dir, poses, range_deg, noise, seed, force):
    """Reproduce the paper's §3 simulation study; print its numbers and write its figures."""
    from sescid.report import body_labels, paper_order
    from sescid.study import paper_study

    names = ["fit.json", "fig3a_r_magnitudes.png", "fig3b_cop.png", "summary.csv"]
    OutputSet([Path(out_dir) / f for f in names], [robot_name], folders=[out_dir], force=force)
    robot = load(robot_name, support)
    st = paper_study(robot, poses, range_deg, noise, seed)
    fit = st.fit
    p = fit.rank
    echo = click.echo
    echo(f"Paper §3 simulation study on {robot.name} (support {robot.support})")
    echo(f"  {poses} poses, joints uniform in ±{range_deg:g}°, CoP noise σ = {noise} m")
    echo(f"  regressor rank p = {p} of {fit.r.size} SESC components")
    echo(
        f"  MAE estimated vs measured CoP: {mm(st.mae)}  (paper: {PAPER_MAE * 1e3:.1f} mm; "
        f"noise floor 0.798σ√(1−p/2n) = {mm(st.noise_floor_mae)})"
    )
    echo(
        f"  RMSE vs noise-free CoP, fitted poses: {mm(st.rmse_fitted)}  "
        f"(theory σ√(p/2n) = {mm(st.rmse_fitted_theory)})"
    )
    echo(
        f"  RMSE vs noise-free CoP, {len(st.fresh.q)} fresh poses: {mm(st.rmse_fresh)}  "
        f"(theory σ√(p/(2n−p−1)) = {mm(st.rmse_fresh_theory)})"
    )
    echo(f"  sigma_hat {mm(fit.sigma_hat)} (true {noise * 1e3:.3f} mm)")
    frac = float(np.mean(fit.com_z_prior_fraction(st.fresh.q[:2000])))
    prior_mm = fit.com_z_from_prior(st.fresh.q[:2000]) * 1e3
    spread = "the same at every pose" if np.ptp(prior_mm) < 1e-6 else "mean over poses"
    echo(
        f"  CoM height: {frac:.0%} of the z regressor row lies outside the identifiable "
        f"subspace; {prior_mm.mean():.1f} mm of each height ({spread}) comes from the prior model"
    )
    labels = body_labels(robot)
    echo("  R_i = |r_i| [mm]   manufacturer   identified ± 1σ")
    r_prior_mm = np.linalg.norm(fit.r_prior, axis=1) * 1e3
    std_mm = np.linalg.norm(fit.r_std, axis=1) * 1e3
    for i in paper_order(robot):
        echo(
            f"    {labels[i]:>3s} {robot.body_names[i]:16s} {r_prior_mm[i]:9.3f}"
            f"   {fit.r_magnitudes[i] * 1e3:9.3f} ± {std_mm[i]:.3f}"
        )
    outs = OutputSet([], [robot_name], folders=[out_dir], force=force)
    with outs:
        out = outs.folder(out_dir)
        _demo_files(robot, st, out)
    echo(f"wrote {out_dir}/fit.json, fig3a_r_magnitudes.png, fig3b_cop.png, summary.csv")


def _demo_files(robot, st, out: Path) -> None:
    """The demo's fit, figures and summary, written into ``out``."""
    from sescid.io import write_table
    from sescid.report import plot_cop_comparison, plot_r_magnitudes, run_figures

    fit = st.fit
    p = fit.rank
    fit.save(out / "fit.json")
    k = np.arange(min(26, len(st.sim.q)))
    predicted = {
        "manufacturer model": robot.cop(st.sim.q[k]),
        "identified": fit.predict_cop(st.sim.q[k]),
    }
    title = f"CoP over {len(k)} of the poses (paper Fig. 3b)"
    run_figures(  # the second figure on the second core where there is one
        [
            lambda: plot_r_magnitudes(fit, out / "fig3a_r_magnitudes.png"),
            lambda: plot_cop_comparison(
                k + 1, st.sim.cop[k], predicted, out / "fig3b_cop.png", title=title
            ),
        ]
    )
    names = [
        "rank",
        "mae_m",
        "noise_floor_mae_m",
        "rmse_fitted_m",
        "rmse_fitted_theory_m",
        "rmse_fresh_m",
        "rmse_fresh_theory_m",
        "sigma_hat_m",
    ]
    values = [
        float(p),
        st.mae,
        st.noise_floor_mae,
        st.rmse_fitted,
        st.rmse_fitted_theory,
        st.rmse_fresh,
        st.rmse_fresh_theory,
        fit.sigma_hat,
    ]
    write_table(out / "summary.csv", {"quantity": np.array(names), "value": np.array(values)})


@click.command()
@robot_options
def info(robot_name, support):
    """Print the robot's bodies, masses, joints and limits."""
    robot = load(robot_name, support)
    click.echo(repr(robot))
    click.echo(f"model file: {robot.model_path}")
    for note in robot.model.notes:
        click.echo(f"note: {note}")
    click.echo("bodies (index 0 = support body):")
    r = robot.sesc_vectors()
    for i, (b, m) in enumerate(zip(robot.body_names, robot.masses, strict=True)):
        rr = " ".join(f"{v * 1e3:8.3f}" for v in r[i])
        click.echo(f"  {i:2d} {b:24s} {m:8.4f} kg   r = [{rr}] mm")
    click.echo("joints (column order of q; limits in degrees):")
    for name, (lo, hi) in zip(robot.joint_names, np.degrees(robot.joint_limits), strict=True):
        click.echo(f"  {name:24s} [{lo:8.1f}, {hi:8.1f}]")
