"""Poses for a payload (planning.payload): the D-optimal choice beats random candidates, and
the standard errors it promises are those a fit on its poses states."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from payload_gen import robot_with_payload

from sescid import Measurements, identify_payload, load_robot, read_table
from sescid.cli import cli
from sescid.planning import PlanOptions, plan_payload_poses

HAND = "MP_ARM_LOW_R"


@pytest.fixture(scope="module")
def op2():
    return load_robot("op2")


@pytest.mark.parametrize("mass", [None, 0.6])
def test_plan_promises_what_a_fit_states(op2, tmp_path, mass):
    sigma = 2e-3
    plan = plan_payload_poses(op2, HAND, 8, 0, PlanOptions(n_candidates=400, sigma=sigma),
                              mass=mass)  # fmt: skip
    assert plan.q.shape == (8, op2.nq)
    free = slice(0, 4) if mass is None else slice(1, 4)
    assert np.all(plan.std[free] <= plan.random_std[free] * 1.05)
    assert np.prod(plan.std[free]) < np.prod(plan.random_std[free])
    # the nominal payload on the planned poses, the CoP with the planned noise
    truth = robot_with_payload(op2, tmp_path, HAND, plan.nominal_mass, [0.0, 0.0, 0.0])
    cop = truth.cop(plan.q) + np.random.default_rng(1).normal(0, sigma, (8, 2))
    fit = identify_payload(op2, Measurements(q=plan.q, cop=cop), HAND, mass=mass,
                           cop_noise=sigma)  # fmt: skip
    p = fit.payload
    assert p is not None
    stated = np.concatenate([[p.mass_std], p.com_std])
    np.testing.assert_allclose(stated[free], plan.std[free], rtol=0.25)


def test_poses_payload_cli(tmp_path):
    out = tmp_path / "p.csv"
    res = CliRunner().invoke(cli, ["poses", "--payload", HAND, "--candidates", "300", "--out",
                                   str(out)])  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "expected std, chosen: mass ±" in res.output
    assert len(read_table(out).get("r_el")) == 8
    res = CliRunner().invoke(cli, ["poses", "--payload", "hand", "--out", str(tmp_path / "x")])
    assert res.exit_code == 2 and "no link named 'hand'" in res.output
    assert len(res.output.strip().splitlines()) == 1
