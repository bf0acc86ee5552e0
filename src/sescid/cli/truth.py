"""Command on the virtual experiment's truth: truth."""

from __future__ import annotations

import math

import click

from sescid.bench import FRESH_POSES, FRESH_WITHIN_DEG
from sescid.cli import common
from sescid.report import mm


@click.command()
@click.argument("fit_file", type=common.FILE)
@click.argument("truth_file", type=common.FILE)
@click.option(
    "--fresh", default=FRESH_POSES, show_default=True, type=click.IntRange(1, 10_000_000),
    help="Fresh poses near the actual ones.",
)  # fmt: skip
@click.option(
    "--within-deg", default=FRESH_WITHIN_DEG, show_default=True,
    type=click.FloatRange(0, 180, min_open=True),
    help="Fresh poses uniform within ±this of the actual ones [degrees].",
)  # fmt: skip
@common.seed_option
def truth(fit_file, truth_file, fresh, within_deg, seed):
    """Compare a fit with the truth of `sescid experiment --truth`: RMS CoP error of the
    identified and the manufacturer model at the actual poses and at fresh poses near them."""
    from sescid.bench import compare_truth
    from sescid.estimation import load_fit

    fit = load_fit(fit_file)
    common.echo_model_change(fit, fit_file)
    c = compare_truth(fit, truth_file, fresh, within_deg, seed, fit_path=fit_file)
    unit = mm if c.quantity == "CoP" else (lambda x: f"{math.degrees(x):.3f}°")
    click.echo(
        f"truth: real robot {c.true_mass_kg:.3f} kg, model {c.model_mass_kg:.3f} kg; "
        f"RMS {c.quantity} error vs the true robot"
    )
    click.echo(
        f"  at the {c.n_poses} actual poses: identified {unit(c.rms_identified)}, "
        f"manufacturer {unit(c.rms_manufacturer)}"
    )
    click.echo(
        f"  at {c.n_fresh} fresh poses within ±{c.within_deg:g}°: identified "
        f"{unit(c.fresh_identified)}, manufacturer {unit(c.fresh_manufacturer)}"
    )
    if c.com_distance is not None:
        true, fitted = c.com_distance
        click.echo(
            f"  CoM distance from the line at the zero pose: true {mm(true)}, identified "
            f"{mm(fitted)} ({(fitted / true - 1) * 100:+.1f} %)"
        )
