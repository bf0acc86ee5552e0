"""``sescid identify``: SESC vectors, sensor offsets (or masses) from poses and measurements.

Parse the flags into the method's options and ``IdentifyOptions`` (whose defaults the flags
show), make one call to ``sescid.identify`` on the files, print the fit.
"""

from __future__ import annotations

import dataclasses
import math

import click

from sescid.api import file_stance
from sescid.api import identify as run_identify
from sescid.base import OutputSet, TerminalProgress
from sescid.cli.common import (
    force_option,
    imu_link_option,
    load,
    model_input,
    refuse_idle,
    robot_options,
    seed_option,
)
from sescid.cli.options import consistent_from_flags, consistent_options, echo_masses
from sescid.errors import DataError, OptionError, choices
from sescid.estimation import (
    COP_ON_TRUNK,
    METHOD_CHOICES,
    AutoOptions,
    ConsistentOptions,
    Fit,
    IdentifyOptions,
    Kind,
    LeastSquaresOptions,
    MapOptions,
    MethodName,
    MethodOptions,
    PriorChoice,
    PriorSelect,
    save_fit,
)
from sescid.io import rows_estimate
from sescid.report import mm

DEFAULTS = IdentifyOptions()
MAP_DEFAULTS = MapOptions()


def options_from_flags(method: MethodName, opts: dict) -> tuple[MethodOptions, IdentifyOptions]:
    """The method's options and ``identify``'s shared options from the command's flags (a
    method's flags with another method are an error naming them)."""
    refuse_idle("gain_prior", opts["tau_gains"], "without --tau-gains")
    refuse_idle("mc_draws", opts["joint_noise_deg"] is not None, "without --joint-noise-deg")
    refuse_idle("noise", method in ("map", "auto") or opts["online"],
                "without --method map (or auto) or --online")  # fmt: skip
    if method not in ("map", "auto"):
        given = [
            name
            for name, on in (
                ("--bias", opts["bias"]),
                ("--prior-scale", opts["prior_scale"] is not None),
                ("--prior-select cv", opts["prior_select"] == "cv"),
                ("--prior", opts["prior"] != "auto"),
            )
            if on
        ]
        if given and not (opts["online"] and given == ["--prior-scale"]):
            why = (
                ": a constant CoP offset is confounded with the support body's x/y SESC "
                "components, only a prior on them separates the two"
                if opts["bias"]
                else ""
            )
            raise OptionError(
                "method", f"{', '.join(given)} needs --method map (got {method}){why}"
            )
    flags = consistent_from_flags(opts)
    total_mass = flags.total_mass  # a weighed mass scales torques as well as the masses
    consistent = dataclasses.replace(flags, total_mass=None)
    if method != "consistent" and consistent != ConsistentOptions():
        raise OptionError("method", f"the consistent options need --method consistent ({method})")
    chosen: MethodOptions = LeastSquaresOptions()
    if method in ("map", "auto"):
        settings = MapOptions(
            prior_scale=opts["prior_scale"],
            noise=opts["noise"],
            select=opts["prior_select"],
            bias=opts["bias"],
            prior=opts["prior"],
        )
        chosen = settings if method == "map" else AutoOptions(settings)
    elif method == "consistent":
        chosen = consistent
    shared = IdentifyOptions(
        rtol=opts["rtol"],
        weighted=opts["weighted"],
        cop_noise=opts["cop_noise"],
        tau_noise=opts["tau_noise"],
        total_mass=total_mass,
        gravity_accel=opts["gravity_accel"],
        tau_gains=opts["tau_gains"],
        kinds=None if opts["kinds"] == "all" else (opts["kinds"],),
        gain_prior=opts["gain_prior"],
        allow_exact=opts["allow_exact"],
        imu_link=opts["imu_link"],
        allow_outside_limits=opts["allow_outside_limits"],
        com_height=opts["com_height"],
        robust="auto" if opts["robust"] is None else bool(opts["robust"]),
        seed=opts["seed"],
        cv=opts["cv"],
        joint_noise=None if opts["joint_noise_deg"] is None else math.radians(
            opts["joint_noise_deg"]),
        mc_draws=opts["mc_draws"],
        online_step=_online_step(opts),
    )  # fmt: skip
    return chosen, shared


def _online_step(opts: dict) -> int | None:
    """--online-step applies with --online only (an error without it, never ignored)."""
    if opts["online"]:
        return opts["online_step"]
    if opts["online_step"] != 1:
        raise OptionError("online", "--online-step needs --online")
    return None


@click.command()
@click.argument("data", nargs=-1, required=True, type=click.Path(dir_okay=False))
@robot_options
@click.option("--out", required=True, type=click.Path(dir_okay=False), help="Fit JSON.")
@click.option(
    "--method",
    type=click.Choice(list(METHOD_CHOICES)),
    default="auto",
    show_default=True,
    help="auto: MAP with the CAD prior when the data leave directions weakly determined, "
    "least squares when they determine every direction well (the fit says which and why); "
    "ls: least squares (the paper's; undetermined directions from the model file); map: "
    "Gaussian CAD prior; consistent: body masses and CoMs (see --total-mass …).",
)
@click.option(
    "--kinds",
    type=click.Choice(["all", *choices(Kind)]),
    default="all",
    show_default=True,
    help="Which measurements of the files to fit: all they have, the CoP only, or the joint "
    "torques only.",
)
@click.option(
    "--com-height",
    default=None,
    type=click.FloatRange(min=0, min_open=True),
    help="Balance data (a robot on a line) carry no scale: the CoM's known distance from the "
    "support line at the zero pose [m] (default: the model's).",
)
@click.option(
    "--weighted",
    is_flag=True,
    default=DEFAULTS.weighted,
    help="Weight rows by their standard errors (cop_se_x/cop_se_y, tau_se_<joint>).",
)
@click.option(
    "--rtol",
    default=DEFAULTS.rtol,
    show_default=True,
    help="Rank tolerance on singular values, relative to the largest (0 < rtol < 1).",
)
@click.option(
    "--cop-noise",
    type=float,
    default=DEFAULTS.cop_noise,
    help="Known CoP noise standard deviation [m] (default: estimated from the data).",
)
@click.option(
    "--tau-noise",
    type=float,
    default=DEFAULTS.tau_noise,
    help="Known joint-torque noise standard deviation [N·m] (default: estimated).",
)
@click.option(
    "--tau-gains",
    is_flag=True,
    default=DEFAULTS.tau_gains,
    help="Also estimate a gain error per torque sensor (only their ratios come from the data).",
)
@click.option(
    "--gain-prior",
    type=float,
    default=DEFAULTS.gain_prior,
    show_default=True,
    help="Prior std of each torque gain error (relative), with --tau-gains.",
)
@click.option(
    "--gravity-accel",
    type=float,
    default=DEFAULTS.gravity_accel,
    show_default=True,
    help="|g| behind the torque rows [m/s²] (local gravity).",
)
@click.option(
    "--allow-exact",
    is_flag=True,
    default=DEFAULTS.allow_exact,
    help="Fit even when no degrees of freedom are left (σ̂ and standard errors: not determined).",
)
@consistent_options
@click.option(
    "--prior-scale",
    type=float,
    default=MAP_DEFAULTS.prior_scale,
    help="map: prior standard deviation of each SESC component [m] (default: evidence).",
)
@click.option(
    "--prior",
    type=click.Choice(choices(PriorChoice)),
    default=MAP_DEFAULTS.prior,
    show_default=True,
    help="map: the CAD prior's shape: each SESC component ±τ m (sesc), or each body's mass ±τ "
    "and first moment ±τ·5 cm per unit mass (bodies, τ relative); auto: bodies for data with "
    "torques, sesc for the CoP alone.",
)
@click.option(
    "--prior-select",
    type=click.Choice(choices(PriorSelect)),
    default=MAP_DEFAULTS.select,
    show_default=True,
    help="map: choose the prior scale by marginal likelihood or 5-fold cross-validation.",
)
@click.option(
    "--noise",
    type=float,
    default=MAP_DEFAULTS.noise,
    help="map/online: known noise scale [m for CoP data] (default: estimated).",
)
@click.option("--bias", is_flag=True, help="map: estimate constant CoP offsets b_x, b_y [m].")
@click.option(
    "--robust/--no-robust",
    default=None,
    help="Huber IRLS, naming the down-weighted poses (default: on for torques without an "
    "approach column, whose static friction acts as bounded errors; off otherwise).",
)
@click.option(
    "--cv",
    type=click.IntRange(min=2),
    default=DEFAULTS.cv,
    help="Print the k-fold cross-validated error.",
)
@click.option(
    "--joint-noise-deg",
    type=click.FloatRange(min=0, min_open=True, max=90),
    default=None,
    help="Monte-Carlo effect of joint-angle errors of this standard deviation [degrees].",
)
@click.option(
    "--mc-draws",
    default=DEFAULTS.mc_draws,
    show_default=True,
    type=click.IntRange(min=2),
    help="MC draws.",
)
@click.option("--online", is_flag=True, help="Recursive estimator; prints the convergence.")
@click.option(
    "--online-step",
    default=1,
    show_default=True,
    type=click.IntRange(min=1),
    help="Poses per online update.",
)
@seed_option
@click.option(
    "--allow-outside-limits",
    is_flag=True,
    help="Accept poses outside the model's joint limits (a warning stored in the fit); "
    "simulated data (cop_x_true columns) get the warning without the flag.",
)
@imu_link_option
@force_option
def identify(data, robot_name, support, out, method, force, **opts):
    """Identify the SESC vectors from CSV/Parquet files of poses (radians) and what was
    measured: cop_x, cop_y (m) and/or tau_<joint> (N·m) columns; several files are pooled.

    Optional columns: grav_x, grav_y, grav_z (gravity direction in the support frame; a tilted
    sole), approach (±1: each pose reached moving up or down, for torque friction), cop_se_*,
    tau_se_* (standard errors, with --weighted), support (each row's stance: a frame of the
    model such as the other sole or a held link, or "double"; stances are pooled over the body
    parameters they share). FILE@FRAME reads FILE as measured in the stance FRAME.
    """
    files = [file_stance(d)[0] for d in data]
    outs = OutputSet([out], [*files, model_input(robot_name)], force=force)
    robot = load(robot_name, support)
    chosen, options = options_from_flags(method, opts)
    size = sum(rows_estimate(f) or 0 for f in files) or None
    with TerminalProgress("identifying poses") as bar:
        fit = run_identify(
            robot,
            list(data),
            method=chosen,
            options=options,
            progress=lambda d, n: bar(d, max(n or size or d + 1, d + 1)),
        )
    trunk = next((w for w in fit.warnings if w.startswith(COP_ON_TRUNK)), None)
    if trunk is not None:
        raise DataError(f"{', '.join(map(str, data))}: {trunk}")
    with outs:
        save_fit(fit, outs.path(out))
    echo_fit(fit)
    click.echo(f"wrote {out}")


def echo_fit(fit: Fit) -> None:
    """The fit's summary, then what its records hold: online history, sensors, extras."""
    if fit.online is not None:
        _echo_online(fit)
    click.echo(fit.summary())
    if fit.inertials is not None:
        echo_masses(fit)
    if fit.robust is not None:
        low = fit.robust.downweighted
        if not low:
            click.echo("robust: no pose down-weighted")
        shown = ", ".join(f"{i} (w {w:.2f})" for i, w in low[:10])
        more = f" and {len(low) - 10} more" if len(low) > 10 else ""
        if low:
            click.echo(
                f"robust: {len(low)} poses down-weighted (pose index, weight): {shown}{more}"
            )
    if fit.cop_offset is not None:
        (bx, by), (sx, sy) = fit.cop_offset.value, fit.cop_offset.std
        click.echo(
            f"bias: b_x = {mm(bx)} ± {mm(sx)}, b_y = {mm(by)} ± {mm(sy)} "
            "(separated from the support body's r by the prior only)"
        )
    _echo_sensors(fit)
    if fit.cv is not None:
        cv = fit.cv
        unit = "× the given errors" if fit.weighted else ("mm" if cv.kind == "cop" else "N·m")
        scale = 1.0 if fit.weighted or cv.kind != "cop" else 1e3
        click.echo(
            f"cv: {cv.k}-fold {'CoP' if cv.kind == 'cop' else 'torque'} RMSE "
            f"{cv.rmse * scale:.3f} {unit} (noise {cv.noise * scale:.3f}, model part "
            f"{cv.model_rmse * scale:.3f})"
        )
    if fit.joint_noise is not None:
        mc = fit.joint_noise
        click.echo(
            f"joint noise {math.degrees(mc.joint_noise_rad):g}°: RMS CoP prediction std "
            f"{mm(mc.cop_std_joint)} from joint angles vs {mm(mc.cop_std_noise)} from CoP noise "
            f"(joint share {mc.share_joint:.0%} of the variance)"
        )
    if fit.truth_cop_rmse is not None:
        click.echo(
            f"truth: RMS of predicted − noise-free CoP at these poses {mm(fit.truth_cop_rmse)} "
            "(columns cop_x_true, cop_y_true)"
        )


def _echo_sensors(fit: Fit) -> None:
    """Torque sensor offsets and friction bands, one line per joint."""
    rows: dict[str, dict[str, str]] = {}
    for e in fit.nuisance:
        if e.kind != "tau":
            continue
        text = f"{e.value:+.4f} ± {e.std:.4f}" if e.determined else "not determined"
        rows.setdefault(e.name, {})[e.what] = text
    if not rows:
        return
    has_f = any("friction" in r for r in rows.values())
    has_g = any("gain" in r for r in rows.values())
    click.echo(
        "torque sensors [N·m]: joint  offset"
        + ("  friction" if has_f else "")
        + ("  gain [1]" if has_g else "")
    )
    for joint, r in rows.items():
        click.echo(
            f"  {joint}  {r.get('offset', '—')}"
            + (f"  {r.get('friction', '—')}" if has_f else "")
            + (f"  {r.get('gain', '—')}" if has_g else "")
        )
    lost = [e for e in fit.nuisance if e.kind == "tau" and not e.determined]
    for e in lost[:4]:
        click.echo(f"  {e.label}: {e.reason}")


def _echo_online(fit: Fit) -> None:
    info = fit.online
    assert info is not None
    click.echo("online: poses  predicted RMS CoP std")
    shown = set()
    for n, std in zip(info.n_poses, info.cop_std, strict=True):
        decade = 10 ** int(math.log10(max(n, 1)))
        first = info.converged_at == n
        if first or n == info.n_poses[-1] or (n // decade in (1, 2, 5) and n % decade == 0):
            if n in shown:
                continue
            shown.add(n)
            text = mm(std) if math.isfinite(std) else "not determined yet"
            click.echo(f"online: {n:6d}  {text}" + ("  converged" if first else ""))
    at = info.converged_at
    click.echo(
        f"online: converged at {at} poses (RMS CoP std fell < {info.tol:.0%} over {info.window})"
        if at
        else "online: not converged yet (more poses would still improve the prediction)"
    )
