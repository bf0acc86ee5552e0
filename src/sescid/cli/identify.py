"""``sescid identify``: the SESC vectors (or masses) from poses and measurements."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import click
import numpy as np

from sescid.base.files import OutputSet
from sescid.base.progress import TerminalProgress
from sescid.cli.common import force_option, imu_link_option, load, mm, robot_options, seed_option
from sescid.cli.options import (
    DEFAULT_CONSISTENT,
    consistent_from_flags,
    consistent_options,
    echo_masses,
)
from sescid.errors import DataError, OptionError
from sescid.estimation import (
    DEFAULT_RTOL,
    METHODS,
    Fit,
    MapOptions,
    OnlineEstimator,
    cross_validate,
    fit_warnings,
    identify_once,
    joint_noise_mc,
    make_fitter,
    outside_limits,
)
from sescid.estimation import (
    identify as run_identify,
)
from sescid.io import (
    read_cop,
    read_cop_se,
    read_poses,
)
from sescid.io.tables import iter_table, read_ahead


def _map_from_flags(opts: dict) -> MapOptions:
    return MapOptions(
        prior_scale=opts["prior_scale"],
        noise=opts["noise"],
        select=opts["prior_select"],
        bias=opts["bias"],
    )


def _run_online(robot, q, cop, sigma, opts, method, rtol) -> Fit:
    if method not in ("ls", "map"):
        raise OptionError("method", f"--online supports ls or map, not {method}")
    if opts["robust"] or opts["bias"]:
        raise OptionError("online", "--online cannot be combined with --robust or --bias")
    prior = None
    if method == "map":
        if opts["prior_scale"] is None or opts["noise"] is None:
            raise OptionError("online", "--online --method map needs --prior-scale and --noise (m)")
        prior = opts["prior_scale"]
    step = opts["online_step"]
    est = OnlineEstimator(robot, prior_scale=prior, noise=opts["noise"], rtol=rtol)
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
            std = mm(st.cop_std) if math.isfinite(st.cop_std) else "not determined yet"
            click.echo(f"online: {n:6d}  {st.rank:4d}  {std}{flag}")
    at = est.converged_at
    click.echo(
        f"online: converged at {at} poses (RMS CoP std fell < {est.tol:.0%} over {est.window})"
        if at
        else "online: not converged yet (more poses would still improve the prediction)"
    )
    return est.fit()


@click.command()
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
    default=DEFAULT_RTOL,
    show_default=True,
    help="Rank tolerance on singular values, relative to the largest (0 < rtol < 1).",
)
@click.option(
    "--method",
    type=click.Choice(list(METHODS)),
    default="ls",
    show_default=True,
    help="ls: least squares (undetermined directions from the model file); map: Gaussian CAD "
    "prior; consistent: body masses and CoMs (see --total-mass …).",
)
@consistent_options
@click.option(
    "--prior-scale",
    type=float,
    default=MapOptions.prior_scale,
    help="map: prior standard deviation of each SESC component [m] (default: evidence).",
)
@click.option(
    "--prior-select",
    type=click.Choice(["evidence", "cv"]),
    default=MapOptions.select,
    show_default=True,
    help="map: choose the prior scale by marginal likelihood or 5-fold cross-validation.",
)
@click.option(
    "--noise",
    type=float,
    default=MapOptions.noise,
    help="map/online: known CoP noise standard deviation [m] (default: estimated).",
)
@click.option("--bias", is_flag=True, help="map: estimate constant CoP offsets b_x, b_y [m].")
@click.option("--robust", is_flag=True, help="Huber IRLS; names the down-weighted poses.")
@click.option(
    "--cv",
    type=click.IntRange(min=2),
    default=None,
    help="Print the k-fold cross-validated CoP error.",
)
@click.option(
    "--joint-noise-deg",
    type=click.FloatRange(min=0, min_open=True, max=90),
    default=None,
    help="Monte-Carlo effect of joint-angle errors of this standard deviation [degrees].",
)
@click.option(
    "--mc-draws", default=30, show_default=True, type=click.IntRange(min=2), help="MC draws."
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
def identify(data, robot_name, support, out, weighted, rtol, method, force, **opts):
    """Identify the SESC vectors from a CSV/Parquet of poses (radians) and cop_x, cop_y (m).

    Optional columns grav_x, grav_y, grav_z (gravity direction in the support frame) give the
    tilted-sole statics: the CoP is where the gravity line through the CoM meets the sole.
    """
    outs = OutputSet([out], [data, robot_name], force=force)
    robot = load(robot_name, support)
    streamed = method == "ls" and not (opts["robust"] or opts["online"])
    streamed = streamed and opts["cv"] is None and opts["joint_noise_deg"] is None
    if streamed:  # read below, once, as it is fitted
        chunks, truth = [], [None]
        q = cop = sigma = gravity = None
    else:
        chunks, truth = _read_chunks(data, robot, weighted, opts["imu_link"])
        q, cop, sigma, gravity = _join(chunks)
    simulated = truth[0] is not None
    n_poses = sum(len(c[0]) for c in chunks)
    if method != "map":
        given = [
            name
            for name, on in (
                ("--bias", opts["bias"]),
                ("--prior-scale", opts["prior_scale"] is not None),
                ("--prior-select cv", opts["prior_select"] == "cv"),
            )
            if on
        ]
        if given:
            why = (
                ": a constant CoP offset is confounded with the support body's x/y SESC "
                "components, only a prior on them separates the two"
                if opts["bias"]
                else ""
            )
            raise OptionError(
                "method", f"{', '.join(given)} needs --method map (got {method}){why}"
            )
    mopts = _map_from_flags(opts) if method == "map" else None
    copts = consistent_from_flags(opts) if method == "consistent" else None
    if (
        method != "consistent"
        and copts is None
        and consistent_from_flags(opts) != DEFAULT_CONSISTENT
    ):
        raise OptionError("method", f"the consistent options need --method consistent ({method})")
    fitter = make_fitter(
        robot, method, rtol=rtol, map_options=mopts, consistent_options=copts, seed=opts["seed"]
    )
    if gravity is not None and (opts["online"] or opts["cv"] is not None):
        raise OptionError(
            "gravity", "--online and --cv do not use the grav_x/y/z columns: drop them or the flag"
        )
    if gravity is not None and opts["joint_noise_deg"] is not None:
        raise OptionError("gravity", "--joint-noise-deg does not use the grav_x/y/z columns")
    if streamed:  # the file read once, chunk by chunk, never joined (flat memory)
        fit, n_poses, limits, simulated = _identify_streamed(
            data, robot, weighted, rtol, opts["allow_outside_limits"], opts["imu_link"]
        )
    else:
        limits = outside_limits(robot, [c[0] for c in chunks])
    if limits is not None and not (opts["allow_outside_limits"] or simulated):
        raise DataError(
            f"{data}: {limits.message(n_poses)}; degrees in a radian column, or another robot? "
            "(--allow-outside-limits accepts them)"
        )
    if streamed:
        pass  # fitted above
    elif opts["online"]:
        fit = _run_online(robot, q, cop, sigma, opts, method, rtol)
    else:
        with TerminalProgress(f"identifying {len(q)} poses"):
            fit = run_identify(
                robot,
                q,
                cop,
                method=method,
                sigma=sigma,
                rtol=rtol,
                map_options=mopts,
                consistent_options=copts,
                robust=opts["robust"],
                seed=opts["seed"],
                gravity=gravity,
            )
    if opts["robust"]:
        from sescid.estimation import huber

        plain = fitter

        def fitter(qq, cc, ss):
            return huber(plain, qq, cc, ss)

    if limits is not None:
        fit.warnings.append(limits.message(n_poses))
    if opts["online"] or streamed:
        fit.warnings += fit_warnings(fit)
    if not streamed:
        _extras(fit, fitter, q, cop, sigma, opts)
    if simulated:  # simulated data: the noise-free CoP
        if not streamed:
            sq = [
                np.sum((fit.predict_cop(c[0], c[3]) - t) ** 2)
                for c, t in zip(chunks, truth, strict=True)
            ]
            fit.truth_cop_rmse = float(np.sqrt(np.sum(sq) / (2 * n_poses)))
        click.echo(
            f"truth: RMS of predicted − noise-free CoP at these poses "
            f"{mm(fit.truth_cop_rmse)} (columns cop_x_true, cop_y_true)"
        )
    with outs:
        fit.save(outs.path(out))
    click.echo(fit.summary())
    if fit.inertials is not None:
        echo_masses(fit)
    click.echo(f"wrote {out}")


def _read_chunks(data, robot, weighted: bool, imu_link=None) -> tuple[list[tuple], list]:
    """(q, cop, sigma, gravity) per chunk of the data file, all in memory, and the noise-free
    CoP per chunk when the file has it (else [None]); see ``_iter_chunks``."""
    chunks, truth = [], []
    for q, cop, sigma, gravity, t in _iter_chunks(data, robot, weighted, imu_link):
        chunks.append((q, cop, sigma, gravity))
        truth.append(t)
    return chunks, truth if truth and truth[0] is not None else [None]


def _identify_streamed(
    data, robot, weighted: bool, rtol: float, allow: bool, imu_link=None
) -> tuple:
    """Least squares over the file read once (``identify_once``): (fit, poses, limits,
    simulated). Poses outside the joint limits stop the fit at once unless allowed (or
    simulated); the rest of the file is then only read to count them for the message."""
    state: dict = {"n": 0, "simulated": None, "bad": []}

    def limits():
        if not state["bad"]:
            return None
        start, first = state["bad"][0]
        n_bad = sum(lim.n_poses for _, lim in state["bad"])
        return dataclasses.replace(first, row=first.row + start, n_poses=n_bad)

    def chunks():
        stop = False
        for q, cop, sigma, gravity, truth in _iter_chunks(data, robot, weighted, imu_link):
            if state["simulated"] is None:
                state["simulated"] = truth is not None
            lim = outside_limits(robot, q)
            if lim is not None:
                state["bad"].append((state["n"], lim))
                stop = stop or not (allow or state["simulated"])
            state["n"] += len(q)
            if not stop:
                yield q, cop, sigma, gravity, truth
        if stop:
            raise DataError(
                f"{data}: {limits().message(state['n'])}; degrees in a radian column, or "
                "another robot? (--allow-outside-limits accepts them)"
            )

    size = _rows_estimate(data)
    with TerminalProgress("identifying poses") as bar:
        report = None if size is None else (lambda d: bar(d, max(size, d + 1)))
        fit = identify_once(robot, chunks(), rtol=rtol, progress=report)
        bar(state["n"], state["n"])
    return fit, state["n"], limits(), bool(state["simulated"])


def _rows_estimate(data) -> int | None:
    """Rough row count of a data file for the progress line (file bytes / bytes of a row)."""
    try:
        path = Path(data)
        with path.open("rb") as fh:
            head = fh.read(1 << 16)
        lines = head.count(b"\n")
        return int(path.stat().st_size / (len(head) / lines)) if lines > 1 else None
    except OSError:
        return None


def _iter_chunks(data, robot, weighted: bool, imu_link=None):
    """(q, cop, sigma, gravity, truth) per streamed chunk of the data file (gravity: grav_x/y/z,
    else the IMU columns on ``imu_link`` (``experiment.imu.table_gravity``); truth: the
    noise-free CoP of simulated data, else None)."""
    from sescid.sensors.imu import table_gravity

    for table in read_ahead(iter_table(data)):
        q = read_poses(table, robot.joint_names, robot.profile.servo)
        cop, sigma = read_cop(table), None
        gravity = table_gravity(robot, table, q, imu_link)
        if weighted:
            sigma = read_cop_se(table)
            if sigma is None:
                raise DataError(f"{data}: --weighted needs columns cop_se_x, cop_se_y")
        has_truth = "cop_x_true" in table and "cop_y_true" in table
        truth = (
            np.column_stack([table.get("cop_x_true"), table.get("cop_y_true")])
            if has_truth
            else None
        )
        yield q, cop, sigma, gravity, truth


def _join(chunks: list[tuple]) -> tuple:
    """One (q, cop, sigma, gravity) from the chunks."""
    first = chunks[0]
    return tuple(
        None if first[i] is None else np.concatenate([c[i] for c in chunks]) for i in range(4)
    )


def _extras(fit: Fit, fitter, q, cop, sigma, opts) -> None:
    """--robust / --bias / --cv / --joint-noise-deg: print and store in the fit."""
    if fit.robust is not None:
        low = fit.robust.downweighted
        shown = ", ".join(f"{i} (w {w:.2f})" for i, w in low[:10])
        more = f" and {len(low) - 10} more" if len(low) > 10 else ""
        click.echo(f"robust: {len(low)} poses down-weighted (row index, weight): {shown}{more}")
    if fit.cop_offset is not None:
        (bx, by), (sx, sy) = fit.cop_offset.value, fit.cop_offset.std
        click.echo(
            f"bias: b_x = {mm(bx)} ± {mm(sx)}, b_y = {mm(by)} ± {mm(sy)} "
            "(separated from the support body's r by the prior only)"
        )
    if opts["cv"] is not None:
        fit.cv = cv = cross_validate(
            fitter, q, cop, opts["cv"], sigma, opts["seed"], progress=TerminalProgress("cv fold")
        )
        if fit.weighted:
            click.echo(
                f"cv: {cv.k}-fold CoP RMSE {cv.rmse:.3f} × the given errors (noise scale "
                f"{cv.noise:.3f}, model part {cv.model_rmse:.3f})"
            )
        else:
            click.echo(
                f"cv: {cv.k}-fold CoP RMSE {mm(cv.rmse)} (noise {mm(cv.noise)}, model part "
                f"{mm(cv.model_rmse)})"
            )
    if opts["joint_noise_deg"] is not None:
        fit.joint_noise = mc = joint_noise_mc(
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
        click.echo(
            f"joint noise {opts['joint_noise_deg']:g}°: RMS CoP prediction std "
            f"{mm(mc.cop_std_joint)} from joint angles vs {mm(mc.cop_std_noise)} from CoP noise "
            f"(joint share {mc.share_joint:.0%} of the variance)"
        )
