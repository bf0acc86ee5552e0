"""Option groups that several commands share (the consistent-mass step of identify and export)
and what both print of it."""

from __future__ import annotations

import click

from sescid.cli.flags import flags
from sescid.estimation import ConsistentOptions, Fit


def consistent_options(f):
    """Options of the consistent step (identify --method consistent, export); the weighed total
    mass is each command's own (identify's scales the torques as well)."""
    return flags(ConsistentOptions, "mass_floor", "symmetric", "box_margin", "via", "prior_std")(f)


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
    if b.exact:
        click.echo("  the fit's SESC vectors reproduced exactly (closest to CAD in its prior)")
    for note in b.notes:
        click.echo(f"  note: {note}")
    for c in b.active_constraints[:8]:
        click.echo(f"  active: {c}")
    if len(b.active_constraints) > 8:
        click.echo(f"  … and {len(b.active_constraints) - 8} more (see the fit file)")
