"""Poses on both feet, checked by computations that are not sescid's: Pinocchio's kinematics
(both soles flat on the floor, the CoM over the feet), scipy's convex hull, coal's collision
geometry (iCub's meshes above the floor), MuJoCo's contact forces (the poses stand on the
physics bench, the pads' CoP is the CoM's projection) and ``sescid measure`` on its log."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from click.testing import CliRunner
from oracle import PinOracle
from refs import PinGeometry, erd
from scipy.spatial import ConvexHull, Delaunay

import sescid
from sescid import planning as design
from sescid.cli import cli
from sescid.errors import OptionError, SescidError
from sescid.planning.feasibility.closure import (
    CLOSE_TOL,
    Loop,
    close_chain,
    free_sole_frame,
    loop_of,
    placements,
)
from sescid.planning.feasibility.double import PLACE_SHARE, PLACE_YAW, hull_margin
from sescid.robot import Robot
from sescid.tables import read_table


@pytest.fixture(scope="module")
def op2_double(op2):
    """120 OP2 candidates on both feet (compliant margin)."""
    opt = design.CandidateOptions(compliance=design.compliance(op2))
    return design.double_candidates(op2, 120, seed=1, options=opt)


def _pin_frames(oracle: PinOracle, q, frames):
    """Per pose, each frame's (rotation, translation) in the oracle's support frame."""
    import pinocchio as pin

    out = []
    for qk in q:
        pin.framesForwardKinematics(oracle.model, oracle.data, oracle.q_pin(qk))
        sup = oracle.data.oMf[oracle.frame]
        out.append([sup.actInv(oracle.data.oMf[oracle.model.getFrameId(f)]) for f in frames])
    return out


def test_op2_soles_flat_and_cop_over_both_feet(op2, op2_double):
    """Pinocchio puts l_sole flat on r_sole's floor (z up, height 0, to 1e-9) within the
    placement range; the candidates' CoP is Pinocchio's CoM x/y, inside the hull of both
    feet's ±23 mm CoP boxes (scipy); the legs stay within the limits."""
    c = op2_double
    assert c.mount == "double" and len(c.q) == 120
    oracle = PinOracle(op2.model_path, "r_sole", op2.joint_names)
    lim = design.sampling_limits(op2)
    assert np.all((c.q >= lim[:, 0]) & (c.q <= lim[:, 1]))
    zero = _pin_frames(oracle, np.zeros((1, op2.nq)), ["l_sole"])[0][0]
    half = design.cop_half_extents(op2)
    box = np.array([[1, 1], [1, -1], [-1, 1], [-1, -1]]) * half
    com = oracle.com(c.q)
    np.testing.assert_allclose(c.cop, com[:, :2], atol=1e-12)
    for k, (sole,) in enumerate(_pin_frames(oracle, c.q, ["l_sole"])):
        rot, pos = sole.rotation, sole.translation
        assert abs(rot[2, 2] - 1.0) < 1e-12 and np.abs(rot[2, :2]).max() < 1e-9
        assert abs(pos[2]) < 1e-9
        d = pos[:2] - zero.translation[:2]
        assert abs(d[0]) <= PLACE_SHARE[0] * 0.105 + 1e-9 and abs(d[1]) <= PLACE_SHARE[1] * 0.066
        assert abs(np.arctan2(rot[1, 0], rot[0, 0])) <= PLACE_YAW + 1e-9
        feet = np.vstack([box, pos[:2] + box @ rot[:2, :2].T])
        assert Delaunay(feet[ConvexHull(feet).vertices]).find_simplex(com[k, :2]) >= 0


def _yaw_rotations(cos: np.ndarray, sin: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations about z of cosine ``cos`` (n,) and sine ``sin`` (n,)."""
    out = np.zeros((len(cos), 3, 3))
    out[:, 0, 0], out[:, 0, 1], out[:, 1, 0], out[:, 1, 1] = cos, -sin, sin, cos
    out[:, 2, 2] = 1.0
    return out


def _placement_error(robot: Robot, loop: Loop, q: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(n, 6) the free sole frame's position error [m] and rotation vector [rad] (axis × angle
    of R R_targetᵀ) from its placement ``target`` (n, 4: x, y [m], cos ψ, sin ψ) on the floor."""
    rot, pos = free_sole_frame(robot, loop, q)
    want = np.stack([target[:, 0], target[:, 1], np.full(len(target), loop.floor)], axis=1)
    turn = rot @ _yaw_rotations(target[:, 2], target[:, 3]).transpose(0, 2, 1)
    v = np.stack([turn[:, 2, 1] - turn[:, 1, 2], turn[:, 0, 2] - turn[:, 2, 0],
                  turn[:, 1, 0] - turn[:, 0, 1]], axis=1)  # fmt: skip
    sin = np.linalg.norm(v, axis=1) / 2
    angle = np.arctan2(sin, (np.trace(turn, axis1=1, axis2=2) - 1.0) / 2)
    scale = np.where(sin > 0, angle / np.where(sin > 0, 2 * sin, 1.0), 0.5)
    return np.concatenate([pos - want, v * scale[:, None]], axis=1)


def test_close_chain_converges_and_reports_failures(op2):
    """Newton's method closes the loop to CLOSE_TOL from the drawn legs; a placement out of
    reach (1 m away) is reported as not closed, never as closed."""
    loop = loop_of(op2)
    rng = np.random.default_rng(0)
    lim = design.sampling_limits(op2)
    q = (rng.random((500, op2.nq)) * (lim[:, 1] - lim[:, 0]) + lim[:, 0]) * 0.5
    target = placements(loop, 500, rng, np.array([0.05, 0.03, 0.2]))
    target[:5, 0] += 1.0
    out, closed = close_chain(op2, loop, q, target)
    assert not closed[:5].any() and closed[5:].mean() > 0.95
    err = _placement_error(op2, loop, out[closed], target[closed])
    assert np.abs(err).max() <= 2 * CLOSE_TOL
    others = np.setdiff1d(np.arange(op2.nq), loop.cols)
    np.testing.assert_array_equal(out[:, others], q[:, others])  # arms and head as drawn


def test_hull_margin_against_scipy():
    """Inside distance to the convex hull of 8 points (two turned rectangles) against scipy's
    hull equations (outward normals, offsets)."""
    rng = np.random.default_rng(3)
    box = np.array([[0.05, 0.03], [0.05, -0.03], [-0.05, 0.03], [-0.05, -0.03]])
    for _ in range(20):
        a = rng.uniform(-0.3, 0.3)
        turn = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
        pts = np.vstack([box, box @ turn.T + rng.uniform(-0.1, 0.1, 2) + [0, 0.1]])
        x = rng.uniform(-0.12, 0.22, (50, 2))
        hull = ConvexHull(pts)
        ref = -(x @ hull.equations[:, :2].T + hull.equations[:, 2]).max(axis=1)
        got = hull_margin(np.broadcast_to(pts, (50, 8, 2)), x)
        np.testing.assert_allclose(got, ref, atol=1e-12)


def test_icub_free_foot_flat_and_geometry_above_the_floor():
    """iCub (example-robot-data, its soles derived from collision meshes): on both feet the
    free foot is only turned about the vertical from its zero-pose orientation (Pinocchio), its
    collision mesh's lowest vertex (coal) at one height in every pose (to 1e-9 m), the floor's
    to the 5 µm by which coal's and sescid's mesh loaders differ (3 µm on these feet); every
    other collision mesh above the floor."""
    path = erd("icub_description/robots/icub.urdf")
    robot = sescid.load_robot(path, "r_sole")
    cand = design.double_candidates(robot, 12, seed=0)
    geo = PinGeometry(path, robot)
    frames = ["l_sole", robot.free_sole.link]
    zero = _pin_frames(geo.oracle, np.zeros((1, robot.nq)), frames)[0]
    for pose in _pin_frames(geo.oracle, cand.q, frames):
        for now, then in zip(pose, zero, strict=True):
            turn = now.rotation @ then.rotation.T  # a turn about the vertical only
            assert abs(turn[2, 2] - 1.0) < 1e-12 and np.abs(turn[2, :2]).max() < 1e-9
    free = set(robot.model.bodies[robot.free_sole.body].links)
    feet = free | set(robot.model.bodies[0].links)
    low, per = geo.lowest(cand.q, feet)
    assert np.all(low > -1e-9)
    foot = np.min([v for k, v in per.items() if k in free], axis=0)
    assert np.ptp(foot) < 1e-9 and abs(foot[0] - robot.floor) < 5e-6


def test_a_robot_without_a_free_foot_is_told(op2):
    """Held by its torso the OP2 has no sole to close a loop onto: one clear error; torques on
    both feet are refused (they depend on the load's split)."""
    torso = op2.at("MP_BODY")
    with pytest.raises(SescidError):
        design.double_candidates(torso, 5)
    with pytest.raises(OptionError, match="split"):
        design.resolve_mount(op2, "double", "tau")


def test_poses_on_both_feet_cli(tmp_path):
    """`sescid poses --mount double` writes support = double and the model CoP (the CoM's
    projection) in the support foot's frame; `--stances double` is the same plan."""
    out = tmp_path / "d.csv"
    args = ["poses", "--count", "22", "--candidates", "300", "--test-poses", "100"]
    res = CliRunner().invoke(cli, [*args, "--mount", "double", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "stability: CoP inside both feet's" in res.output
    t = read_table(out)
    assert set(t.text["support"]) == {"double"}
    op2 = sescid.load_robot("op2")
    q = np.column_stack([t.columns[j] for j in op2.joint_names])
    model_cop = np.column_stack([t.columns["cop_x_model"], t.columns["cop_y_model"]])
    np.testing.assert_allclose(model_cop, op2.com(q)[:, :2], atol=1e-12)
    out2 = tmp_path / "d2.csv"
    res = CliRunner().invoke(cli, [*args, "--stances", "double", "--out", str(out2)])
    assert res.exit_code == 0, res.output
    assert out2.read_bytes() == out.read_bytes()


def test_double_support_stands_on_the_mujoco_bench(op2, op2_double):
    """Planned poses on both feet stand on the physics bench (none skipped) with both boards
    loaded; the pads' CoP (MuJoCo's contact forces) is MuJoCo's CoM projected along gravity
    (its subtree CoM, not sescid's) to 50 µm; `measure` gives that CoP in r_sole's frame from
    both feet's pads to within the OP2 encoders' tick (0.088°) over the legs."""
    pytest.importorskip("mujoco")
    from sescid.bench import ExperimentConfig
    from sescid.bench.mujoco import MujocoBenchConfig, run_mujoco_experiment
    from sescid.sensors import load_sensors, measure, read_log, table_from_columns

    sensors = load_sensors(None, op2.profile)
    config = ExperimentConfig(backlash_deg=0.0, extra_mass_fraction=0.0, extra=(), fsr_noise=0.0,
                              fsr_bias=0.0, readback_jitter_ticks=0.0)  # fmt: skip
    bench = MujocoBenchConfig(double_support=True)
    q = op2_double.q[:8]
    ex = run_mujoco_experiment(op2, q, sensors, samples=10, config=config, bench=bench)
    assert not ex.skipped
    assert np.all(ex.columns["l_fsr1"] + ex.columns["l_fsr4"] > 0)
    assert np.all(ex.columns["r_fsr1"] + ex.columns["r_fsr4"] > 0)
    ph = ex.truth.physics
    com = ph.com_sole
    g = -np.array(ex.truth.grav)
    proj = com[:, :2] - com[:, 2:3] * g[:, :2] / g[:, 2:3]
    assert np.abs(ph.cop_pads - proj).max() < 5e-5
    meas = measure(op2, read_log(op2, table_from_columns(ex.columns), sensors), sensors, 5)
    assert len(meas.pose) == len(q)
    assert np.abs(meas.data.cop - ph.cop_pads).max() < 5e-4


def test_check_mujoco_on_both_feet(tmp_path):
    """`--mount double --check mujoco` runs the chosen poses on both feet on the bench."""
    pytest.importorskip("mujoco")
    out = tmp_path / "d.csv"
    args = ["poses", "--mount", "double", "--count", "22", "--candidates", "200",
            "--test-poses", "50", "--check", "mujoco", "--out", str(out)]  # fmt: skip
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    assert "MuJoCo bench check: " in res.output and "poses simulated" in res.output


def test_double_support_measured_and_fitted(op2):
    """Planned poses on both feet on the kinematic bench (the real OP2: unmodelled mass, ±1°
    play, noisy pads on both feet): `measure` combines both feet's pads into the whole robot's
    CoP in r_sole's frame, and the fit of those rows (support "double") predicts the true CoP
    of fresh poses on both feet better than the CAD model does."""
    from sescid import identify
    from sescid.bench import ExperimentConfig, run_experiment
    from sescid.bench.real_robot import real_robot
    from sescid.sensors import load_sensors, measure, read_log, table_from_columns

    sensors = load_sensors(None, op2.profile)
    plan = design.plan_poses(op2, 40, mount="double", n_candidates=600, n_test=200, seed=2)
    config = ExperimentConfig(double_support=True)
    ex = run_experiment(op2, plan.q, sensors, samples=20, seed=0, config=config)
    assert len(ex.skipped) <= 2
    meas = measure(op2, read_log(op2, table_from_columns(ex.columns), sensors), sensors)
    data = dataclasses.replace(meas.data, support="double")
    fit = identify(op2, data, method="ls", weighted=True)
    fresh = plan.candidates.q[-150:]
    r_true, _, _ = real_robot(op2, config)
    truth = op2.cop(fresh, r_true)
    err_fit = np.sqrt(np.mean(np.sum((fit.predict_cop(fresh) - truth) ** 2, axis=1)))
    err_cad = np.sqrt(np.mean(np.sum((op2.cop(fresh) - truth) ** 2, axis=1)))
    assert err_fit < 0.5 * err_cad
