"""The options of ``identify``: one object per method, each checking its own values when made;
one dispatch from a method's name; one public ``identify``."""

from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

import numpy as np
import pytest

import sescid
from sescid.errors import OptionError, check_choice, choices
from sescid.estimation import (
    METHOD_CHOICES,
    METHODS,
    AutoOptions,
    ConsistentOptions,
    IdentifyOptions,
    LeastSquaresOptions,
    MapOptions,
    Method,
    MethodName,
    method_options,
)
from sescid.simulation import simulate

SRC = Path(sescid.__file__).parent


def test_a_name_gives_its_method_with_default_options_and_an_object_is_its_own():
    assert method_options("ls") == LeastSquaresOptions()
    assert method_options("map") == MapOptions()
    assert method_options("consistent") == ConsistentOptions()
    assert method_options("auto") == AutoOptions(MapOptions())
    given = MapOptions(prior_scale=1e-3, bias=True)
    assert method_options(given) is given
    assert [method_options(m).method for m in METHOD_CHOICES] == list(METHOD_CHOICES)
    assert AutoOptions(given).resolved("map") is given
    assert AutoOptions(given).resolved("ls") == LeastSquaresOptions()
    with pytest.raises(OptionError, match=r"method: must be one of 'auto', 'ls', 'map', 'cons"):
        method_options("lsq")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: MapOptions(select="bayes"), r"select: must be one of 'evidence', 'cv'"),
        (lambda: MapOptions(prior="body"), r"prior: must be one of 'auto', 'sesc', 'bodies'"),
        (lambda: MapOptions(prior_scale=1e300), r"prior_scale: .*≤ 100"),
        (lambda: MapOptions(noise=0.0), r"noise: must be a positive"),
        (lambda: MapOptions(folds=1), r"folds: .*at least 2"),
        (lambda: MapOptions(select="cv", bias=True), r"bias: .*cv does not fit a bias"),
        (lambda: ConsistentOptions(via="both"), r"via: must be one of 'auto', 'prior', 'fit'"),
        (lambda: IdentifyOptions(robust="yes"), r"robust: must be one of True, False, 'auto'"),
        (
            lambda: IdentifyOptions(kinds=("cop", "force")),
            r"kinds: must be one of 'cop', 'tau', 'balance'",
        ),
        (lambda: IdentifyOptions(kinds=()), r"kinds: must name some measurement kinds"),
        (lambda: IdentifyOptions(cv=1), r"cv: must be ≥ 2, got 1"),
        (lambda: IdentifyOptions(online_step=0), r"online_step: must be ≥ 1"),
        (lambda: IdentifyOptions(gain_prior=2.0), r"gain_prior: must be a relative std"),
        (lambda: IdentifyOptions(joint_noise=2.0), r"joint_noise: must be an angle"),
    ],
)
def test_each_options_object_checks_its_values_when_made(make, match):
    with pytest.raises(OptionError, match=match):
        make()


def test_a_replaced_or_overridden_field_is_checked_too():
    """``dataclasses.replace`` and ``identify``'s keyword overrides make a new, checked object."""
    with pytest.raises(OptionError, match="select"):
        dataclasses.replace(MapOptions(), select="cross")  # type: ignore[arg-type]
    with pytest.raises(OptionError, match="huber_k"):
        IdentifyOptions().with_overrides(huber_k=-1.0)
    with pytest.raises(OptionError, match="rtoll: is not an option of identify"):
        IdentifyOptions().with_overrides(rtoll=1e-9)


def test_the_messages_list_the_choices_of_the_alias():
    """The allowed values come from the ``Literal`` alias (one home), nested aliases and
    ``bool`` flattened."""
    assert choices(Method) == METHODS == ("ls", "map", "consistent")
    assert choices(MethodName) == METHOD_CHOICES == ("auto", "ls", "map", "consistent")
    from sescid.estimation.solvers.options import PriorChoice, Robust

    assert choices(PriorChoice) == ("auto", "sesc", "bodies")
    assert choices(Robust) == (True, False, "auto")
    check_choice("robust", False, Robust)
    with pytest.raises(OptionError, match="got 1"):
        check_choice("robust", 1, Robust)  # 1 == True, but not a bool


def test_a_method_object_gives_the_same_fit_as_its_name(op2):
    """``method="map"`` and ``method=MapOptions()`` are one method; a MAP option object carries
    its settings (a given prior scale) into the fit."""
    sim = simulate(op2, 60, 30.0, 0.005, 4)
    by_name = sescid.identify(op2, sim.q, sim.cop, method="map")
    by_object = sescid.identify(op2, sim.q, sim.cop, method=MapOptions())
    assert by_name.method == by_object.method == "map"
    np.testing.assert_array_equal(by_name.r, by_object.r)
    given = sescid.identify(op2, sim.q, sim.cop, method=MapOptions(prior_scale=2e-3))
    assert given.map is not None and given.map.prior_scale == 2e-3
    assert given.map.prior_scale_by == "given"


def test_shared_options_a_method_cannot_run_with_are_refused(op2):
    sim = simulate(op2, 30, 30.0, 0.005, 5)
    with pytest.raises(OptionError, match="online: the recursive fit supports ls or map"):
        sescid.identify(op2, sim.q, sim.cop, method="consistent", online_step=5)
    with pytest.raises(OptionError, match="online: a recursive MAP fit needs"):
        sescid.identify(op2, sim.q, sim.cop, method="map", online_step=5)
    with pytest.raises(OptionError, match="tau_gains: torque gains go with ls or map"):
        sescid.identify(op2, sim.q, sim.cop, method="consistent", tau_gains=True)


def _defs_named(name: str) -> list[str]:
    out = []
    for path in sorted(SRC.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef) and node.name == name:
                out.append(str(path.relative_to(SRC)))
    return out


def test_one_identify_outside_the_command_line():
    """One function named ``identify`` (``sescid.identify``); the CLI's command of that name is
    a shell over it."""
    defs = [p for p in _defs_named("identify") if not p.startswith("cli/")]
    assert defs == ["api.py"]
    assert sescid.identify.__module__ == "sescid.api"
