"""``sescid identify``: SESC vectors, sensor offsets (or masses) from poses and measurements.

Parse the flags into the method's options and ``IdentifyOptions`` (whose defaults the flags
show), make one call to ``sescid.identify`` on the files, print the fit.
"""

from __future__ import annotations

import math
from typing import Any

import click

from sescid.api import file_stance, identify_payload
from sescid.api import identify as run_identify
from sescid.base import OutputSet, TerminalProgress, option_spec
from sescid.cli import common
from sescid.cli.flags import SectionedCommand, flags, help_of, record
from sescid.cli.options import consistent_options, echo_masses
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
    check_base,
    fit_summary,
    load_fit,
    save_fit,
)
from sescid.io import rows_estimate
from sescid.report import mm


def options_from_flags(method: MethodName, opts: dict) -> tuple[MethodOptions, IdentifyOptions]:
    """The method's options and ``identify``'s shared options from the command's flags (a
    method's flags with another method are an error naming them)."""
    common.refuse_idle("gain_prior", opts["tau_gains"], "without --tau-gains")
    common.refuse_idle("mc_draws", opts["joint_noise_deg"] is not None, "without --joint-noise-deg")
    common.refuse_idle("noise", method in ("map", "auto") or opts["online"],
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
    consistent = record(ConsistentOptions, opts, total_mass=None)  # the weighed mass: identify's
    if method != "consistent" and consistent != ConsistentOptions():
        raise OptionError("method", f"the consistent options need --method consistent ({method})")
    chosen: MethodOptions = LeastSquaresOptions()
    if method in ("map", "auto"):
        settings = record(MapOptions, opts)
        chosen = settings if method == "map" else AutoOptions(settings)
    elif method == "consistent":
        chosen = consistent
    deg = opts["joint_noise_deg"]
    shared = record(
        IdentifyOptions,
        opts,
        kinds=None if opts["kinds"] == "all" else (opts["kinds"],),
        robust="auto" if opts["robust"] is None else bool(opts["robust"]),
        joint_noise=None if deg is None else math.radians(deg),
        online_step=_online_step(opts),
    )
    return chosen, shared


def _online_step(opts: dict) -> int | None:
    """--online-step applies with --online only (an error without it, never ignored)."""
    if opts["online"]:
        return opts["online_step"]
    if opts["online_step"] != 1:
        raise OptionError("online", "--online-step needs --online")
    return None


#: identify's options in ``--help``, by what they are about
SECTIONS = {
    "Data": ("robot_name", "support", "line", "kinds", "weighted", "cop_noise", "com_height",
             "imu_link", "allow_outside_limits"),
    "Method": ("method", "rtol", "allow_exact", "robust", "cv", "joint_noise_deg", "mc_draws",
               "online", "online_step", "seed"),
    "MAP (--method map or auto)": ("prior_scale", "prior", "prior_select", "noise", "bias"),
    "Consistent masses (--method consistent)": ("total_mass", "mass_floor", "symmetric",
                                                "box_margin", "via", "cad_std"),
    "Joint torques": ("tau_noise", "tau_noise_model", "tau_gains", "gain_prior", "gravity_accel"),
    "Payload (what the robot carries)": ("payload", "payload_mass", "base"),
    "Output": ("out", "force"),
}  # fmt: skip
_, _NOISE = option_spec(IdentifyOptions, "joint_noise")
_, _STEP = option_spec(IdentifyOptions, "online_step")


@click.command(cls=SectionedCommand, sections=SECTIONS)
@click.argument("data", nargs=-1, required=True, type=common.FILE)
@common.robot_options
@common.file_option("--out", "Fit JSON.", required=True)
@common.choice_option(
    "--method",
    METHOD_CHOICES,
    "auto",
    "auto: MAP with the CAD prior when the data leave directions weakly determined, "
    "least squares when they determine every direction well (the fit says which and why); "
    "ls: least squares (the paper's; undetermined directions from the model file); map: "
    "Gaussian CAD prior; consistent: body masses and CoMs (see --total-mass …).",
)
@common.choice_option(
    "--kinds",
    ["all", *choices(Kind)],
    "all",
    "Which measurements of the files to fit: all they have, the CoP only, or the joint "
    "torques only.",
)
@flags(IdentifyOptions, "com_height", "weighted", "rtol", "cop_noise", "tau_noise",
       "tau_noise_model", "tau_gains",
       "gain_prior", "gravity_accel", "allow_exact", "total_mass")  # fmt: skip
@consistent_options
@flags(MapOptions, "prior_scale", "prior", "select", "noise", "bias")
@click.option("--robust/--no-robust", default=None, help=help_of(IdentifyOptions, "robust"))
@flags(IdentifyOptions, "cv")
@click.option(
    "--joint-noise-deg",
    type=click.FloatRange(min=0, min_open=True, max=round(math.degrees(_NOISE.high or 0))),
    default=None,
    help=_NOISE.help.replace("[rad]", "[degrees]"),
)
@flags(IdentifyOptions, "mc_draws")
@click.option("--online", is_flag=True, help="Recursive estimator; prints the convergence.")
@click.option(
    "--online-step", default=1, show_default=True, type=click.IntRange(min=1), help=_STEP.help
)
@flags(IdentifyOptions, "seed", "allow_outside_limits", "imu_link")
@click.option(
    "--payload",
    default=None,
    metavar="BODY",
    help="Identify only a payload fixed to this link: its mass and CoM in the link's frame, "
    "the robot's own masses kept as the base (--base).",
)
@click.option(
    "--payload-mass",
    type=float,
    default=None,
    help="The payload's weighed mass [kg] (with --payload): only its CoM is identified.",
)
@common.file_option(
    "--base",
    "With --payload: the robot's own masses — a previous fit (JSON, any stance) or the model "
    "file (default: the robot's model).",
)
@common.force_option
def identify(data, robot_name, support, out, method, force, **opts):
    """Identify the robot's mass distribution from CSV/Parquet files of poses (a column per
    joint, radians) and what was measured there: the CoP (cop_x, cop_y, m), joint torques
    (tau_<joint>, N·m) or, for a robot balancing on a line (--line), the gravity direction of
    each balanced pose (grav_x, grav_y, grav_z). Several files, of one stance or several, pool
    into one fit of the SESC vectors (with --method consistent: body masses and CoMs).

    Optional columns: grav_x, grav_y, grav_z (gravity direction in the support frame; a tilted
    sole), approach (±1: each pose reached moving up or down, for torque friction), cop_se_*,
    tau_se_* (standard errors, with --weighted), support (each row's stance: a frame of the
    model such as the other sole or a held link, or "double"; stances are pooled over the body
    parameters they share). FILE@FRAME reads FILE as measured in the stance FRAME.
    """
    files = [file_stance(d)[0] for d in data]
    payload, mass, base = opts.pop("payload"), opts.pop("payload_mass"), opts.pop("base")
    if payload is None:
        if mass is not None or base is not None:
            raise OptionError("payload", "--payload-mass and --base go with --payload BODY")
        outs = OutputSet([out], [*files, common.model_input(robot_name)], force=force)
        robot = common.load(robot_name, support)
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
    else:  # the payload on a base (a fit, or the model file)
        if method != "auto":
            raise OptionError("method", "--method does not apply with --payload (the base is kept)")
        robot, model, base_fit = _payload_base(robot_name, support, base)
        ins = [*files, common.model_input(model)] + ([base] if base else [])
        outs = OutputSet([out], ins, force=force)
        shared = options_from_flags("ls", opts)[1]
        fit = identify_payload(robot, list(data), payload, mass=mass, base=base_fit, options=shared)
    with outs:
        save_fit(fit, outs.path(out))
    echo_fit(fit)
    click.echo(f"wrote {out}")


def _payload_base(
    robot_name: str, support: str | None, base: str | None
) -> tuple[Any, str, Fit | None]:
    """The robot a payload is identified on, the model it names and the base fit (None: the
    model's own masses): ``--base`` a fit (JSON) or a model file, else ``--robot``."""
    from pathlib import Path

    base_fit = None
    given = common.given("robot_name")
    if base is not None and Path(base).suffix.lower() == ".json":
        base_fit = load_fit(base)
        common.echo_model_change(base_fit, base)
        robot_name = robot_name if given else base_fit.robot.source
        if given and robot_name != base_fit.robot.source:  # another robot: say so first
            robot = common.load(robot_name, support)
        else:
            robot = common.load(robot_name, support or base_fit.robot.support)
        check_base(robot, base_fit, base)
    elif base is not None:
        if given and Path(robot_name) != Path(base):
            raise OptionError("base", f"the base model {base} is not --robot {robot_name}")
        robot_name = base
        robot = common.load(base, support)
    else:
        robot = common.load(robot_name, support)
    return robot, robot_name, base_fit


def echo_fit(fit: Fit) -> None:
    """The fit's summary, then what its records hold: online history, sensors, extras."""
    if fit.online is not None:
        _echo_online(fit)
    click.echo(fit_summary(fit))
    if fit.payload is not None:
        click.echo(fit.payload.summary())
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
    noise = {r.joint: r for r in fit.torque_noise}
    unit = " [× tau_se]" if noise and fit.torque_noise[0].unit == "1" else ""
    click.echo(
        "torque sensors [N·m]: joint  offset"
        + ("  friction" if has_f else "")
        + ("  gain [1]" if has_g else "")
        + (f"  noise σ_j{unit}" if noise else "")
    )
    for joint, r in rows.items():
        n = noise.get(joint)
        click.echo(
            f"  {joint}  {r.get('offset', '—')}"
            + (f"  {r.get('friction', '—')}" if has_f else "")
            + (f"  {r.get('gain', '—')}" if has_g else "")
            + (f"  {n.sigma:.4f}" + (" (pooled)" if n.by == "pooled" else "") if n else "")
        )
    lost = [e for e in fit.nuisance if e.kind == "tau" and (not e.determined or e.reason)]
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
