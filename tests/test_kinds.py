"""The measurement kinds, one vocabulary (``sescid.kinds``): what one measurement is and what a
plan, a session or a simulation measures, with the one parser and formatter of their spellings."""

from __future__ import annotations

import numpy as np
import pytest

import sescid.estimation as estimation
import sescid.estimation.data.measurements as measurements
import sescid.planning as planning
from sescid.cli.simulate import Measure
from sescid.errors import OptionError, choices
from sescid.kinds import KINDS, DesignKind, Kind, kinds_label, parse_kinds
from sescid.session import SessionKind, SessionOptions


def test_one_vocabulary():
    """The estimation's kind, the planner's spelling and the stance's refusals name the same
    objects (imported from their one home, exported where they were)."""
    assert estimation.Kind is measurements.Kind is Kind
    assert estimation.KINDS is KINDS == ("cop", "tau", "balance")
    assert planning.DesignKind is DesignKind


@pytest.mark.parametrize(
    "text,kinds",
    [
        ("cop", ("cop",)),
        ("tau", ("tau",)),
        ("both", ("cop", "tau")),
        ("cop,tau", ("cop", "tau")),
        (" tau , cop ", ("cop", "tau")),
        (("tau", "cop"), ("cop", "tau")),
        (["tau"], ("tau",)),
    ],
)
def test_every_spelling_parses_to_the_kinds_in_order(text, kinds):
    assert parse_kinds(text) == kinds
    assert parse_kinds(parse_kinds(text)) == kinds  # parsed kinds parse to themselves


@pytest.mark.parametrize("spelled", [DesignKind, Measure])
def test_the_label_is_the_spelling_users_wrote(spelled):
    """Each spelling parses and formats back to itself: printed text and files keep it."""
    for word in choices(spelled):
        assert kinds_label(parse_kinds(word, "measure", spelled)) == word


@pytest.mark.parametrize("bad", ["x", "", "cop,x", "balance", ("cop", "force"), 3])
def test_a_bad_spelling_is_refused_with_the_message_it_had(bad):
    """The message the planner's Literal check gave before the one parser (the same text)."""
    with pytest.raises(OptionError) as got:
        parse_kinds(bad)
    assert str(got.value) == f"kinds: must be one of 'cop', 'tau', 'both', got {bad!r}"


def test_a_spelling_that_names_no_kind_is_refused():
    """A session's "auto" is read before the parser; given to it, it is refused, not empty."""
    with pytest.raises(OptionError, match="'auto' names no measurement kind"):
        parse_kinds("auto", "kinds", SessionKind)


def test_a_set_no_spelling_names_is_refused():
    """``simulate --measure`` has balance alone, never with the CoP."""
    assert parse_kinds("balance", "measure", Measure) == ("balance",)
    with pytest.raises(OptionError, match="measure: must be one of 'cop', 'tau', 'both', 'bal"):
        parse_kinds("cop,balance", "measure", Measure)


def test_session_options_read_the_same_spellings():
    """A session takes any spelling of its kinds, "auto" too; a bad one gets the message the
    Literal check gave."""
    assert SessionOptions(kinds="cop,tau").kinds == "cop,tau"
    assert SessionOptions(kinds="auto").kinds == "auto"
    with pytest.raises(OptionError) as got:
        SessionOptions(kinds="cop,x")
    assert str(got.value) == "kinds: must be one of 'auto', 'cop', 'tau', 'both', got 'cop,x'"


def test_a_plan_is_the_same_for_every_spelling(op2):
    """``plan_poses(kinds="both")`` keeps working, and every spelling of the same kinds plans
    the same poses."""
    small = {"seed": 3, "n_candidates": 300, "n_test": 100}
    plans = [planning.plan_poses(op2, 25, kinds=k, **small) for k in ("both", "tau,cop")]
    assert plans[0].kinds == plans[1].kinds == ("cop", "tau")
    np.testing.assert_array_equal(plans[0].q, plans[1].q)
