"""When uniform draws are (almost) never stable, the planner searches: draws moved over the foot
by the CoM Jacobian, then every check. Checked on iCub (URDF: 0 of 10⁶ uniform draws pass) and
on a synthetic humanoid with a small foot and a heavy torso far ahead (MJCF, feet-only
collision), against Pinocchio and MuJoCo; a robot that cannot stand on one foot is told so."""

from __future__ import annotations

import numpy as np
import pytest
from humanoid_gen import H1_STYLE, STUCK
from refs import erd, mj_body_lowest, mj_geom_corners, write_humanoid
from scipy.optimize import minimize

import sescid
from sescid import planning as design
from sescid.errors import SescidError
from sescid.planning.feasibility.candidates import SWITCH_AFTER
from sescid.planning.feasibility.com import com_state
from sescid.planning.feasibility.compliance import compliant_margin
from sescid.robot import Robot
from sescid.robots import RobotProfile


def test_icub_uniform_finds_nothing_the_search_finds_poses():
    """iCub on r_sole: no uniform draw of 10⁶ passes the checks; the planner's search gives 40
    poses whose CoP (Pinocchio) is in the box and whose compliant margin is positive."""
    from oracle import PinOracle

    robot = sescid.load_robot(erd("icub_description/robots/icub.urdf"), "r_sole")
    model = design.compliance(robot)
    with pytest.raises(SescidError, match=r"only 0 of 1000000 uniform poses are accepted"):
        uniform = design.CandidateOptions(sampler="uniform", compliance=model, max_sampled=10**6)
        design.candidates(robot, 5, 0, uniform)
    plan = sescid.plan_poses(robot, count=40, n_candidates=300, n_test=80, seed=1)
    assert plan.candidates.sampler == "adjusted"
    cop = PinOracle(robot.model_path, "r_sole", robot.joint_names).com(plan.q)[:, :2]
    half = plan.candidates.half_extents
    assert np.all(np.abs(cop - robot.sole_centre) < half)
    assert np.all(compliant_margin(model, com_state(robot, plan.q)) > 0)


@pytest.fixture(scope="module")
def h1_style(tmp_path_factory):
    path = write_humanoid(tmp_path_factory.mktemp("h1"), H1_STYLE, "h1_style")
    return path, sescid.load_robot(path, "legA_sole")


def test_synthetic_h1_style_uniform_fails(h1_style):
    """A small foot (80 × 40 mm) and a 35 kg torso 0.3 m ahead: at most 5 in 10⁴ uniform draws
    pass; the uniform-only sampler asked for 1000 within 10⁶ draws gives up and points to the
    search."""
    _, robot = h1_style
    with pytest.raises(SescidError, match="adjusted sampler") as exc:
        uniform = design.CandidateOptions(
            sampler="uniform", compliance=design.compliance(robot), max_sampled=10**6
        )
        design.candidates(robot, 1000, 0, uniform)
    assert int(str(exc.value).split()[1]) <= 500


def test_synthetic_h1_style_search_poses_checked_by_mujoco(h1_style):
    """The search's poses, checked on MuJoCo's model: CoP in the box, every body above the
    floor, the free foot's sole ≥ the clearance above it."""
    from mjcf_gen import mujoco_com

    path, robot = h1_style
    plan = sescid.plan_poses(robot, count=22, n_candidates=250, n_test=60, seed=0)
    names = robot.joint_names
    cop = mujoco_com(path, "legA_sole", names, plan.q)[:, :2]
    assert np.all(np.abs(cop - robot.sole_centre) < plan.candidates.half_extents)
    per = mj_body_lowest(path, "legA_sole", names, plan.q, skip_body="legA_foot")
    assert np.min(list(per.values())) > robot.floor
    sole = mj_geom_corners(path, "legA_sole", names, plan.q, "legB_foot_box")[:, ::2, 2]
    assert np.all(sole > robot.floor + 0.005)


def test_uniform_profile_hands_over_to_the_search(h1_style):
    """A profile that asks for uniform draws and a ±5 mm CoP box: too few pass, the search takes
    over (said)."""
    path, robot = h1_style
    prof = RobotProfile(name="h1_style", pose_sampler="uniform", cop_box=0.005)
    uni = Robot(robot.model, str(path), prof)
    cand = design.candidates(uni, 50, 0, design.CandidateOptions(compliance=design.compliance(uni)))
    assert cand.sampler in ("uniform+adjusted", "adjusted") and len(cand.q) == 50
    assert cand.n_sampled >= SWITCH_AFTER
    assert "moved over the foot by the CoM Jacobian" in cand.summary()


def test_robot_that_cannot_stand_on_one_foot_is_told_so(tmp_path):
    """No hip or ankle roll and wide hips: the CoM cannot reach the foot (an optimiser over the
    joint limits confirms it); the error says so and how near the search came."""
    path = write_humanoid(tmp_path, STUCK, "stuck")
    robot = sescid.load_robot(path, "legA_sole")
    half, centre = design.cop_half_extents(robot), robot.sole_centre
    lim = design.sampling_limits(robot)

    def box_distance(x):
        return float(np.max(np.abs(robot.cop(x[None])[0] - centre) / half))

    rng = np.random.default_rng(0)
    best = min(
        minimize(box_distance, lim[:, 0] + np.ptp(lim, axis=1) * rng.random(robot.nq),
                 bounds=lim, method="Powell").fun
        for _ in range(4)
    )  # fmt: skip
    assert best > 1.0  # even an optimiser cannot put the CoP in the box
    with pytest.raises(SescidError, match="cannot put its CoP in the stability box") as exc:
        sescid.plan_poses(robot, count=22, n_candidates=200, n_test=50, seed=0)
    near = float(str(exc.value).split("no nearer than ")[1].split(" times")[0])
    assert near >= best - 1e-6
    assert "sampling range" not in str(exc.value)


def test_a_support_without_a_sole_is_named(tmp_path):
    """A shank as the support (level frame, no flat face under it): one error naming the
    support and the fix, not a zero-size box searched to infinity."""
    robot = sescid.load_robot(str(write_humanoid(tmp_path)), "legA_shank")
    with pytest.raises(SescidError, match=r"'legA_shank' has no sole to stand on .* sole frame"):
        sescid.plan_poses(robot, count=22, seed=0)
