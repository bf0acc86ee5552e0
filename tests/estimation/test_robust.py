"""Huber IRLS and Monte-Carlo joint-angle errors, checked against simulated truth."""

import math

import numpy as np
import pytest
from click.testing import CliRunner
from fitting import identify_ls

from sescid import identify
from sescid.cli import cli
from sescid.errors import SescidError
from sescid.estimation import IdentifyOptions, LeastSquaresOptions, Measurements, load_fit
from sescid.estimation.result.validation import truth_error
from sescid.estimation.solvers.robust import joint_noise_mc
from sescid.estimation.solvers.runs import make_fitter
from sescid.simulation import random_poses, simulate

SIGMA = 0.00493
BAD = np.array([5, 17, 60, 111, 150])  # corrupted poses


@pytest.fixture(scope="module")
def corrupted(robot):
    sim = simulate(robot, 200, 30.0, SIGMA, 3)
    cop = sim.cop.copy()
    cop[BAD] += np.array([0.04, -0.03])  # 5 cm outliers (a foot slipping off a sensor)
    return sim, cop


def _ls(robot):
    """A (q, cop) → least-squares fit function."""
    fitter = make_fitter(robot, LeastSquaresOptions(), IdentifyOptions())
    return lambda q, c: fitter([Measurements(q=q, cop=c).checked(robot)])


def _mfit(robot):
    return make_fitter(robot, LeastSquaresOptions(), IdentifyOptions())


def huber(robot, q, cop, sigma=None, **kw):
    return identify(robot, q, cop, sigma=sigma, robust=True, **kw)


def test_huber_names_the_corrupted_poses(robot, corrupted):
    sim, cop = corrupted
    fit = huber(robot, sim.q, cop)
    low = {i for i, w in fit.robust.downweighted if w < 0.5}
    assert low == set(BAD.tolist())


def test_huber_recovers_the_clean_accuracy(robot, corrupted):
    sim, cop = corrupted
    fresh = simulate(robot, 3000, 30.0, 0.0, 50)
    e_ls = truth_error(identify_ls(robot, sim.q, cop), fresh.q, fresh.cop_true)
    e_hub = truth_error(huber(robot, sim.q, cop), fresh.q, fresh.cop_true)
    e_clean = truth_error(identify_ls(robot, sim.q, sim.cop), fresh.q, fresh.cop_true)
    assert e_hub < 0.75 * e_ls
    assert e_hub < 1.15 * e_clean


def test_huber_noise_scale_in_metres(robot, corrupted):
    sim, cop = corrupted
    fit = huber(robot, sim.q, cop)
    assert fit.sigma_hat == pytest.approx(SIGMA, rel=0.12)
    assert fit.robust.scale == pytest.approx(SIGMA, rel=0.12)


def test_huber_on_clean_data_down_weights_about_5_percent(robot):
    sim = simulate(robot, 400, 30.0, SIGMA, 8)
    fit = huber(robot, sim.q, sim.cop)
    frac = len(fit.robust.downweighted) / 400
    assert 0.02 <= frac <= 0.09  # P(‖e‖ > 2.45σ) = 5 % for Gaussian noise


def test_huber_wraps_map(robot, corrupted):
    sim, cop = corrupted
    fit = huber(robot, sim.q, cop, method="map")
    low = {i for i, w in fit.robust.downweighted if w < 0.5}
    assert low == set(BAD.tolist()) and fit.method == "map" and fit.method_label == "map+huber"


def test_joint_noise_mc_matches_replicated_spread(robot):
    """MC from one data set predicts the spread that 1° joint errors cause over replicates."""
    dq = math.radians(1.0)
    sim = simulate(robot, 200, 30.0, 0.0, 9)  # CoP exact: the joint errors alone
    q_ref = random_poses(robot, 300, 30.0, 10)
    rng = np.random.default_rng(11)
    fitter = _ls(robot)
    preds = [
        fitter(sim.q + rng.normal(0, dq, sim.q.shape), sim.cop).predict_cop(q_ref)
        for _ in range(30)
    ]
    spread = math.sqrt(np.mean(np.var(np.array(preds), axis=0, ddof=1)))
    q_meas = sim.q + rng.normal(0, dq, sim.q.shape)
    fit = fitter(q_meas, sim.cop)
    data = Measurements(q=q_meas, cop=sim.cop).checked(robot)
    mc = joint_noise_mc(_mfit(robot), fit, data, dq, draws=30, reference_poses=q_ref)
    assert mc.cop_std_joint == pytest.approx(spread, rel=0.2)
    assert 0 < mc.share_joint < 1


def test_joint_noise_share_grows_with_the_angle_error(robot):
    sim = simulate(robot, 150, 30.0, SIGMA, 12)
    fitter = _ls(robot)
    fit = fitter(sim.q, sim.cop)
    data = Measurements(q=sim.q, cop=sim.cop).checked(robot)
    small = joint_noise_mc(_mfit(robot), fit, data, math.radians(0.2), draws=10)
    large = joint_noise_mc(_mfit(robot), fit, data, math.radians(2.0), draws=10)
    assert small.share_joint < 0.1 < 0.5 < large.share_joint
    assert large.cop_std_joint == pytest.approx(10 * small.cop_std_joint, rel=0.35)


def test_bad_inputs_raise(robot, corrupted):
    sim, cop = corrupted
    with pytest.raises(SescidError, match="huber_k"):
        huber(robot, sim.q, cop, huber_k=0)
    fit = identify_ls(robot, sim.q, cop)
    with pytest.raises(SescidError, match="joint noise"):
        joint_noise_mc(_mfit(robot), fit, Measurements(q=sim.q, cop=cop), -1.0)


def test_cli_robust_and_joint_noise(robot, corrupted, tmp_path, write_dataset):
    sim, cop = corrupted
    data = write_dataset(tmp_path / "d.csv", sim.q, cop)
    out = tmp_path / "fit.json"
    args = [
        "identify",
        str(data),
        "--out",
        str(out),
        "--robust",
        "--allow-outside-limits",
        "--joint-noise-deg",
        "1",
    ]
    res = CliRunner().invoke(cli, [*args, "--mc-draws", "5"])
    assert res.exit_code == 0, res.output
    first = res.output.split("down-weighted (pose index, weight): ")[1].split(",")[:5]
    assert {int(s.split()[0]) for s in first} == set(BAD.tolist())
    back = load_fit(out)
    assert back.joint_noise.draws == 5 and back.robust.downweighted


def test_huber_with_per_pose_errors_scale_near_one(robot):
    """Heteroscedastic CoP noise with its true standard errors given: scale ≈ 1, outliers named."""
    rng = np.random.default_rng(13)
    q = random_poses(robot, 200, 30.0, 14)
    se = rng.uniform(0.002, 0.008, 200)
    cop = robot.cop(q) + rng.normal(0, 1, (200, 2)) * se[:, None]
    cop[BAD] += np.array([0.04, -0.03])
    fit = huber(robot, q, cop, se)
    assert fit.robust.scale == pytest.approx(1.0, abs=0.15)
    assert {i for i, w in fit.robust.downweighted if w < 0.5} == set(BAD.tolist())
    assert fit.weighted


def _same_fit(a, b) -> None:
    assert np.array_equal(a.r, b.r) and np.array_equal(a.cov, b.cov, equal_nan=True)
    assert a.robust.downweighted == b.robust.downweighted
    assert a.robust.scales == b.robust.scales and a.robust.iterations == b.robust.iterations
    assert [k.sigma for k in a.kinds] == [k.sigma for k in b.kinds]


def test_huber_streamed_in_chunks_is_the_in_memory_fit(robot):
    """The IRLS over a data set read in chunks (each step re-reads them; the residual sizes
    spilled, their median exact) gives the fit of the same data in memory, bit for bit — the
    default fit of torques without approach sides (robust="auto") and an explicit robust CoP
    fit; and the in-memory IRLS around a fitter (``robust.huber``) gives it too."""
    from sescid.estimation.data.sources import HeldSource
    from sescid.estimation.solvers.robust import huber as huber_in_memory
    from sescid.estimation.solvers.runs import run_method

    rng = np.random.default_rng(21)
    n = 1500
    q = random_poses(robot, n, 30.0, 22)
    names = tuple(robot.joint_names)
    tau = robot.torques(q, joints=names) + rng.normal(0, 0.05, (n, len(names)))
    tau += rng.uniform(-0.1, 0.1, tau.shape)  # static friction: bounded errors
    tau[::50, 3] += 2.0  # outlying readings: the default (robust="auto") turns Huber on
    cop = robot.cop(q) + rng.normal(0, SIGMA, (n, 2))
    cop[::50] += 0.03
    whole = Measurements(q=q, cop=cop, tau=tau, tau_joints=names)
    chunks = [whole.take(slice(s, s + 400)) for s in range(0, n, 400)]
    for kw in ({"kinds": ("tau",)}, {"kinds": ("cop",), "robust": True}, {}):
        for method in ("auto", "ls"):
            mem = identify(robot, whole, method=method, **kw)
            streamed = identify(robot, iter(chunks), method=method, **kw)
            assert mem.robust is not None and mem.robust.downweighted
            _same_fit(mem, streamed)
    opts = IdentifyOptions()
    data = [whole.only(("tau",)).checked(robot)]

    def run(d, weighted):
        o = IdentifyOptions(weighted=weighted)
        return run_method(robot, LeastSquaresOptions(), o, [HeldSource(m) for m in d], d,
                          compare=False)  # fmt: skip

    in_memory = huber_in_memory(run, data, k=opts.huber_k)
    shared = identify(robot, whole, method="ls", kinds=("tau",), tau_noise_model="shared")
    _same_fit(shared, in_memory)
