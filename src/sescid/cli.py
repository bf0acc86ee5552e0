"""The ``sescid`` command line: a thin shell over the Python API.

Every error a user can cause is printed as one line ``sescid: error: …`` with exit code 2;
outputs are written atomically (nothing is left half-written).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import click
import numpy as np

from .errors import SescidError
from .progress import TerminalProgress


class _Group(click.Group):
    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except SescidError as exc:
            click.echo(f"sescid: error: {exc}", err=True)
            sys.exit(2)
        except OSError as exc:
            name = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
            click.echo(f"sescid: error: {name}{exc.strerror or exc}", err=True)
            sys.exit(2)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="sescid")
def cli() -> None:
    """Identify a humanoid robot's mass distribution from centre-of-pressure measurements."""


def robot_options(f):
    """--robot/--support, shared by every command that loads a robot."""
    f = click.option(
        "--support",
        default=None,
        help="Support link (the sole frame the robot stands on). Default: r_sole for op2.",
    )(f)
    f = click.option(
        "--robot",
        "robot_name",
        default="op2",
        show_default=True,
        help="Embedded model name (op2) or a URDF file.",
    )(f)
    return f


def _load(robot_name: str, support: str | None):
    from .robot import load_robot

    return load_robot(robot_name, support)


def _mm(x: float) -> str:
    return "n/a" if x is None or math.isnan(x) else f"{x * 1e3:.3f} mm"


@cli.command()
@robot_options
@click.option("--poses", default=1000, show_default=True, help="Number of poses.")
@click.option(
    "--range-deg", default=30.0, show_default=True, help="Joints uniform in ±range [degrees]."
)
@click.option(
    "--noise", default=0.00493, show_default=True, help="CoP noise standard deviation [m]."
)
@click.option("--seed", default=0, show_default=True)
@click.option("--clip", is_flag=True, help="Clip the poses to the joint limits.")
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Output CSV.")
def simulate(robot_name, support, poses, range_deg, noise, seed, clip, out):
    """Simulate poses and CoP measurements (paper §3) into a CSV.

    Columns: one per joint (radians), cop_x, cop_y (noisy, m), cop_x_true, cop_y_true (m).
    """
    from .io import write_table
    from .simulate import simulate as run

    robot = _load(robot_name, support)
    sim = run(robot, poses, range_deg, noise, seed, clip)
    cols = {name: sim.q[:, j] for j, name in enumerate(robot.joint_names)}
    cols |= {"cop_x": sim.cop[:, 0], "cop_y": sim.cop[:, 1]}
    cols |= {"cop_x_true": sim.cop_true[:, 0], "cop_y_true": sim.cop_true[:, 1]}
    write_table(out, cols)
    click.echo(f"wrote {out}: {poses} poses of {robot.name}, noise {noise} m")


def _fit_ls(robot, q, cop, sigma, opts):
    from .estimate import identify as run

    with TerminalProgress(f"identifying {len(q)} poses") as bar:
        return run(robot, q, cop, sigma=sigma, rtol=opts["rtol"], progress=bar)


def _fit_map(robot, q, cop, sigma, opts):
    from .prior import identify_map

    return identify_map(
        robot,
        q,
        cop,
        sigma=sigma,
        prior_scale=opts.get("prior_scale"),
        noise=opts.get("noise"),
        bias=bool(opts.get("bias")),
        rtol=opts["rtol"],
        select=opts.get("prior_select") or "evidence",
        seed=opts.get("seed") or 0,
    )


def consistent_options(f):
    """Options of the consistent step (identify --method consistent, export)."""
    for opt in reversed(
        [
            click.option(
                "--total-mass",
                type=float,
                default=None,
                help="consistent: weighed total mass [kg] (default: the URDF's).",
            ),
            click.option(
                "--mass-floor",
                type=float,
                default=0.0,
                show_default=True,
                help="consistent: lower bound on every body's mass [kg].",
            ),
            click.option(
                "--symmetric", is_flag=True, help="consistent: mirrored bodies (*_R/*_L) equal."
            ),
            click.option(
                "--box-margin",
                type=float,
                default=None,
                help="consistent: grow the CoM boxes by this [m] (default 0, fallback boxes 0.02).",
            ),
            click.option(
                "--cad-std",
                type=float,
                default=None,
                help="consistent: trade data fit against a Gaussian prior on the relative "
                "deviation from CAD of this std (e.g. 0.05) instead of fitting the data first.",
            ),
        ]
    ):
        f = opt(f)
    return f


def _consistent_kwargs(opts) -> dict:
    return {
        "total_mass": opts.get("total_mass"),
        "mass_floor": opts.get("mass_floor") or 0.0,
        "symmetric": bool(opts.get("symmetric")),
        "box_margin": opts.get("box_margin"),
        "prior_std": opts.get("cad_std"),
    }


def _fit_consistent(robot, q, cop, sigma, opts):
    from .consistent import identify_consistent

    if opts.get("bias"):
        raise SescidError("--bias needs --method map")
    return identify_consistent(
        robot, q, cop, sigma=sigma, rtol=opts["rtol"], **_consistent_kwargs(opts)
    )


#: ``identify --method`` name → fit function ``(robot, q, cop, sigma, opts) -> Fit``; ``opts``
#: holds every option of the command by parameter name (add a method's own options there).
IDENTIFY_METHODS = {"ls": _fit_ls, "map": _fit_map, "consistent": _fit_consistent}


def _run_online(robot, q, cop, sigma, opts, method):
    from .online import OnlineEstimator

    if method not in ("ls", "map"):
        raise SescidError(f"--online supports --method ls or map, not {method}")
    if opts.get("robust") or opts.get("bias"):
        raise SescidError("--online cannot be combined with --robust or --bias")
    prior = None
    if method == "map":
        if opts.get("prior_scale") is None or opts.get("noise") is None:
            raise SescidError("--online --method map needs --prior-scale and --noise (m)")
        prior = opts["prior_scale"]
    step = opts.get("online_step") or 1
    if step < 1:
        raise SescidError(f"--online-step must be ≥ 1 pose, got {step}")
    est = OnlineEstimator(robot, prior_scale=prior, noise=opts.get("noise"), rtol=opts["rtol"])
    click.echo("online: poses  rank  predicted RMS CoP std")
    shown, marks = set(), {1, 2, 5}
    for s in range(0, len(q), step):
        blk = slice(s, s + step)
        st = est.update(q[blk], cop[blk], None if sigma is None else sigma[blk])
        first = st.converged and est.converged_at == st.n_poses
        n = st.n_poses
        decade = 10 ** int(math.log10(n))
        if first or n == len(q) or (n // decade in marks and n % decade == 0 and n not in shown):
            shown.add(n)
            flag = "  converged" if first else ""
            std = _mm(st.cop_std) if math.isfinite(st.cop_std) else "not determined yet"
            click.echo(f"online: {n:6d}  {st.rank:4d}  {std}{flag}")
    at = est.converged_at
    click.echo(
        f"online: converged at {at} poses (RMS CoP std fell < {est.tol:.0%} over {est.window})"
        if at
        else "online: not converged yet (more poses would still improve the prediction)"
    )
    return est.fit()


@cli.command()
@click.argument("data", type=click.Path(dir_okay=False))
@robot_options
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Fit JSON.")
@click.option(
    "--weighted",
    is_flag=True,
    help="Weight each pose by its CoP standard error (columns cop_se_x, cop_se_y).",
)
@click.option(
    "--rtol",
    default=1e-6,
    show_default=True,
    help="Rank tolerance on singular values, relative to the largest.",
)
@click.option(
    "--method",
    type=click.Choice(list(IDENTIFY_METHODS)),
    default="ls",
    show_default=True,
    help="ls: least squares (undetermined directions from the URDF); map: Gaussian CAD prior; "
    "consistent: body masses and CoMs (see --total-mass …).",
)
@consistent_options
@click.option(
    "--prior-scale",
    type=float,
    default=None,
    help="map: prior standard deviation of each SESC component [m] (default: evidence).",
)
@click.option(
    "--prior-select",
    type=click.Choice(["evidence", "cv"]),
    default="evidence",
    show_default=True,
    help="map: choose the prior scale by marginal likelihood or 5-fold cross-validation.",
)
@click.option(
    "--noise",
    type=float,
    default=None,
    help="map/online: known CoP noise standard deviation [m] (default: estimated).",
)
@click.option("--bias", is_flag=True, help="map: estimate constant CoP offsets b_x, b_y [m].")
@click.option("--robust", is_flag=True, help="Huber IRLS; names the down-weighted poses.")
@click.option("--cv", type=int, default=None, help="Print the k-fold cross-validated CoP error.")
@click.option(
    "--joint-noise-deg",
    type=float,
    default=None,
    help="Monte-Carlo effect of joint-angle errors of this standard deviation [degrees].",
)
@click.option("--mc-draws", default=30, show_default=True, help="Monte-Carlo draws.")
@click.option("--online", is_flag=True, help="Recursive estimator; prints the convergence.")
@click.option("--online-step", default=1, show_default=True, help="Poses per online update.")
@click.option("--seed", default=0, show_default=True, help="Seed of CV folds / Monte Carlo.")
def identify(data, robot_name, support, out, weighted, rtol, method, **opts):
    """Identify the SESC vectors from a CSV/Parquet of poses (radians) and cop_x, cop_y (m)."""
    from .io import read_cop, read_cop_se, read_poses, read_table

    robot = _load(robot_name, support)
    table = read_table(data)
    q = read_poses(table, robot.joint_names)
    cop = read_cop(table)
    sigma = None
    if weighted:
        sigma = read_cop_se(table)
        if sigma is None:
            raise SescidError(f"{data}: --weighted needs columns cop_se_x, cop_se_y")
    opts["rtol"] = rtol
    if method != "map":
        given = [
            name
            for name, on in (
                ("--bias", opts.get("bias")),
                ("--prior-scale", opts.get("prior_scale") is not None),
                ("--prior-select cv", opts.get("prior_select") == "cv"),
            )
            if on
        ]
        if given:
            why = (
                ": a constant CoP offset is confounded with the support body's x/y SESC "
                "components, only a prior on them separates the two"
                if opts.get("bias")
                else ""
            )
            raise SescidError(f"{', '.join(given)} needs --method map (got {method}){why}")
    method_fit = IDENTIFY_METHODS[method]

    def fitter(qq, cc, ss):
        return method_fit(robot, qq, cc, ss, opts)

    if opts["robust"]:
        from .robust import huber

        plain = fitter

        def fitter(qq, cc, ss):
            return huber(plain, qq, cc, ss)

    fit = (
        _run_online(robot, q, cop, sigma, opts, method) if opts["online"] else fitter(q, cop, sigma)
    )
    _report_extras(fit, fitter, q, cop, sigma, opts)
    if "cop_x_true" in table and "cop_y_true" in table:  # simulated data: the noise-free CoP
        from .validation import truth_error

        truth = np.column_stack([table.get("cop_x_true"), table.get("cop_y_true")])
        fit.extra["truth_cop_rmse_m"] = truth_error(fit, q, truth)
        click.echo(
            f"truth: RMS of predicted − noise-free CoP at these poses "
            f"{_mm(fit.extra['truth_cop_rmse_m'])} (columns cop_x_true, cop_y_true)"
        )
    fit.save(out)
    click.echo(fit.summary())
    click.echo(f"wrote {out}")


def _report_extras(fit, fitter, q, cop, sigma, opts) -> None:
    """--robust / --bias / --cv / --joint-noise-deg: print and store in fit.extra."""
    if "robust" in fit.extra:
        low = fit.extra["robust"]["downweighted"]
        shown = ", ".join(f"{i} (w {w:.2f})" for i, w in low[:10])
        more = f" and {len(low) - 10} more" if len(low) > 10 else ""
        click.echo(f"robust: {len(low)} poses down-weighted (row index, weight): {shown}{more}")
    if "bias" in fit.extra:
        (bx, by), (sx, sy) = fit.extra["bias"], fit.extra["bias_std"]
        click.echo(
            f"bias: b_x = {_mm(bx)} ± {_mm(sx)}, b_y = {_mm(by)} ± {_mm(sy)} "
            "(separated from the support body's r by the prior only)"
        )
    if opts["cv"] is not None:
        from .validation import cross_validate

        cv = cross_validate(
            fitter, q, cop, opts["cv"], sigma, opts["seed"], progress=TerminalProgress("cv fold")
        )
        fit.extra["cv"] = cv.to_json()
        click.echo(
            f"cv: {cv.k}-fold CoP RMSE {_mm(cv.rmse)} (noise {_mm(cv.noise)}, model part "
            f"{_mm(cv.model_rmse)})"
        )
    if opts["joint_noise_deg"] is not None:
        from .robust import joint_noise_mc

        mc = joint_noise_mc(
            fitter,
            fit,
            q,
            cop,
            math.radians(opts["joint_noise_deg"]),
            sigma=sigma,
            draws=opts["mc_draws"],
            seed=opts["seed"],
            progress=TerminalProgress("joint-noise draw"),
        )
        fit.extra["joint_noise"] = mc.to_json()
        click.echo(
            f"joint noise {opts['joint_noise_deg']:g}°: RMS CoP prediction std "
            f"{_mm(mc.cop_std_joint)} from joint angles vs {_mm(mc.cop_std_noise)} from CoP noise "
            f"(joint share {mc.share_joint:.0%} of the variance)"
        )


@cli.command()
@click.argument("fit_file", type=click.Path(dir_okay=False))
@click.argument("poses", type=click.Path(dir_okay=False))
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Output CSV.")
@click.option(
    "--level",
    type=float,
    default=None,
    help="Add <col>_lower/<col>_upper interval columns at this confidence (e.g. 0.95). "
    "The CoM-z interval omits the error of its prior-filled part (com_z_from_prior).",
)
def predict(fit_file, poses, out, level):
    """Predict CoP (x, y) and CoM (x, y, z) in metres at the poses of a CSV (radians)."""
    from .io import load_fit, read_poses, read_table, write_table

    fit = load_fit(fit_file)
    q = read_poses(read_table(poses), fit.robot.joint_names)
    cop = fit.predict_cop(q)
    com = fit.predict_com(q)
    std = fit.predict_std(q)
    cols = {
        "cop_x": cop[:, 0],
        "cop_y": cop[:, 1],
        "com_x": com[:, 0],
        "com_y": com[:, 1],
        "com_z": com[:, 2],
        "com_x_std": std[:, 0],
        "com_y_std": std[:, 1],
        "com_z_std": std[:, 2],
        "com_z_from_prior": fit.com_z_from_prior(q),
    }
    if level is not None:
        from .validation import com_interval

        iv = com_interval(fit, q, level)  # CoP = CoM x, y
        for j, name in enumerate(("com_x", "com_y", "com_z")):
            cols[f"{name}_lower"], cols[f"{name}_upper"] = iv.lower[:, j], iv.upper[:, j]
        for j, name in enumerate(("cop_x", "cop_y")):
            cols[f"{name}_lower"], cols[f"{name}_upper"] = iv.lower[:, j], iv.upper[:, j]
    write_table(out, cols)
    click.echo(f"wrote {out}: {len(q)} poses")


@cli.command()
@robot_options
def info(robot_name, support):
    """Print the robot's bodies, masses, joints and limits."""
    robot = _load(robot_name, support)
    click.echo(repr(robot))
    click.echo(f"URDF: {robot.urdf_path}")
    click.echo("bodies (index 0 = support body):")
    r = robot.sesc_vectors()
    for i, (b, m) in enumerate(zip(robot.body_names, robot.masses, strict=True)):
        rr = " ".join(f"{v * 1e3:8.3f}" for v in r[i])
        click.echo(f"  {i:2d} {b:24s} {m:8.4f} kg   r = [{rr}] mm")
    click.echo("joints (column order of q; limits in degrees):")
    for name, (lo, hi) in zip(robot.joint_names, np.degrees(robot.joint_limits), strict=True):
        click.echo(f"  {name:24s} [{lo:8.1f}, {hi:8.1f}]")


@cli.command()
@robot_options
@click.option("--out-dir", default="demo_out", show_default=True, type=click.Path(file_okay=False))
@click.option("--poses", default=1000, show_default=True)
@click.option("--range-deg", default=30.0, show_default=True, help="[degrees]")
@click.option("--noise", default=0.00493, show_default=True, help="[m]")
@click.option("--seed", default=0, show_default=True)
def demo(robot_name, support, out_dir, poses, range_deg, noise, seed):
    """Reproduce the paper's §3 simulation study; print its numbers and write its figures."""
    from .io import write_table
    from .report import plot_cop_comparison, plot_r_magnitudes
    from .simulate import PAPER_MAE, paper_study

    robot = _load(robot_name, support)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    st = paper_study(robot, poses, range_deg, noise, seed)
    fit = st.fit
    p = fit.rank
    echo = click.echo
    echo(f"Paper §3 simulation study on {robot.name} (support {robot.support})")
    echo(f"  {poses} poses, joints uniform in ±{range_deg:g}°, CoP noise σ = {noise} m")
    echo(f"  regressor rank p = {p} of {fit.r.size} SESC components")
    echo(
        f"  MAE estimated vs measured CoP: {_mm(st.mae)}  (paper: {PAPER_MAE * 1e3:.1f} mm; "
        f"noise floor 0.798σ√(1−p/2n) = {_mm(st.noise_floor_mae)})"
    )
    echo(
        f"  RMSE vs noise-free CoP, fitted poses: {_mm(st.rmse_fitted)}  "
        f"(theory σ√(p/2n) = {_mm(st.rmse_fitted_theory)})"
    )
    echo(
        f"  RMSE vs noise-free CoP, {len(st.fresh.q)} fresh poses: {_mm(st.rmse_fresh)}  "
        f"(theory σ√(p/(2n−p−1)) = {_mm(st.rmse_fresh_theory)})"
    )
    echo(f"  sigma_hat {_mm(fit.sigma_hat)} (true {noise * 1e3:.3f} mm)")
    frac = float(np.mean(fit.com_z_prior_fraction(st.fresh.q[:2000])))
    prior_mm = fit.com_z_from_prior(st.fresh.q[:2000]) * 1e3
    spread = "the same at every pose" if np.ptp(prior_mm) < 1e-6 else "mean over poses"
    echo(
        f"  CoM height: {frac:.0%} of the z regressor row lies outside the identifiable "
        f"subspace; {prior_mm.mean():.1f} mm of each height ({spread}) comes from the prior model"
    )
    from .report import body_labels, paper_order

    labels = body_labels(robot)
    echo("  R_i = |r_i| [mm]   manufacturer   identified ± 1σ")
    r_prior_mm = np.linalg.norm(fit.r_prior, axis=1) * 1e3
    std_mm = np.linalg.norm(fit.r_std, axis=1) * 1e3
    for i in paper_order(robot):
        echo(
            f"    {labels[i]:>3s} {robot.body_names[i]:16s} {r_prior_mm[i]:9.3f}"
            f"   {fit.r_magnitudes[i] * 1e3:9.3f} ± {std_mm[i]:.3f}"
        )
    fit.save(out / "fit.json")
    plot_r_magnitudes(fit, out / "fig3a_r_magnitudes.png")
    k = np.arange(26)
    plot_cop_comparison(
        k + 1,
        st.sim.cop[k],
        {
            "manufacturer model": robot.cop(st.sim.q[k]),
            "identified": fit.predict_cop(st.sim.q[k]),
        },
        out / "fig3b_cop.png",
        title="CoP over 26 of the poses (paper Fig. 3b)",
    )
    write_table(
        out / "summary.csv",
        {
            "quantity": np.array(
                [
                    "rank",
                    "mae_m",
                    "noise_floor_mae_m",
                    "rmse_fitted_m",
                    "rmse_fitted_theory_m",
                    "rmse_fresh_m",
                    "rmse_fresh_theory_m",
                    "sigma_hat_m",
                ]
            ),
            "value": np.array(
                [
                    float(p),
                    st.mae,
                    st.noise_floor_mae,
                    st.rmse_fitted,
                    st.rmse_fitted_theory,
                    st.rmse_fresh,
                    st.rmse_fresh_theory,
                    fit.sigma_hat,
                ]
            ),
        },
    )
    echo(f"wrote {out}/fit.json, fig3a_r_magnitudes.png, fig3b_cop.png, summary.csv")


def _echo_masses(fit) -> None:
    ex = fit.extra
    click.echo(
        f"consistent: total mass {ex['total_mass_kg']:.4f} kg, "
        f"{len(ex['active_constraints'])} active constraints, solver {ex['solver']} "
        f"({ex['solve_time_s'] * 1e3:.0f} ms)"
    )
    for c in ex["active_constraints"][:8]:
        click.echo(f"  active: {c}")
    if len(ex["active_constraints"]) > 8:
        click.echo(f"  … and {len(ex['active_constraints']) - 8} more (see the fit's extra)")


@cli.command("export")
@click.argument("fit_file", type=click.Path(dir_okay=False))
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Output URDF.")
@consistent_options
def export_cmd(fit_file, out, **opts):
    """Write the fit's URDF with the identified masses and CoMs (inertias rescaled).

    A fit without masses (e.g. least squares) first goes through the consistent step with the
    --total-mass/--mass-floor/--symmetric/--box-margin/--cad-std options.
    """
    from .consistent import consistent_from_fit
    from .export import export_urdf
    from .io import load_fit

    fit = load_fit(fit_file)
    if "bodies" not in fit.extra:
        click.echo(f"{fit_file}: the {fit.method} fit has no masses; running the consistent step")
        fit = consistent_from_fit(fit, **_consistent_kwargs(opts))
        _echo_masses(fit)
    elif (
        (opts["total_mass"], opts["box_margin"], opts["cad_std"]) != (None, None, None)
        or opts["symmetric"]
        or opts["mass_floor"]
    ):
        raise SescidError(
            f"{fit_file}: this fit already holds masses; the consistent options apply only to "
            "fits without (re-run identify --method consistent to change them)"
        )
    for warning in export_urdf(fit, out):
        click.echo(f"sescid: warning: {warning}", err=True)
    total = sum(b["mass_kg"] for b in fit.extra["bodies"].values())
    click.echo(f"wrote {out}: {fit.robot.name} with identified masses (total {total:.4f} kg)")


@cli.command()
@click.argument("raw", type=click.Path(dir_okay=False))
@robot_options
@click.option(
    "--sensors",
    "sensors_file",
    default=None,
    type=click.Path(dir_okay=False),
    help="Foot-sensor configuration JSON (default: the shipped op2_fsr.json, a hypothesis).",
)
@click.option(
    "--poses",
    "poses_file",
    default=None,
    type=click.Path(dir_okay=False),
    help="Pose list: every pose id in the log must be in it (its 'pose' column or row number).",
)
@click.option("--min-samples", default=5, show_default=True, help="Usable samples per pose.")
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Output CSV.")
def fsr(raw, robot_name, support, sensors_file, poses_file, min_samples, out):
    """Reduce a raw foot-sensor log to one CoP per pose (support frame, m) with its error.

    Writes pose, joint columns (mean read-backs, rad), cop_x, cop_y, cop_se_x, cop_se_y (m),
    n_used, n_rejected, reject_reasons, and force_n (mean total force, N) when forces are logged.
    """
    from .io import write_table
    from .sensors import REASONS, load_sensors
    from .sensors import fsr as run

    robot = _load(robot_name, support)
    config = load_sensors(sensors_file, robot.source)
    res, unmeasured = run(robot, raw, config, min_samples, poses_file)
    write_table(out, res.columns(robot.joint_names))
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
            f"x {_mm(float(np.mean(res.cop_se[:, 0])))}, y {_mm(float(np.mean(res.cop_se[:, 1])))}"
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


@cli.command()
@robot_options
@click.option(
    "--poses",
    "poses_file",
    required=True,
    type=click.Path(dir_okay=False),
    help="Pose list (joint columns in radians; optional 'pose' id column).",
)
@click.option("--samples", default=100, show_default=True, help="Sensor readings per pose.")
@click.option("--seed", default=0, show_default=True)
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Raw log CSV.")
@click.option(
    "--truth",
    default=None,
    type=click.Path(dir_okay=False),
    help="Also write the truth (true SESC vectors, actual poses, true CoPs) as JSON.",
)
@click.option(
    "--sensors",
    "sensors_file",
    default=None,
    type=click.Path(dir_okay=False),
    help="Foot-sensor configuration JSON (default: the shipped one).",
)
@click.option(
    "--extra-mass",
    default=0.07,
    show_default=True,
    help="Unmodelled mass as a fraction of the model's mass.",
)
@click.option("--backlash-deg", default=1.0, show_default=True, help="Joint play ±b [degrees].")
@click.option("--fsr-noise", default=1.5, show_default=True, help="Per-sensor noise std [N].")
@click.option("--fsr-bias", default=0.1, show_default=True, help="Per-sensor bias std [N].")
@click.option(
    "--registers",
    type=click.Choice(["forces", "centroid", "both"]),
    default="forces",
    show_default=True,
    help="Log the four forces, the centroid registers, or both.",
)
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
    registers,
):
    """Virtual bench experiment: a "real" robot (unmodelled mass, backlash, noisy biased FSRs)
    stands in each pose of the list; writes the raw sensor log that `sescid fsr` reads."""
    import json

    from .experiment import ExperimentConfig, run_experiment
    from .io import atomic_open, read_poses, read_table, write_table
    from .sensors import load_sensors, pose_list_ids

    robot = _load(robot_name, support)
    sensors = load_sensors(sensors_file, robot.source)
    table = read_table(poses_file)
    q = read_poses(table, robot.joint_names)
    ids = pose_list_ids(table)
    cfg = ExperimentConfig(
        extra_mass_fraction=extra_mass,
        backlash_deg=backlash_deg,
        fsr_noise=fsr_noise,
        fsr_bias=fsr_bias,
        registers=registers,
    )
    try:
        ex = run_experiment(robot, q, sensors, samples, seed, cfg, pose_ids=ids)
    except SescidError as exc:
        raise SescidError(f"{poses_file}: {exc}") from None
    write_table(out, ex.columns)
    if truth:
        with atomic_open(truth, "w") as fh:
            json.dump(ex.truth, fh, indent=1)
            fh.write("\n")
    t = ex.truth
    n_logged = len(q) - len(ex.skipped)
    click.echo(
        f"wrote {out}: {n_logged} poses × {samples} samples; real robot {t['true_mass_kg']:.4f} kg "
        f"(model {t['model_mass_kg']:.4f} kg), backlash ±{backlash_deg:g}°, "
        f"FSR noise {fsr_noise:g} N, bias {fsr_bias:g} N"
    )
    for pose, why in ex.skipped:
        click.echo(f"  pose {pose} skipped: {why}", err=True)
    if truth:
        click.echo(f"wrote {truth} (the truth: true SESC vectors, actual poses, true CoPs)")


@cli.command()
@click.argument("fit_file", type=click.Path(dir_okay=False))
@click.argument("measured", type=click.Path(dir_okay=False))
@click.option("--out-dir", default="report", show_default=True, type=click.Path(file_okay=False))
def report(fit_file, measured, out_dir):
    """Figures and one self-contained HTML page from a fit and measured CoPs (never re-fits)."""
    from .io import load_fit, read_cop, read_cop_se, read_poses, read_table
    from .report import write_report
    from .sensors import pose_list_ids

    fit = load_fit(fit_file)
    table = read_table(measured)
    q = read_poses(table, fit.robot.joint_names)
    cop = read_cop(table)
    se = read_cop_se(table)
    res = write_report(
        fit,
        q,
        cop,
        out_dir,
        cop_se=se,
        pose_ids=pose_list_ids(table),
        progress=TerminalProgress("report files"),
    )
    b, a = res["before"], res["after"]
    click.echo(
        f"CoP offset predicted − measured over {len(q)} poses: manufacturer model mean "
        f"{_mm(b['mean'])} (x {_mm(b['mean_x'])}, y {_mm(b['mean_y'])}), RMS {_mm(b['rms'])}; "
        f"identified mean {_mm(a['mean'])}, RMS {_mm(a['rms'])}"
    )
    click.echo(f"wrote {res['html']} and {len(res['figures'])} figures")


@cli.command()
@robot_options
@click.option("--count", default=38, show_default=True, help="Number of poses K to choose.")
@click.option(
    "--select",
    type=click.Choice(["d-optimal", "random"]),
    default="d-optimal",
    show_default=True,
    help="D-optimal (greedy + exchange) or K random candidates.",
)
@click.option("--seed", default=0, show_default=True)
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Pose list CSV.")
@click.option(
    "--candidates",
    "n_candidates",
    default=20_000,
    show_default=True,
    help="Stable, collision-free candidate poses to choose from.",
)
@click.option(
    "--test-poses", default=2_000, show_default=True, help="Held-out poses for the error."
)
@click.option(
    "--cop-box",
    default=0.023,
    show_default=True,
    help="Stability: model CoP within ±this of the sole centre in x and y [m].",
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
    help="Sole rectangle length and width [m] for --margin (default: the OP2's 0.105 0.066).",
)
@click.option(
    "--clearance",
    default=0.005,
    show_default=True,
    help="Free sole corners above the ground by at least this [m].",
)
@click.option(
    "--range-deg", default=None, type=float, help="Also limit every joint to ±this [degrees]."
)
@click.option(
    "--urdf-limits", is_flag=True, help="OP2: sample within the URDF limits, not the paper's."
)
@click.option(
    "--noise",
    default=0.00493,
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
    help="OP2: add <joint>_paper_deg columns (the paper's Table 2 angle convention).",
)
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
    paper_convention,
):
    """Plan stable, collision-free poses for the bench experiment (paper §4), chosen to be
    informative, ordered to keep consecutive poses close.

    Columns: pose (id), one per joint in radians (servo convention), <joint>_deg, <joint>_ticks
    (Dynamixel MX-28, 2048 = 0, 4096 per turn), cop_x, cop_y (model CoP, m).
    """
    from . import design
    from .io import write_table

    robot = _load(robot_name, support)
    need = design.min_poses(robot)
    if count < need:
        raise SescidError(
            f"--count {count}: at least {need} poses are needed ({robot.name} has about "
            f"{2 * need} identifiable combinations, 2 equations per pose)"
        )
    if n_candidates < count or test_poses < 1:
        raise SescidError(f"--candidates must be ≥ --count ({count}) and --test-poses ≥ 1")
    if not noise > 0 or not clearance >= 0:
        raise SescidError("--noise must be > 0 and --clearance ≥ 0 (metres)")
    pc = design.paper_convention(robot)
    if paper_convention and pc is None:
        raise SescidError("--paper-convention is only defined for the embedded op2")
    half = design.cop_half_extents(robot, cop_box, margin, sole_size)
    limits = design.sampling_limits(robot, paper=not urdf_limits, range_deg=range_deg)
    plan = design.plan_poses(
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
    notes = list(plan.candidates.capsules.notes)
    try:
        ticks = design.mx28_ticks(plan.q)
    except SescidError:  # only possible for other robots (joints beyond ±180°)
        ticks = None
        notes.append("no _ticks columns: some angles are outside the MX-28 range")
    cols: dict[str, np.ndarray] = {"pose": np.arange(count)}
    names = robot.joint_names
    cols |= {j: plan.q[:, k] for k, j in enumerate(names)}
    cols |= {f"{j}_deg": np.degrees(plan.q[:, k]) for k, j in enumerate(names)}
    if ticks is not None:
        cols |= {f"{j}_ticks": ticks[:, k] for k, j in enumerate(names)}
    if paper_convention:
        qp = np.degrees(pc.to_paper(plan.q))
        cols |= {f"{j}_paper_deg": qp[:, k] for k, j in enumerate(names)}
    cols |= {"cop_x": plan.cop[:, 0], "cop_y": plan.cop[:, 1]}
    echo = click.echo
    cand = plan.candidates
    echo(f"candidates: {cand.summary()}")
    free = design.free_sole(robot)
    echo(
        f"  stability: CoP within ±{half[0] * 1e3:.1f} mm (x) ±{half[1] * 1e3:.1f} mm (y); "
        + (f"{free} corners ≥ {clearance * 1e3:g} mm above ground; " if free else "")
        + f"{len(cand.capsules.pairs)} capsule pairs checked"
    )
    for note in notes:
        echo(f"  note: {note}")
    echo(f"identifiable subspace: p = {plan.rank}; chose {count} poses ({select})")
    echo(
        f"expected noise-free CoP error on fresh poses (σ = {noise * 1e3:g} mm): "
        f"chosen {_mm(plan.expected_error)}, {count} random {_mm(plan.random_error)} (median)"
    )
    echo(
        f"joint-space path from the zero pose: {plan.path_unordered:.2f} rad in selection "
        f"order → {plan.path_ordered:.2f} rad ordered"
    )
    write_table(out, cols)
    echo(f"wrote {out}: {count} poses ({len(cols)} columns)")
    if figure:
        ks = [need, 25, 30, 38, 50, 70, 100, 150, 200, count]
        ks = sorted({k for k in ks if need <= k <= min(n_candidates, max(200, count))})
        curve = design.design_curve(
            plan.a_pool, plan.c_test, ks, noise, seed, progress=TerminalProgress("figure: K values")
        )
        design.design_figure(curve, figure, title=f"{robot.name}: pose selection")
        echo(f"wrote {figure}")


def main() -> None:
    cli(prog_name="sescid")


if __name__ == "__main__":
    main()
