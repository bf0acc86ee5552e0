"""One planner (``plan_poses`` over one stance or several) and one D-optimal engine
(``planning.design.engine``): a one-element stance set is the robot rooted there, the engine's
CoP fast path and its block search reach the exhaustive optimum, its errors are the closed form,
and the CLI leaves every count rule to the planner."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from click.testing import CliRunner

from sescid import load_robot
from sescid import planning as design
from sescid.cli import cli
from sescid.errors import OptionError
from sescid.estimation import min_poses, structural_rank
from sescid.planning.design.blocks import select_blocks
from sescid.planning.design.doptimal import select_d_optimal
from sescid.planning.design.engine import (
    choose,
    expected_error,
    random_errors,
    select_poses,
)
from sescid.planning.design.kinds import BlockRows

SMALL = {"n_candidates": 300, "n_test": 100}


@pytest.fixture(scope="module")
def op2():
    return load_robot("op2")


def test_one_stance_is_the_robot_rooted_there(op2):
    """``stances="l_sole"`` plans exactly what the robot rooted at l_sole plans; the model CoP is
    that robot's (Robot.cop, computed apart from the planner's level CoP)."""
    left = op2.stance("l_sole")
    plan = design.plan_poses(op2, 22, stances="l_sole", **SMALL)
    alone = design.plan_poses(left, 22, **SMALL)
    assert isinstance(plan, design.PosePlan) and isinstance(plan, design.Plan)
    np.testing.assert_array_equal(plan.q, alone.q)
    assert plan.expected_error == alone.expected_error and plan.mount == "stand"
    np.testing.assert_allclose(plan.cop, left.cop(plan.q), atol=1e-12)


def test_stance_options_are_refused_by_the_planner(op2):
    """A mount beside stances, random poses over several stances, a hang height on a standing
    robot and too few poses: one-line OptionErrors before any candidate is drawn."""
    with pytest.raises(OptionError, match="mount"):
        design.plan_poses(op2, 22, stances="l_sole", mount="stand", **SMALL)
    with pytest.raises(OptionError, match="D-optimally"):
        design.plan_poses(op2, 30, "random", stances="r_sole,l_sole", **SMALL)
    with pytest.raises(OptionError, match="hang height"):
        design.plan_poses(op2, 22, hang_height=0.5, **SMALL)
    with pytest.raises(OptionError, match=f"at least {min_poses(op2)} poses"):
        design.plan_poses(op2, min_poses(op2) - 1, **SMALL)
    with pytest.raises(OptionError, match="must not exceed --candidates"):
        design.plan_poses(op2, 40, n_candidates=30)


def test_cli_leaves_the_count_rule_to_the_planner(tmp_path, op2):
    """`poses --count 10`: the planner's message (the identifiable combinations), no file."""
    out = tmp_path / "p.csv"
    res = CliRunner().invoke(cli, ["poses", "--count", "10", "--out", str(out)])
    assert res.exit_code == 2 and not out.exists()
    assert f"op2 has {structural_rank(op2)} identifiable combinations" in res.output


def _exhaustive(a: np.ndarray, k: int) -> float:
    return max(
        np.linalg.slogdet(np.einsum("nri,nrj->ij", a[list(s)], a[list(s)]))[1]
        for s in itertools.combinations(range(len(a)), k)
    )


def test_both_searches_reach_the_exhaustive_optimum_of_cop_rows():
    """CoP rows (two a pose, no offset): the engine takes the rank-2 search (the same picks as
    ``select_d_optimal``); it and the block search both find the best 3 of 14 by enumeration."""
    rng = np.random.default_rng(6)
    a = rng.normal(size=(14, 2, 4)) * rng.uniform(0.2, 2.0, size=(14, 1, 1))
    rows = BlockRows.plain(a)
    fast = select_poses(rows, 3, 0)
    np.testing.assert_array_equal(fast.index, select_d_optimal(a, 3, 0).index)
    best = _exhaustive(a, 3)
    assert fast.logdet == pytest.approx(best, abs=1e-9)
    assert select_blocks(rows, 3, 0).logdet == pytest.approx(best, abs=1e-9)


def test_random_choice_and_errors_are_the_closed_form():
    """A random choice's log det is that of its rows' information; the expected error is
    σ sqrt(trace(M⁻¹ C)) computed here with a plain inverse."""
    rng = np.random.default_rng(3)
    a = rng.normal(size=(60, 2, 5))
    c = np.einsum("nri,nrj->ij", a[:20], a[:20]) / 40
    rows = BlockRows.plain(a)
    sel = choose(rows, 8, "random", 4, np.arange(60) >= 10)
    assert np.all(sel.index >= 10) and len(set(sel.index)) == 8
    m = np.einsum("nri,nrj->ij", a[sel.index], a[sel.index])
    assert sel.logdet == pytest.approx(np.linalg.slogdet(m)[1], abs=1e-12)
    sigma = 0.005
    want = sigma * math.sqrt(np.trace(np.linalg.inv(m) @ c))
    assert expected_error(rows, sel.index, c, sigma) == pytest.approx(want, rel=1e-10)
    draws = random_errors(rows, 8, c, 5, 1, sigma)
    assert draws.shape == (5,) and np.all(draws > 0)
    assert expected_error(rows, [0, 1], c) == math.inf  # 4 rows cannot determine 5 coordinates
