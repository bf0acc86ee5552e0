"""Stances pooled: the body parameters every stance shares, against an independent dense least
squares, and what pooling adds (ranks, accuracy) with the same number of poses."""

from __future__ import annotations

import re

import numpy as np
import pytest

import sescid
from sescid import identify
from sescid.errors import DataError
from sescid.estimation import Measurements
from sescid.estimation.sums.pooled import PARAM_UNIT, for_support, prior_x
from sescid.simulation import random_poses


def real(robot, rng) -> np.ndarray:
    """Body parameters θ of a "real" robot: masses ±10 %, first moments ±5 mm per unit mass."""
    theta = robot.body_parameters()
    n = len(robot.body_names)
    theta[:n] *= 1 + 0.1 * rng.normal(size=n)
    theta[n:] += 0.005 * np.repeat(theta[:n], 3) * rng.normal(size=3 * n)
    return theta


def cop_data(ref, theta, support, k, rng, noise=0.002):
    robot = ref.at(support)
    r = (robot.sesc_matrix(ref) @ theta / theta[: len(ref.body_names)].sum()).reshape(-1, 3)
    q = random_poses(robot, k, 30, rng)
    cop = robot.cop(q, r) + rng.normal(0, noise, (k, 2))
    return Measurements(q=q, cop=cop, support=None if support == ref.support else support)


def test_pooled_least_squares_is_the_dense_one_over_body_parameters(op2, rng):
    """Both soles' CoP: the fit equals numpy's minimum-norm least squares over x (both stances'
    regressors times their maps from x), the model filling the rest; its predictions in either
    stance are that solution's."""
    theta = real(op2, rng)
    data = [cop_data(op2, theta, s, 120, rng) for s in ("r_sole", "l_sole")]
    fit = identify(op2, data, method="ls")
    n = len(op2.body_names)
    scale = np.concatenate([np.ones(n), np.full(3 * n, PARAM_UNIT)])
    rows, ys = [], []
    for m, s in zip(data, ("r_sole", "l_sole"), strict=True):
        robot = op2.at(s)
        lmap = robot.sesc_matrix(op2) * scale
        rows.append(np.einsum("nap,pk->nak", robot.regressor(m.q), lmap).reshape(-1, 4 * n))
        ys.append((m.cop - robot.d[:2]).reshape(-1))
    a, y = np.vstack(rows), np.concatenate(ys)
    x0 = prior_x(op2)
    x = x0 + np.linalg.lstsq(a, y - a @ x0, rcond=1e-6)[0]
    assert fit.bodies.rank == np.linalg.matrix_rank(a, tol=1e-6 * np.linalg.norm(a, 2))
    fresh = random_poses(op2, 200, 30, 9)
    for s in ("r_sole", "l_sole"):
        robot = op2.at(s)
        r = ((robot.sesc_matrix(op2) * scale) @ x).reshape(-1, 3)
        seen = for_support(fit, s)
        np.testing.assert_allclose(seen.predict_cop(fresh), robot.cop(fresh, r), atol=1e-9)


def test_both_soles_determine_more_than_one(op2):
    """OP2, CoP: each sole alone determines 42 combinations of the 84 body parameters (42 of the
    63 SESC components), both together 44 (43 of the right sole's r): the support foot's own
    vertical moment and the lower leg's masses. With the same number of poses least squares
    puts the whole-body CoM closer to the truth (its height: what one sole cannot see)."""
    rng = np.random.default_rng(5)
    one, both = [], []
    for _ in range(6):
        theta = real(op2, rng)
        right = cop_data(op2, theta, "r_sole", 160, rng)
        pooled = [cop_data(op2, theta, s, 80, rng) for s in ("r_sole", "l_sole")]
        r_true = (op2.sesc_matrix() @ theta / theta[:21].sum()).reshape(-1, 3)
        fresh = random_poses(op2, 400, 30, 3)
        for data, out in ((right, one), (pooled, both)):
            fit = identify(op2, data, method="ls")
            d = op2.com(fresh, fit.r) - op2.com(fresh, r_true)
            out.append(np.sqrt(np.mean(np.sum(d * d, axis=1))))
        assert fit.rank == 43 and fit.bodies.rank == 44
        assert [s.rank for s in fit.bodies.stances] == [42, 42]
        assert any("MP_ANKLE2_R" in a for a in fit.bodies.added)
    assert np.mean(both) < 0.85 * np.mean(one)


def test_torques_of_both_feet_share_their_sensors(op2):
    """Torques on each foot, one offset per joint for both: 40 combinations from one foot, 44
    pooled; the offsets are the sensors' (shared), recovered from noise-free readings."""
    rng = np.random.default_rng(2)
    theta = real(op2, rng)
    mass = theta[:21].sum()
    offsets = rng.normal(0, 0.05, op2.nq)
    data = []
    for s in ("r_sole", "l_sole"):
        robot = op2.at(s)
        r = (robot.sesc_matrix(op2) @ theta / mass).reshape(-1, 3)
        q = random_poses(robot, 40, 30, rng)
        tau = robot.torques(q, r, total_mass=mass) + offsets
        support = None if s == "r_sole" else s
        data.append(Measurements(q=q, tau=tau, tau_joints=tuple(op2.joint_names), support=support))
    fit = identify(op2, data, method="ls", total_mass=mass, robust=False)
    assert fit.bodies.rank == 44 and [s.rank for s in fit.bodies.stances] == [40, 40]
    est = np.array([e.value for e in fit.nuisance if e.what == "offset"])
    assert len(est) == op2.nq
    np.testing.assert_allclose(est, offsets, atol=1e-8)
    r_true = (op2.sesc_matrix() @ theta / mass).reshape(-1, 3)
    fresh = random_poses(op2, 200, 30, 4)
    truth = op2.torques(fresh, r_true, total_mass=mass)
    np.testing.assert_allclose(fit.predict_torque(fresh), truth, atol=1e-8)


def test_a_support_column_pools_the_rows_of_one_file(op2, tmp_path, rng):
    from sescid.tables import write_table

    theta = real(op2, rng)
    data = [cop_data(op2, theta, s, 60, rng) for s in ("r_sole", "l_sole")]
    q = np.concatenate([m.q for m in data])
    cop = np.concatenate([m.cop for m in data])
    support = np.array(["r_sole"] * 60 + ["l_sole"] * 60)
    order = rng.permutation(120)
    cols = {j: q[order, i] for i, j in enumerate(op2.joint_names)}
    cols |= {"cop_x": cop[order, 0], "cop_y": cop[order, 1], "support": support[order]}
    write_table(tmp_path / "m.csv", cols)
    fit = sescid.identify(op2, tmp_path / "m.csv", method="ls", allow_outside_limits=True)
    ref = identify(op2, data, method="ls")
    np.testing.assert_allclose(fit.r, ref.r, atol=1e-12)
    bad = dict(cols)
    bad["support"] = np.array(["r_sole"] * 119 + ["toe"])
    write_table(tmp_path / "bad.csv", bad)
    with pytest.raises(
        DataError, match=r"bad\.csv: row 121, column 'support': .*unknown support 'toe'"
    ):
        sescid.identify(op2, tmp_path / "bad.csv", allow_outside_limits=True)


def test_double_support_rows_are_the_robots_cop_and_refuse_torques(op2, rng):
    q = random_poses(op2, 60, 30, rng)
    cop = op2.cop(q) + rng.normal(0, 0.002, (60, 2))
    one = identify(op2, Measurements(q=q, cop=cop), method="ls")
    double = identify(op2, Measurements(q=q, cop=cop, support="double"), method="ls")
    fresh = random_poses(op2, 100, 30, 1)
    np.testing.assert_allclose(double.predict_cop(fresh), one.predict_cop(fresh), atol=1e-9)
    tau = op2.torques(q)
    m = Measurements(q=q, tau=tau, tau_joints=tuple(op2.joint_names), support="double")
    with pytest.raises(DataError, match="joint torques on both feet"):
        identify(op2, [Measurements(q=q, cop=cop), m], total_mass=op2.total_mass)


def test_pooled_fit_on_the_command_line_and_in_its_file(tmp_path):
    """simulate on each sole (a support column), identify pools them, the fit file keeps the body
    parameters, predict --support answers in the other stance, FILE@FRAME reads a file without
    the column."""
    from click.testing import CliRunner

    from sescid.cli import cli
    from sescid.tables import read_table

    def run(*args):
        res = CliRunner().invoke(cli, [str(a) for a in args])
        assert res.exit_code == 0, res.output
        return res.output

    op2 = sescid.load_robot("op2")
    run("simulate", "--poses", 60, "--seed", 1, "--out", tmp_path / "r.csv")
    run("simulate", "--support", "l_sole", "--poses", 60, "--seed", 2, "--out", tmp_path / "l.csv")
    assert set(read_table(tmp_path / "l.csv").text["support"]) == {"l_sole"}
    out = run("identify", tmp_path / "r.csv", tmp_path / "l.csv", "--method", "ls",
              "--allow-outside-limits", "--out", tmp_path / "f.json")  # fmt: skip
    assert "stances pooled over the 84 body parameters" in out
    fit = sescid.load_fit(tmp_path / "f.json")
    assert fit.bodies is not None and fit.bodies.rank == 44
    run("predict", tmp_path / "f.json", tmp_path / "l.csv", "--support", "l_sole",
        "--out", tmp_path / "p.csv")  # fmt: skip
    table = read_table(tmp_path / "p.csv")
    data = read_table(tmp_path / "l.csv")
    ql = np.column_stack([data.get(j) for j in op2.joint_names])
    seen = for_support(fit, "l_sole")
    np.testing.assert_allclose(table.get("cop_x"), seen.predict_cop(ql)[:, 0], atol=1e-15)
    # a file without the column, named with its stance
    cols = {c: data.get(c) for c in op2.joint_names + ["cop_x", "cop_y"]}
    from sescid.tables import write_table

    write_table(tmp_path / "bare.csv", cols)
    run("identify", tmp_path / "r.csv", f"{tmp_path / 'bare.csv'}@l_sole", "--method", "ls",
        "--allow-outside-limits", "--out", tmp_path / "g.json")  # fmt: skip
    np.testing.assert_allclose(sescid.load_fit(tmp_path / "g.json").r, fit.r, atol=1e-12)


def test_the_bench_carries_the_stance_through_measure_and_truth(tmp_path):
    """experiment writes the stance, measure keeps it (and reduces in that stance's frame),
    identify pools the two measured files, truth judges the pooled fit in each stance."""
    from click.testing import CliRunner

    from sescid.cli import cli
    from sescid.tables import read_table

    def run(*args):
        res = CliRunner().invoke(cli, [str(a) for a in args])
        assert res.exit_code == 0, res.output
        return res.output

    for side, seed in (("r_sole", 0), ("l_sole", 1)):
        run(
            "poses",
            "--support",
            side,
            "--count",
            30,
            "--seed",
            seed,
            "--out",
            tmp_path / f"p{side}.csv",
        )
        run("experiment", "--support", side, "--poses", tmp_path / f"p{side}.csv", "--samples", 10,
            "--out", tmp_path / f"r{side}.csv", "--truth", tmp_path / f"t{side}.json")  # fmt: skip
        run("measure", tmp_path / f"r{side}.csv", "--out", tmp_path / f"m{side}.csv")
        assert set(read_table(tmp_path / f"m{side}.csv").text["support"]) == {side}
    out = run(
        "identify", tmp_path / "mr_sole.csv", tmp_path / "ml_sole.csv", "--out", tmp_path / "f.json"
    )
    assert "stances pooled" in out
    for side in ("r_sole", "l_sole"):
        text = run("truth", tmp_path / "f.json", tmp_path / f"t{side}.json")
        ident, manu = (
            float(x) for x in re.findall(r"identified ([\d.]+) mm, manufacturer ([\d.]+)", text)[-1]
        )
        assert ident < manu
    res = CliRunner().invoke(cli, ["measure", str(tmp_path / "rl_sole.csv"), "--support", "r_sole",
                                   "--out", str(tmp_path / "x.csv")])  # fmt: skip
    assert res.exit_code == 2 and "measured on 'l_sole'" in res.output
