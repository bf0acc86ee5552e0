"""Commands on candidate model files and fits: audit, compare."""

from __future__ import annotations

import json
import math
import sys

import click

from sescid.audit import DEFAULT_FOLDS, DEFAULT_Z
from sescid.base import OutputSet
from sescid.cli import common

#: exit code of ``audit --fail-on`` when the best candidate is rejected or fails a check
FAIL_EXIT = 3


class _Several(click.Option):
    """An option that takes every value up to the next flag (``--models A.urdf B.xml``); the
    flag may also be repeated."""

    def add_to_parser(self, parser, ctx):
        super().add_to_parser(parser, ctx)
        for name in self.opts:
            opt = parser._long_opt.get(name) or parser._short_opt.get(name)
            if opt is None:
                continue
            first = opt.process

            def process(value, state, first=first):
                first(value, state)
                while state.rargs and not state.rargs[0].startswith("-"):
                    first(state.rargs.pop(0), state)

            opt.process = process


#: ``--noise`` units → SI
NOISE_SI = {"cop": 1e-3, "tau": 1.0, "balance": math.pi / 180}


def _noise(given: tuple[str, ...]) -> dict[str, float] | None:
    """``--noise KIND=VALUE`` flags as SI standard deviations per kind (None: none given)."""
    out = {}
    for g in given:
        kind, _, value = g.partition("=")
        if kind not in NOISE_SI:
            common.fail(f"--noise {g}: KIND is cop, tau or balance")
        try:
            v = float(value)
        except ValueError:
            v = math.nan
        if not (math.isfinite(v) and v > 0):
            common.fail(f"--noise {g}: VALUE must be a number > 0")
        out[kind] = v * NOISE_SI[kind]
    return out or None


def _write_json(outs: OutputSet, out: str | None, doc: dict) -> None:
    """Write ``doc`` to ``--json`` (when given) and say so."""
    if out is None:
        return
    with outs, open(outs.path(out), "w") as fh:
        json.dump(doc, fh, indent=1, allow_nan=False)
        fh.write("\n")
    click.echo(f"wrote {out}")


@click.command()
@click.argument("data", nargs=-1, required=True)
@click.option("--models", "-m", "models", cls=_Several, multiple=True, required=True,
              help="A candidate model file (URDF or MJCF, or an embedded robot name); repeat the "
              "flag, or give several after it.")  # fmt: skip
@click.option("--support", default=None, help="The support frame the data were measured on.")
@click.option("--line", default=None,
              help="Balance data: the support line (x, y, -y, … or ax,ay,az).")  # fmt: skip
@click.option("--total-mass", type=click.FloatRange(0, min_open=True), default=None,
              help="The weighed total mass [kg].")  # fmt: skip
@click.option("--mass-std", type=click.FloatRange(0, min_open=True), default=None,
              help="Standard deviation of the weighed mass [kg] (default 0.5 %).")  # fmt: skip
@click.option("--z", "level", type=click.FloatRange(0, min_open=True), default=DEFAULT_Z,
              show_default=True, help="z a change must reach to be named.")  # fmt: skip
@click.option("--noise", "noise", multiple=True, metavar="KIND=VALUE",
              help="A kind's noise standard deviation instead of the data's own estimate: "
              "cop=MM, tau=NM, balance=DEG (repeat for several).")  # fmt: skip
@click.option("--folds", type=click.IntRange(0, 100), default=DEFAULT_FOLDS, show_default=True,
              help="Folds of the cross-validated error after a fit (0: skip it).")  # fmt: skip
@common.file_option("--json", "Write the audit as JSON here.", "json_out")
@click.option("--fail-on", type=click.Choice(["rejected", "checks"]), default=None,
              help=f"Exit {FAIL_EXIT} when the best candidate is rejected by the data or fails "
              "a model check (for CI).")  # fmt: skip
@common.force_option
def audit(data, models, noise, folds, json_out, fail_on, force, **keywords):
    """Score candidate model files of one robot against measured DATA (CoP, torques, balance;
    files pool; FILE@FRAME for a stance): mass gap, prediction and cross-validated errors per
    kind, the bodies the data reject, model checks, a ranking and a verdict."""
    # keywords: the flags named as sescid.audit's own (support, line, total_mass, mass_std, level)
    from sescid.audit import audit as run_audit

    if folds == 1:
        common.fail("--folds: 0 (no cross-validation) or at least 2")
    outs = OutputSet([json_out], list(data) + list(models), force=force)
    result = run_audit(list(data), list(models), folds=folds, noise=_noise(noise), **keywords)
    click.echo(result.text())
    _write_json(outs, json_out, result.to_json())
    best = result.best
    if (fail_on == "rejected" and best.rejected) or (fail_on == "checks" and best.checks):
        sys.exit(FAIL_EXIT)


@click.command()
@click.argument("fits", nargs=-1, required=True, type=common.FILE)
@click.option("--z", "level", type=click.FloatRange(0, min_open=True), default=DEFAULT_Z,
              show_default=True, help="z a change must reach to be named.")  # fmt: skip
@common.file_option("--json", "Write the comparison as JSON here.", "json_out")
@common.force_option
def compare_cmd(fits, level, json_out, force):
    """What changed between FITS of one robot and support: two fits (before/after), the bodies
    whose mass or CoM changed beyond their uncertainty; several (sessions), the outlier and
    each combination's repeatability."""
    from sescid.audit import compare

    if len(fits) < 2:
        common.fail("compare needs at least two fit files")
    outs = OutputSet([json_out], list(fits), force=force)
    result = compare(list(fits), level=level)
    click.echo(result.text())
    _write_json(outs, json_out, result.to_json())
