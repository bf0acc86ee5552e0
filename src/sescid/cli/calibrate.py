"""``sescid calibrate``: foot-pad gains and offsets estimated with the mass model."""

from __future__ import annotations

import json
from pathlib import Path

import click

from sescid.base.files import atomic_open, check_outputs
from sescid.cli.common import load, min_samples_option, mm, robot_options, sensors_option
from sescid.errors import OptionError
from sescid.io import read_table
from sescid.sensors import load_sensors
from sescid.sensors.calibration import (
    GAIN_PRIOR,
    OFFSET_PRIOR,
    calibrate_sensors,
    calibrated_sensor_document,
    pad_session,
)
from sescid.sensors.pads import default_sensors_path


def _pairs(values: tuple[str, ...], what: str) -> dict[str, str]:
    out = {}
    for v in values:
        name, sep, val = v.partition("=")
        if not sep or not name or not val:
            raise OptionError(what, f"expected SESSION=VALUE, got {v!r}")
        out[name] = val
    return out


@click.command()
@click.argument("raw", nargs=-1, required=True, type=click.Path(dir_okay=False))
@robot_options
@sensors_option
@click.option(
    "--total-mass",
    type=float,
    default=None,
    help="Weighed mass of the robot [kg]: fixes the gains' scale (default: the model's, "
    "reported as unidentifiable).",
)
@click.option(
    "--sensor-set",
    "sensor_sets",
    multiple=True,
    help="SESSION=LABEL: sessions with the same label share gains (default: one set). A "
    "session is named by its file's stem.",
)
@click.option(
    "--noise-force",
    "noise_force",
    multiple=True,
    help="SESSION=N: given noise of the session's total-force rows [N] (default: estimated).",
)
@click.option(
    "--noise-cop",
    "noise_cop",
    multiple=True,
    help="SESSION=M: given noise of the session's moment rows, as CoP [m] (default: estimated).",
)
@click.option(
    "--prior-scale", type=float, default=None, help="SESC prior τ [m] (default: evidence)."
)
@click.option("--gain-prior", type=float, default=GAIN_PRIOR, show_default=True,
              help="Prior std of each gain (relative).")  # fmt: skip
@click.option("--offset-prior", type=float, default=OFFSET_PRIOR, show_default=True,
              help="Prior std of each offset [N]; the offset twist comes from it.")  # fmt: skip
@min_samples_option
@click.option(
    "--offsets-from",
    default=None,
    help="Session whose offsets go into the sensor file (default: the last one given).",
)
@click.option(
    "--out",
    required=True,
    type=click.Path(dir_okay=False),
    help="Calibrated sensor file (sescid-fsr/2), for `sescid fsr --sensors`.",
)
@click.option(
    "--fit",
    "fit_out",
    default=None,
    type=click.Path(dir_okay=False),
    help="Also write the jointly estimated mass model (a MAP fit) for export/report.",
)
def calibrate(
    raw,
    robot_name,
    support,
    sensors_file,
    total_mass,
    sensor_sets,
    noise_force,
    noise_cop,
    prior_scale,
    gain_prior,
    offset_prior,
    min_samples,
    offsets_from,
    out,
    fit_out,
):
    """Estimate every foot pad's gain and offset together with the mass model from RAW logs.

    Each RAW log (the table `sescid fsr` reads, with the pad forces of both feet) is one
    session with its own offsets and noise levels; sessions on each foot in turn (or in double
    support) determine the gains, the weighed mass their scale. Prints each gain and offset
    with its standard error, each session's share, and the directions the sessions leave
    undetermined; writes the layout with the gains and one session's offsets.
    """
    robot = load(robot_name, support)
    check_outputs([out, fit_out], list(raw) + [sensors_file])
    config = load_sensors(sensors_file, robot.profile)
    source = sensors_file or default_sensors_path(robot.profile)
    names = [Path(p).stem for p in raw]
    if len(set(names)) != len(names):
        raise OptionError("raw", f"session files must have different names, got {names}")
    sets = _pairs(sensor_sets, "sensor_set")
    nf = {k: float(v) for k, v in _pairs(noise_force, "noise_force").items()}
    nc = {k: float(v) for k, v in _pairs(noise_cop, "noise_cop").items()}
    for what, d in (("sensor_set", sets), ("noise_force", nf), ("noise_cop", nc)):
        unknown = [k for k in d if k not in names]
        if unknown:
            raise OptionError(what, f"no session '{unknown[0]}' (sessions: {', '.join(names)})")
    sessions = [
        pad_session(
            robot,
            read_table(path),
            config,
            name,
            sensors=sets.get(name, "default"),
            min_samples=min_samples,
            noise_force=nf.get(name),
            noise_cop=nc.get(name),
        )
        for path, name in zip(raw, names, strict=True)
    ]
    cal = calibrate_sensors(
        robot,
        sessions,
        total_mass=total_mass,
        prior_scale=prior_scale,
        gain_prior=gain_prior,
        offset_prior=offset_prior,
    )
    click.echo(cal.summary())
    click.echo(f"mass model: CoP residual RMS {mm(cal.fit.rms)}, rank {cal.fit.rank}")
    session = offsets_from or names[-1]
    doc = calibrated_sensor_document(source, cal, session, sets.get(session, "default"))
    with atomic_open(out, "w") as fh:
        json.dump(doc, fh, indent=1)
        fh.write("\n")
    click.echo(f"wrote {out} (gains, offsets of session {session})")
    if fit_out:
        cal.fit.save(fit_out)
        click.echo(f"wrote {fit_out}")
