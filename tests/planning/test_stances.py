"""Plans over several stances: the rows each stance gives about the shared body parameters θ
against Pinocchio (CoM in another sole's frame, holding torques with a held torso), the ranks
against the singular values of the stacked rows, the expected error against a simulated MAP
fit with known truth, and the plan's grouping, cost and pose table."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner
from oracle import PinOracle, PinStatics

from sescid import planning as design
from sescid.base import G0
from sescid.cli import cli
from sescid.errors import OptionError
from sescid.planning.design.kinds import design_kinds
from sescid.planning.design.stances import StanceRows, theta_scale
from sescid.planning.pooled import PRIOR_TAU
from sescid.simulation import random_poses
from sescid.tables import read_table

SMALL = {"n_candidates": 400, "n_test": 200}


def test_parse_stances(op2):
    """Frames, double, gantry:/stand: prefixes; the trunk is held by default; errors name it."""
    st = design.parse_stances("r_sole, l_sole,double,gantry:MP_BODY", op2)
    assert [s.label for s in st] == ["r_sole", "l_sole", "double", "MP_BODY"]
    assert [s.mount for s in st] == ["stand", "stand", "double", "gantry"]
    assert st[2].support == "r_sole"
    assert design.parse_stances("MP_BODY", op2)[0].mount == "gantry"
    assert design.parse_stances(["stand:l_sole"], op2)[0] == design.Stance("l_sole", "stand")
    for bad, err in (("", OptionError), ("r_sole,r_sole", OptionError),
                     ("hang:MP_BODY", OptionError), ("no_such_link", OptionError)):  # fmt: skip
        with pytest.raises(err):
            design.parse_stances(bad, op2)


def test_rows_over_theta_against_pinocchio(op2):
    """A pose's rows times θ̃ = θ / D give Pinocchio's CoM x/y in l_sole's frame and its holding
    torques with l_sole fixed and with the torso held (the offsets 0)."""
    spec = design_kinds(op2, "both")
    theta = op2.body_parameters() / theta_scale(op2)
    q = random_poses(op2, 6, 30.0, 1)
    for support, mount in (("l_sole", "stand"), ("MP_BODY", "gantry")):
        rows = StanceRows(op2, design.Stance(support, mount), spec, op2.total_mass)
        x = np.concatenate([b for _, b in rows.blocks(q)])
        y = x[:, :, : len(theta)] @ theta
        tau = PinStatics(op2.model_path, support, op2.joint_names, G0).torques(q)
        np.testing.assert_allclose(y[:, 2:] * spec.tau_noise, tau, atol=1e-12)
        eye = np.broadcast_to(np.eye(op2.nq), (6, op2.nq, op2.nq))
        np.testing.assert_allclose(x[:, 2:, len(theta) :] * spec.tau_noise, eye)
        if mount == "gantry":
            assert not np.any(x[:, :2])
            continue
        com = PinOracle(op2.model_path, support, op2.joint_names).com(q)
        d = op2.at(support).d
        np.testing.assert_allclose(y[:, :2] * spec.cop_noise + d[:2], com[:, :2], atol=1e-12)


def _svd_rank(mats: list[np.ndarray]) -> int:
    a = np.concatenate([m.reshape(-1, m.shape[-1]) for m in mats])
    s = np.linalg.svd(a, compute_uv=False)
    return int(np.sum(s > 1e-6 * s[0]))


def test_cop_from_both_feet_determines_more(op2):
    """CoP on r_sole and on l_sole: the plan's ranks over θ are those of the stacked rows' singular
    values (each foot alone, both pooled), and pooling determines more than either foot."""
    st = design.parse_stances("r_sole,l_sole", op2)
    plan = design.plan_poses(op2, 40, stances=st, kinds="cop", **SMALL)
    spec = design_kinds(op2, "cop")
    q = random_poses(op2, 300, 30.0, 2)
    x = [np.concatenate([b for _, b in StanceRows(op2, s, spec, op2.total_mass).blocks(q)])
         for s in st]  # fmt: skip
    alone = [_svd_rank([m]) for m in x]
    assert [r.rank for r in plan.reports] == alone
    assert plan.rank == _svd_rank(x) > max(alone)
    assert [r.adds for r in plan.reports] == [plan.rank - alone[1], plan.rank - alone[0]]


@pytest.fixture(scope="module")
def tau_plan(op2):
    st = design.parse_stances("r_sole,l_sole", op2)
    return design.plan_poses(op2, 30, stances=st, kinds="tau", **SMALL)


def test_torques_from_both_feet(tau_plan):
    """Torques on either foot: pooled, more directions than either alone and a smaller expected
    CoM error than the reference foot alone with all 30 poses."""
    plan = tau_plan
    assert plan.rank > max(r.rank for r in plan.reports)
    assert len(plan.q) == 30 - 5 * plan.changes and plan.changes == 1
    assert plan.expected_com_xy < 0.9 * plan.reference_com_xy
    assert plan.expected_com < plan.reference_com


def test_expected_error_is_a_simulated_map_fit(op2, tau_plan):
    """The expected CoM error of a plan is the RMS error of MAP fits of simulated data: body
    parameters drawn from the CAD prior, offsets of ±1 N·m, noise at the design's levels."""
    plan = tau_plan
    spec = design_kinds(op2, "tau")
    mats = []
    for st in plan.stances:
        mine = plan.stance == st.label
        mats.append(np.concatenate([b for _, b in StanceRows(op2, st, spec, op2.total_mass)
                                    .blocks(plan.q[mine])]))  # fmt: skip
    a = np.concatenate(mats).reshape(-1, mats[0].shape[2])
    n4 = 4 * len(op2.body_names)
    ref = design.Stance("r_sole", "stand")
    rows_ref = StanceRows(op2, ref, design_kinds(op2, "cop"), op2.total_mass)
    e = rows_ref.e / op2.total_mass
    phi = op2.regressor(plan.test_q, (0, 1, 2)) @ e  # CoM rows over θ̃
    rng = np.random.default_rng(0)
    prior = np.concatenate([np.full(n4, 1 / PRIOR_TAU**2), np.zeros(a.shape[1] - n4)])
    h = a.T @ a + np.diag(prior)
    err3, err2 = [], []
    for _ in range(400):
        offsets = rng.standard_normal(a.shape[1] - n4) / spec.tau_noise
        dtheta = np.concatenate([PRIOR_TAU * rng.standard_normal(n4), offsets])
        y = a @ dtheta + rng.standard_normal(len(a))
        est = np.linalg.solve(h, a.T @ y)  # MAP about the CAD values (the deviations)
        d = phi @ (est[:n4] - dtheta[:n4])  # (n, 3) CoM errors
        err3.append(np.mean(np.sum(d**2, axis=1)))
        err2.append(np.mean(np.sum(d[:, :2] ** 2, axis=1)))
    assert math.sqrt(np.mean(err3)) == pytest.approx(plan.expected_com, rel=0.1)
    assert math.sqrt(np.mean(err2)) == pytest.approx(plan.expected_com_xy, rel=0.1)


def test_gantry_and_a_foot_pooled(op2):
    """Torques held by the torso and on r_sole: pooled, more directions than either alone; the
    poses are visited stance by stance in the given order, the change costing 5 poses."""
    st = design.parse_stances("gantry:MP_BODY,r_sole", op2)
    plan = design.plan_poses(op2, 30, stances=st, kinds="tau", cost=5.0, **SMALL)
    assert plan.rank > max(r.rank for r in plan.reports)
    labels = list(dict.fromkeys(plan.stance))
    assert labels == ["MP_BODY", "r_sole"] and len(plan.q) == 25
    assert np.all(np.isnan(plan.cop[plan.stance == "MP_BODY"]))
    right = plan.stance == "r_sole"
    np.testing.assert_allclose(plan.cop[right], op2.com(plan.q[right])[:, :2], atol=1e-12)


def test_a_stance_that_adds_nothing_must_pay_for_its_change(op2):
    """Double support adds no direction to r_sole and l_sole for the CoP: at a cost of 5 poses it
    is left out (0 poses), the subsets tried say so."""
    st = design.parse_stances("r_sole,l_sole,double", op2)
    plan = design.plan_poses(op2, 40, stances=st, kinds="cop", **SMALL)
    rep = {r.stance.label: r for r in plan.reports}
    assert rep["double"].adds == 0 and rep["double"].poses == 0
    tried = {labels: k for labels, k, _ in plan.subsets}
    assert tried[("r_sole", "l_sole")] == 35 and tried[("r_sole", "l_sole", "double")] == 30


def test_poses_over_stances_cli(tmp_path):
    """`sescid poses --stances` writes each pose's stance in a support column, grouped, with the
    model CoP in that stance's frame; a stance that cannot give the planned kinds is refused."""
    import sescid

    out = tmp_path / "s.csv"
    args = ["poses", "--candidates", "300", "--test-poses", "100", "--out", str(out)]
    res = CliRunner().invoke(cli, [*args, "--stances", "r_sole,l_sole", "--kinds", "tau",
                                   "--count", "30"])  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "rank over the 84 body parameters" in res.output and "l_sole: alone" in res.output
    t = read_table(out)
    lab = np.asarray(t.text["support"])
    assert list(dict.fromkeys(lab)) == ["r_sole", "l_sole"] and len(lab) == 25
    op2 = sescid.load_robot("op2")
    q = np.column_stack([t.columns[j] for j in op2.joint_names])
    left = lab == "l_sole"
    np.testing.assert_allclose(t.columns["cop_x_model"][left], op2.at("l_sole").com(q[left])[:, 0],
                               atol=1e-12)  # fmt: skip
    for extra, why in ((["--stances", "r_sole,gantry:MP_BODY", "--kinds", "cop"], "gantry"),
                       (["--stances", "r_sole,l_sole", "--select", "random"], "D-optimal"),
                       (["--stances", "double,l_sole", "--mount", "stand"], "mount")):  # fmt: skip
        res = CliRunner().invoke(cli, [*args, *extra, "--count", "30", "--force"])
        assert res.exit_code == 2 and why in res.output, res.output
        assert len(res.output.strip().splitlines()) == 1
