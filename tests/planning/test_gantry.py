"""A robot held in a gantry: the mount from the support, the floor under a hanging robot, and
planned poses checked with Pinocchio's kinematics and coal (not sescid's): every collision shape
(boxes, meshes) above the floor by the clearance, and no two of the planner's self-collision
capsules in contact (the pairs it checks) — on the OP2 held by its torso and on Unitree's G1
(example-robot-data) by its pelvis."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from refs import PinGeometry, erd, write_humanoid

import sescid
from sescid import planning as design
from sescid.cli import cli
from sescid.errors import OptionError, SescidError
from sescid.planning.feasibility.gantry import GANTRY_LIFT, gantry_floor, standing_height
from sescid.planning.feasibility.stability import DEFAULT_CLEARANCE
from sescid.tables import read_table

CLEARANCE = 0.005


def _capsule_contacts(geo: PinGeometry, robot, q: np.ndarray) -> list[tuple[str, str]]:
    """Body pairs whose self-collision capsules (``collision_capsules``: the planner's cover of
    the collision shapes) touch at some pose of ``q``: each capsule placed by Pinocchio's link
    placements, the distance of every checked pair by coal."""
    import coal

    pin, o = geo.pin, geo.oracle
    cap = design.collision_capsules(robot)
    names = robot.body_names
    frames = [o.model.getFrameId(names[b]) for b in cap.body]
    length = np.linalg.norm(cap.p1 - cap.p0, axis=1)
    shapes = [coal.Capsule(float(r), float(h)) for r, h in zip(cap.radius, length, strict=True)]
    req = coal.DistanceRequest()
    out = set()
    for qk in q:
        pin.framesForwardKinematics(o.model, o.data, o.q_pin(qk))
        sup = o.data.oMf[o.frame]
        tfs = []
        for c, f in enumerate(frames):
            m = o.data.oMf[f]
            a, b = m.act(cap.p0[c]), m.act(cap.p1[c])
            a, b = sup.actInv(a), sup.actInv(b)
            axis = (b - a) / length[c] if length[c] > 0 else np.array([0.0, 0.0, 1.0])
            rot = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), axis).matrix()
            tfs.append(coal.Transform3s(rot, (a + b) / 2))
        for i, j in cap.pairs:
            res = coal.DistanceResult()
            if coal.distance(shapes[i], tfs[i], shapes[j], tfs[j], req, res) <= 0:
                out.add((names[cap.body[i]], names[cap.body[j]]))
    return sorted(out)


def _check_held_plan(path, robot, plan, hang_height: float | None):
    """The plan's poses by Pinocchio + coal: above the floor by the clearance, no contact."""
    geo = PinGeometry(path, robot)
    held = set(robot.model.bodies[0].links)
    low0, _ = geo.lowest(np.zeros((1, robot.nq)), held)
    standing = -float(low0[0])  # the held link's height when the robot stands at q = 0
    floor = -(standing + GANTRY_LIFT if hang_height is None else hang_height)
    low, _ = geo.lowest(plan.q, held)
    assert np.all(low > floor + CLEARANCE)
    assert _capsule_contacts(geo, robot, plan.q) == []
    return standing, low - floor


def test_the_mount_follows_from_the_support(op2):
    assert not design.held_trunk(op2)
    torso = sescid.load_robot("op2", support=op2.model.model_root)
    assert design.held_trunk(torso) and design.resolve_mount(torso, None, "tau") == "gantry"
    arm = sescid.load_robot("op2", support="MP_ARM_LOW_L")  # a limb's end: not a trunk
    assert design.resolve_mount(arm, None, "tau") == "stand"
    with pytest.raises(OptionError, match="--kinds tau"):
        design.resolve_mount(torso, None, "cop")
    with pytest.raises(OptionError, match="--kinds tau"):
        design.resolve_mount(op2, "gantry", "both")


def test_op2_held_by_its_torso_clears_the_floor_and_itself(op2):
    """Hung 15 mm above its standing height, the floor rejects poses (a foot pitched down, a
    leg swung); the kept ones clear it by the clearance and touch nothing, by coal."""
    torso = op2.model.model_root
    robot = sescid.load_robot("op2", support=torso)
    standing = standing_height(robot)
    hang = standing + 0.015
    plan = design.plan_poses(robot, 25, kinds="tau", seed=1, n_candidates=300, n_test=100,
                             hang_height=hang)  # fmt: skip
    assert plan.mount == "gantry" and np.isnan(plan.cop).all()
    cand = plan.candidates
    assert cand.mount == "gantry" and cand.n_ground < cand.n_sampled  # the floor did reject
    ref_standing, gap = _check_held_plan(robot.model_path, robot, plan, hang)
    assert standing == pytest.approx(ref_standing, abs=1e-9)
    assert gap.min() < 0.015  # some poses reach closer to the floor than at the zero pose
    # the reference finds the contacts of uniform draws that sescid rejects (it can fail)
    lim = design.sampling_limits(robot)
    q = lim[:, 0] + np.ptp(lim, axis=1) * np.random.default_rng(3).random((40, robot.nq))
    rot, org = robot.forward(q)
    hit = ~design.collision_free_mask(design.collision_capsules(robot), rot, org)
    assert hit.any() and _capsule_contacts(PinGeometry(robot.model_path, robot), robot, q[hit])
    assert plan.expected_error < plan.random_error


def test_g1_held_by_its_pelvis_clears_the_floor_and_itself():
    """Unitree G1 (29 joints, mesh collision shapes): uniform draws almost always cross limbs,
    so the held search moves draws near accepted poses; every kept pose clears the default
    floor (standing height + 50 mm) and touches nothing, by coal on the meshes."""
    path = erd("g1_description/urdf/g1_29dof_rev_1_0.urdf")
    robot = sescid.load_robot(path, "pelvis")
    plan = design.plan_poses(robot, 30, kinds="tau", seed=0, n_candidates=300, n_test=100)
    assert plan.mount == "gantry" and plan.candidates.sampler == "uniform+adjusted"
    _check_held_plan(path, robot, plan, None)
    assert plan.expected_error < plan.random_error


def test_a_hang_height_below_the_standing_height_is_refused(op2):
    robot = sescid.load_robot("op2", support=op2.model.model_root)
    with pytest.raises(SescidError, match="touches it at the zero pose"):
        design.plan_poses(robot, 25, kinds="tau", hang_height=0.2, n_candidates=100)
    with pytest.raises(OptionError, match="hang height goes with a robot held"):
        design.plan_poses(op2, 25, kinds="tau", hang_height=1.0, n_candidates=100)


def test_cli_gantry_writes_no_cop(tmp_path, op2):
    out = tmp_path / "g.csv"
    base = ["poses", "--support", op2.model.model_root, "--count", "20", "--candidates", "200",
            "--test-poses", "50", "--seed", "0"]  # fmt: skip
    res = CliRunner().invoke(cli, [*base, "--kinds", "tau", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "(gantry)" in res.output and "standing height" in res.output
    cols = read_table(out).columns
    assert "cop_x_model" not in cols and "cop_x" not in cols and len(cols["pose"]) == 20
    bad = CliRunner().invoke(cli, [*base, "--out", str(tmp_path / "b.csv")])  # --kinds cop
    assert bad.exit_code == 2 and "--kinds tau" in bad.output
    assert not (tmp_path / "b.csv").exists()


def test_a_gantry_needs_no_sole(tmp_path):
    """Held by a thigh (a capsule: no flat face, no sole to stand on): the CLI and the session's
    design plan held poses, each clear of the floor; standing on it is refused, naming why."""
    from sescid.session.design import SessionDesign
    from sescid.session.records import SessionOptions

    path = write_humanoid(tmp_path)
    robot = sescid.load_robot(path, "legA_thigh")
    with pytest.raises(SescidError, match="no sole to stand on"):
        design.cop_half_extents(robot)
    out = tmp_path / "g.csv"
    res = CliRunner().invoke(cli, ["poses", "--robot", str(path), "--support", "legA_thigh",
                                   "--mount", "gantry", "--kinds", "tau", "--count", "20",
                                   "--candidates", "200", "--test-poses", "50",
                                   "--out", str(out)])  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "held by legA_thigh (gantry)" in res.output and "stability" not in res.output
    q = np.column_stack([read_table(out).columns[j] for j in robot.joint_names])
    rot, org = robot.forward(q)
    floor, _ = gantry_floor(robot, None, DEFAULT_CLEARANCE)
    from sescid.planning.feasibility.ground import lowest_heights

    assert np.all(lowest_heights(robot, rot, org, exempt=False) > floor + DEFAULT_CLEARANCE)
    plan = SessionDesign(robot, SessionOptions(n_candidates=150, mount="gantry", kinds="tau"))
    assert plan.mount == "gantry" and plan.half is None and len(plan.cand.q) == 150


@pytest.mark.parametrize(("quat", "tilt"), [("1 0 0 0", None), ("0.9996573 0.0261769 0 0", None),
                                            ("0.7071068 0.7071068 0 0", 90),
                                            ("0.9238795 0 0.3826834 0", 45)])  # fmt: skip
def test_a_held_frame_not_upright_is_said(tmp_path, quat, tilt):
    """The gantry holds its frame with z vertical: a root body turned in the model's world (the
    CMU humanoid's is y-up) is named with its tilt (90°: z along −y; 45° about y); upright or
    within 5° (3° here), nothing is said."""
    pytest.importorskip("mujoco")
    from humanoid_mjcf_gen import write_humanoid as write_split_humanoid

    from sescid.planning.feasibility.gantry import held_tilt

    main = write_split_humanoid(tmp_path / "h")
    part = main.parent / "parts" / "robot.xml"
    at = 'name="pelvis" pos="0 0 0.7"'
    part.write_text(part.read_text().replace(at, f'{at} quat="{quat}"'))
    for held in ("pelvis", "torso"):
        note = held_tilt(sescid.load_robot(main, held))
        if tilt is None:
            assert note is None
        else:
            assert f"the held frame '{held}' is tilted {tilt}° from upright" in note
    if tilt == 90:
        assert "z axis along (+0.00, -1.00, +0.00)" in note
