"""Option groups that several commands share (the consistent-mass step of identify and export)."""

from __future__ import annotations

import click

from sescid.errors import choices
from sescid.estimation import ConsistentOptions, Fit, Via

DEFAULT_CONSISTENT = ConsistentOptions()


def consistent_options(f):
    """Options of the consistent step (identify --method consistent, export)."""
    for opt in reversed(
        [
            click.option(
                "--total-mass",
                type=float,
                default=DEFAULT_CONSISTENT.total_mass,
                help="consistent: weighed total mass [kg] (default: the model's).",
            ),
            click.option(
                "--mass-floor",
                type=float,
                default=DEFAULT_CONSISTENT.mass_floor,
                show_default=True,
                help="consistent: lower bound on every body's mass [kg].",
            ),
            click.option(
                "--symmetric", is_flag=True, help="consistent: mirrored bodies (*_R/*_L) equal."
            ),
            click.option(
                "--box-margin",
                type=float,
                default=DEFAULT_CONSISTENT.box_margin,
                help="consistent: grow the CoM boxes by this [m] (default 0, fallback boxes 0.02).",
            ),
            click.option(
                "--via",
                type=click.Choice(choices(Via)),
                default=DEFAULT_CONSISTENT.via,
                show_default=True,
                help="consistent: 'prior' weighs the data against a CAD prior on masses/CoMs "
                "whose scale the data choose (controller-ready; a weighed total mass goes "
                "where the data put it); 'fit' reproduces the fit first (least squares follows "
                "the noise); 'auto': 'fit' for a MAP fit, else 'prior'. --cad-std fixes the "
                "prior scale instead.",
            ),
            click.option(
                "--cad-std",
                type=float,
                default=DEFAULT_CONSISTENT.prior_std,
                help="consistent: trade data fit against a Gaussian prior on the relative "
                "deviation from CAD of this std (e.g. 0.05) instead of fitting the data first.",
            ),
        ]
    ):
        f = opt(f)
    return f


def consistent_from_flags(opts: dict) -> ConsistentOptions:
    """The typed options from the consistent flags."""
    return ConsistentOptions(
        total_mass=opts["total_mass"],
        mass_floor=opts["mass_floor"],
        symmetric=opts["symmetric"],
        box_margin=opts["box_margin"],
        prior_std=opts["cad_std"],
        via=opts["via"],
    )


def echo_masses(fit: Fit) -> None:
    """Print the consistent masses of a fit beside CAD, one line per body."""
    b = fit.inertials
    assert b is not None
    click.echo(
        f"consistent: total mass {b.total_mass:.4f} kg, "
        f"{len(b.active_constraints)} active constraints, solver clarabel "
        f"({b.solve_time * 1e3:.0f} ms)"
    )
    worst = b.worst_mass_change()
    if worst is not None and b.cad_masses is not None:
        i, rel = worst
        name = fit.robot.body_names[i]
        click.echo(
            f"  worst body-mass change from the model: {name} {100 * rel:.1f} % "
            f"({b.cad_masses[i]:.4f} → {b.masses[i]:.4f} kg)"
            + ("" if b.prior_std is None else f"; CAD prior std {100 * b.prior_std:.1f} %")
        )
    for c in b.active_constraints[:8]:
        click.echo(f"  active: {c}")
    if len(b.active_constraints) > 8:
        click.echo(f"  … and {len(b.active_constraints) - 8} more (see the fit file)")
