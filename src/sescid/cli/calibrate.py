"""``sescid calibrate``: foot-pad gains and offsets estimated with the mass model."""

from __future__ import annotations

import json
import math
from pathlib import Path

import click

from sescid.base import OutputSet, check_distinct
from sescid.cli import common
from sescid.cli.flags import flags, record
from sescid.errors import OptionError
from sescid.estimation import check_total_mass, save_fit
from sescid.report import mm
from sescid.sensors import (
    CalibrationOptions,
    PadSessionOptions,
    calibrate_sensors,
    calibrated_sensor_document,
    default_sensors_path,
    load_sensors,
    pad_session,
)
from sescid.tables import read_table


def pad_session_options(raw: tuple[str, ...], opts: dict) -> dict[str, PadSessionOptions]:
    """Each session's options (its name is its file's stem) from the SESSION=VALUE flags."""
    names = [Path(p).stem for p in raw]
    if len(set(names)) != len(names):
        raise OptionError("RAW", f"session files must have different names, got {names}")
    sets = _pairs(opts["sensor_sets"], "--sensor-set")
    nf = _positive(_pairs(opts["noise_force"], "--noise-force"), "--noise-force", "N")
    nc = _positive(_pairs(opts["noise_cop"], "--noise-cop"), "--noise-cop", "m")
    for what, d in (("--sensor-set", sets), ("--noise-force", nf), ("--noise-cop", nc)):
        unknown = [k for k in d if k not in names]
        if unknown:
            raise OptionError(what, f"no session '{unknown[0]}' (sessions: {', '.join(names)})")
    return {
        name: PadSessionOptions(
            sets.get(name, "default"), opts["min_samples"], nf.get(name), nc.get(name)
        )
        for name in names
    }


def _pairs(values: tuple[str, ...], what: str) -> dict[str, str]:
    out = {}
    for v in values:
        name, sep, val = v.partition("=")
        if not sep or not name or not val:
            raise OptionError(what, f"expected SESSION=VALUE, got {v!r}")
        out[name] = val
    return out


def _positive(values: dict[str, str], what: str, unit: str) -> dict[str, float]:
    """SESSION=VALUE pairs as positive finite numbers (one-line error naming the option)."""
    out = {}
    for name, v in values.items():
        try:
            x = float(v)
        except ValueError:
            raise OptionError(what, f"{name}={v}: expected a number [{unit}]") from None
        if not (math.isfinite(x) and x > 0):
            raise OptionError(what, f"{name}={v}: must be a finite number > 0 [{unit}]")
        out[name] = x
    return out


@click.command()
@click.argument("raw", nargs=-1, required=True, type=common.FILE)
@common.robot_options
@common.sensors_option
@flags(CalibrationOptions, "total_mass")
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
@flags(CalibrationOptions, "prior_scale", "gain_prior", "offset_prior")
@common.min_samples_option
@click.option(
    "--offsets-from",
    default=None,
    help="Session whose offsets go into the sensor file (default: the last one given).",
)
@common.file_option(
    "--out", "Calibrated sensor file (sescid-fsr/2), for `sescid measure --sensors`.", required=True
)
@common.file_option(
    "--fit", "Also write the jointly estimated mass model (a MAP fit) for export/report.", "fit_out"
)
@common.force_option
def calibrate(**opts):
    """Estimate every foot pad's gain and offset together with the mass model from RAW logs.

    Each RAW log (the table `sescid measure` reads, with the pad forces of both feet) is one
    session with its own offsets and noise levels; sessions on each foot in turn (or in double
    support) determine the gains, the weighed mass their scale. Prints each gain and offset
    with its standard error, each session's share, and the directions the sessions leave
    undetermined; writes the layout with the gains and one session's offsets.
    """
    raw, out, fit_out = opts["raw"], opts["out"], opts["fit_out"]
    outs = OutputSet([out, fit_out], [*raw, opts["sensors_file"]], force=opts["force"])
    check_distinct(list(raw), "a session")
    robot = common.load(opts["robot_name"], opts["support"])
    options = record(CalibrationOptions, opts)
    options.check()
    if options.total_mass is not None:
        check_total_mass(robot, options.total_mass, "--total-mass")
    config = load_sensors(opts["sensors_file"], robot.profile)
    source = opts["sensors_file"] or default_sensors_path(robot.profile)
    per_session = pad_session_options(raw, opts)
    sessions = [
        pad_session(robot, read_table(path), config, name, o)
        for path, (name, o) in zip(raw, per_session.items(), strict=True)
    ]
    cal = calibrate_sensors(robot, sessions, options)
    click.echo(cal.summary())
    click.echo(f"mass model: CoP residual RMS {mm(cal.fit.rms)}, rank {cal.fit.rank}")
    session = opts["offsets_from"] or list(per_session)[-1]
    sensor_set = per_session[session].sensors if session in per_session else "default"
    doc = calibrated_sensor_document(source, cal, session, sensor_set)
    with outs:
        with open(outs.path(out), "w") as fh:
            json.dump(doc, fh, indent=1)
            fh.write("\n")
        if fit_out:
            save_fit(cal.fit, outs.path(fit_out))
    click.echo(f"wrote {out} (gains, offsets of session {session})")
    if fit_out:
        click.echo(f"wrote {fit_out}")
