"""``sescid demo``: the paper's §3 simulation study on the embedded OP2."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from sescid.base import OutputSet
from sescid.cli import common
from sescid.estimation import save_fit
from sescid.report import mm
from sescid.robot import Robot
from sescid.simulation import PAPER_MAE, PAPER_NOISE, PAPER_POSES, PAPER_RANGE_DEG


@click.command()
@common.robot_options
@common.folder_option(
    "--out-dir", "Folder for fit.json, the two figures and summary.csv.", "demo_out"
)
@common.study_options(PAPER_POSES, PAPER_RANGE_DEG, PAPER_NOISE)
@common.seed_option
@common.force_option
def demo(robot_name, support, out_dir, poses, range_deg, noise, seed, force):
    """Reproduce the paper's §3 simulation study; print its numbers and write its figures."""
    from sescid.report import body_labels, paper_order
    from sescid.study import paper_study

    names = ["fit.json", "fig3a_r_magnitudes.png", "fig3b_cop.png", "summary.csv"]
    OutputSet(
        [Path(out_dir) / f for f in names],
        [common.model_input(robot_name)],
        folders=[out_dir],
        force=force,
    )
    robot = common.load(robot_name, support)
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
    outs = OutputSet([], [common.model_input(robot_name)], folders=[out_dir], force=force)
    with outs:
        out = outs.folder(out_dir)
        _demo_files(robot, st, out)
    echo(f"wrote {Path(out_dir) / 'fit.json'}, fig3a_r_magnitudes.png, fig3b_cop.png, summary.csv")


def _demo_files(robot: Robot, st, out: Path) -> None:
    """The demo's fit, figures and summary, written into ``out``."""
    from sescid.report import plot_cop_comparison, plot_r_magnitudes, run_figures
    from sescid.tables import write_table

    fit = st.fit
    p = fit.rank
    save_fit(fit, out / "fit.json")
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
