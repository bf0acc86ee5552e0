"""Any robot: soles from geometry, honest pose checks, simulate/export on generated bipeds and
the public humanoids of example-robot-data (CoM against Pinocchio)."""

from __future__ import annotations

import importlib.metadata
import math
from pathlib import Path

import numpy as np
import pytest

import sescid
from sescid.model.meshes import resolve_mesh
from sescid.planning import collision_capsules, collision_free_mask
from sescid.planning.feasibility.adjust import _subtrees, adjust_support_leg, support_chain
from sescid.planning.feasibility.broadphase import collision_free_mask_broad
from sescid.planning.feasibility.collision import mesh_capsules, segment_distance
from sescid.planning.feasibility.ground import ground_checks

ANKLE = 0.06  #: m, ankle frame above the foot box's bottom in the generated biped
FOOT = (0.16, 0.08, 0.03)  #: m, foot box


def biped_urdf(rng: np.random.Generator) -> str:
    """A small biped: pelvis, two 5-joint legs with box feet below the ankle frames, a torso
    with two 2-joint arms; random masses and CoMs."""

    def inertial():
        m = rng.uniform(0.3, 3.0)
        c = " ".join(f"{x:.6f}" for x in rng.uniform(-0.03, 0.03, 3))
        return (
            f'<inertial><origin xyz="{c}"/><mass value="{m:.6f}"/>'
            '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
        )

    def cyl(length):
        return (
            f'<collision><origin xyz="0 0 {-length / 2}"/><geometry><cylinder radius="0.03" '
            f'length="{length * 0.7:.4f}"/></geometry></collision>'
        )

    links = [f'<link name="pelvis">{inertial()}</link>']
    joints = []

    def rev(name, parent, child, xyz, axis, lo=-0.6, hi=0.6):
        joints.append(
            f'<joint name="{name}" type="revolute"><parent link="{parent}"/>'
            f'<child link="{child}"/><origin xyz="{xyz}"/><axis xyz="{axis}"/>'
            f'<limit lower="{lo}" upper="{hi}" effort="1" velocity="1"/></joint>'
        )

    for side, y in (("r", -0.08), ("l", 0.08)):
        chain = [
            ("hip_roll", f"0 {y} -0.05", "1 0 0", ""),
            ("hip_pitch", "0 0 0", "0 1 0", cyl(0.3)),
            ("knee", "0 0 -0.3", "0 1 0", cyl(0.3)),
            ("ankle_pitch", "0 0 -0.3", "0 1 0", ""),
        ]
        parent = "pelvis"
        for jn, xyz, axis, geom in chain:
            child = f"{side}_{jn}_link"
            links.append(f'<link name="{child}">{inertial()}{geom}</link>')
            rev(f"{side}_{jn}", parent, child, xyz, axis)
            parent = child
        foot = f"{side}_foot"
        box = (
            f'<collision><origin xyz="0.02 0 {-ANKLE + FOOT[2] / 2}"/><geometry><box size="'
            f'{FOOT[0]} {FOOT[1]} {FOOT[2]}"/></geometry></collision>'
        )
        links.append(f'<link name="{foot}">{inertial()}{box}</link>')
        rev(f"{side}_ankle_roll", parent, foot, "0 0 0", "1 0 0", -0.4, 0.4)
    links.append(
        f'<link name="torso">{inertial()}<collision><origin xyz="0 0 0.15"/><geometry>'
        '<box size="0.12 0.2 0.25"/></geometry></collision></link>'
    )
    rev("waist", "pelvis", "torso", "0 0 0.05", "0 0 1")
    for side, y in (("r", -0.14), ("l", 0.14)):
        links.append(f'<link name="{side}_upper_arm">{inertial()}{cyl(0.2)}</link>')
        links.append(f'<link name="{side}_fore_arm">{inertial()}{cyl(0.2)}</link>')
        rev(f"{side}_shoulder", "torso", f"{side}_upper_arm", f"0 {y} 0.22", "0 1 0", -1.5, 1.5)
        rev(f"{side}_elbow", f"{side}_upper_arm", f"{side}_fore_arm", "0 0 -0.2", "0 1 0", 0, 1.5)
    return '<?xml version="1.0"?><robot name="biped">' + "".join(links + joints) + "</robot>"


@pytest.fixture(scope="module")
def biped(tmp_path_factory):
    """A generated biped URDF standing on its right ankle frame (no sole link)."""
    path = tmp_path_factory.mktemp("biped") / "biped.urdf"
    path.write_text(biped_urdf(np.random.default_rng(3)))
    return sescid.load_robot(path, "r_foot")


def test_sole_derived_from_box_foot(biped):
    """A foot frame above a box foot: floor, sole size and centre are the box's bottom face."""
    sole = biped.sole
    assert sole is not None and sole.derived
    assert biped.floor == pytest.approx(-ANKLE, abs=1e-12)
    np.testing.assert_allclose(sole.size, FOOT[:2], atol=1e-12)
    np.testing.assert_allclose(biped.sole_centre, [0.02, 0.0], atol=1e-12)
    free = biped.free_sole
    assert free is not None and free.link == "l_foot"
    rot, org = biped.link_poses(np.zeros((1, biped.nq)), "l_foot")
    corners = org[0] + free.corners @ np.eye(3).T  # l_foot's body frame is its link frame
    np.testing.assert_allclose(corners[:, 2], -ANKLE, atol=1e-12)


def test_stability_box_scaled_to_the_sole(biped):
    """Without a profile CoP box the default box is half the sole's half-sizes, on its centre."""
    from sescid.planning import cop_half_extents

    np.testing.assert_allclose(cop_half_extents(biped), np.array(FOOT[:2]) / 4, atol=1e-12)
    assert np.all(cop_half_extents(sescid.load_robot("op2")) == 0.023)


def test_poses_on_biped_are_honest(biped):
    """Planned poses: CoP inside the box, free sole corners ≥ clearance above the floor, every
    other body's collision capsules above the floor (recomputed here)."""
    plan = sescid.plan_poses(biped, count=20, n_candidates=300, n_test=100, seed=1)
    cand = plan.candidates
    assert cand.sampler == "adjusted"
    cop = biped.cop(plan.q)
    assert np.all(np.abs(cop - biped.sole_centre) < cand.half_extents)
    rot, org = biped.link_poses(plan.q, "l_foot")
    corners = org[:, None, :] + np.einsum("nij,cj->nci", rot, biped.free_sole.corners)
    assert np.all(corners[..., 2] > biped.floor + 0.005)
    cap = collision_capsules(biped)
    r, o = biped.forward(plan.q)
    w0, w1 = cap.world(r, o)
    low = np.minimum(w0[..., 2], w1[..., 2]) - cap.radius
    assert np.all(low[:, cap.body != 0] > biped.floor)


def test_adjusted_draws_mostly_stable(biped):
    """Moving the supporting leg puts most draws' CoP in the box (uniform draws: far fewer)."""
    from sescid.planning import cop_half_extents, sampling_limits

    rng = np.random.default_rng(0)
    lim = sampling_limits(biped)
    q = lim[:, 0] + (lim[:, 1] - lim[:, 0]) * rng.random((2000, biped.nq))
    half, c = cop_half_extents(biped), biped.sole_centre
    before = np.mean(np.all(np.abs(biped.cop(q) - c) < half, axis=1))
    q2 = adjust_support_leg(biped, q, lim, half, c, rng)
    after = np.mean(np.all(np.abs(biped.cop(q2) - c) < half, axis=1))
    assert after > 0.8 and after > 2 * before
    assert np.all((q2 >= lim[:, 0]) & (q2 <= lim[:, 1]))


def test_support_leg_jacobian_matches_finite_differences(biped):
    """Closed-form ∂CoM/∂q of the supporting leg equals central differences."""
    cols, chain = support_chain(biped)
    assert len(cols) == 5
    bodies = biped.model.bodies
    mass = np.array([b.mass for b in bodies])
    com = np.array([b.com for b in bodies])
    sub = _subtrees(biped, chain) * mass
    axis = np.array([bodies[c].axis * bodies[c].sign for c in chain])
    q = np.random.default_rng(2).uniform(-0.4, 0.4, (4, biped.nq))
    rot, org = biped.forward(q)
    cw = org + (rot @ com[:, :, None])[..., 0]
    w = (rot[:, chain] @ axis[:, :, None])[..., 0]
    jac = np.cross(w, np.einsum("kb,nbi->nki", sub, cw) - sub.sum(1)[:, None] * org[:, chain])
    jac /= mass.sum()
    for k, c in enumerate(cols):
        dq = np.zeros(biped.nq)
        dq[c] = 1e-6
        fd = (biped.com(q + dq) - biped.com(q - dq)) / 2e-6
        np.testing.assert_allclose(jac[:, k], fd, atol=1e-8)


def test_mesh_capsules_contain_every_vertex():
    """Capsules around a point cloud's principal-axis box contain every point."""
    rng = np.random.default_rng(4)
    v = rng.normal(size=(500, 3)) * [0.2, 0.07, 0.03] @ np.linalg.qr(rng.normal(size=(3, 3)))[0]
    e0, e1, r = mesh_capsules(v)
    d = segment_distance(e0[None], e1[None], v[:, None], v[:, None])
    assert np.all(d.min(axis=1) <= r + 1e-12)
    assert r < 0.2  # tighter than one capsule around the cloud


def test_broad_phase_equals_all_pairs(op2):
    """The broad-phase self-collision mask equals the all-pairs one."""
    cap = collision_capsules(op2)
    q = np.random.default_rng(5).uniform(-0.8, 0.8, (3000, op2.nq))
    rot, org = op2.forward(q)
    a = collision_free_mask(cap, rot, org)
    assert 0.05 < a.mean() < 0.95
    np.testing.assert_array_equal(collision_free_mask_broad(cap, rot, org), a)


def test_resolve_mesh_paths(tmp_path):
    """package:// resolves against an ancestor directory named after the package; relative
    paths against the model's directory; a missing file gives None."""
    pkg = tmp_path / "my_pkg"
    (pkg / "meshes").mkdir(parents=True)
    (pkg / "urdf").mkdir()
    (pkg / "meshes" / "a.stl").write_text("solid a\nendsolid a\n")
    model = pkg / "urdf" / "r.urdf"
    assert resolve_mesh("package://my_pkg/meshes/a.stl", model) == pkg / "meshes" / "a.stl"
    assert resolve_mesh("../meshes/a.stl", model).resolve() == pkg / "meshes" / "a.stl"
    assert resolve_mesh("package://my_pkg/meshes/b.stl", model) is None


def test_simulate_clip_and_stable(biped):
    """simulate clips to the limits when asked; stable keeps CoPs inside the sole."""
    sim = sescid.simulate(biped, 300, 60, 0.0, seed=0, clip=True, stable=True)
    lim = biped.joint_limits
    assert np.all((sim.q >= lim[:, 0]) & (sim.q <= lim[:, 1]))
    half = np.asarray(biped.sole.size) / 2
    assert np.all(np.abs(sim.cop_true - biped.sole_centre) < half)
    assert sim.n_drawn > 300 and sim.n_clipped > 0


def _export_cop_error(robot, tmp_path, n=300):
    """Max |CoP of the exported MAP fit − the fit's CoP| on fresh poses, m."""
    sim = sescid.simulate(robot, n, 20, 0.002, seed=0, clip=True)
    fit = sescid.identify(robot, sim.q, sim.cop, method="map")
    out = tmp_path / f"{robot.name}_exp{robot.model_path.suffix}"
    cfit = sescid.to_consistent(fit)
    sescid.export_model(cfit, out, repair_inertia=True)  # TALOS, iCub: massive point masses
    exp = sescid.load_robot(out, robot.support)
    q = sescid.simulate(robot, 1000, 20, 0.0, seed=9, clip=True).q
    return float(np.abs(exp.cop(q) - fit.predict_cop(q)).max())


def test_export_of_map_fit_reproduces_cop_biped(biped, tmp_path):
    """The export of a MAP fit reproduces its CoP to ≤ 1e-9 m on fresh poses (generated biped)."""
    assert _export_cop_error(biped, tmp_path) <= 1e-9


# --- public humanoids (example-robot-data) ------------------------------------------------
def _erd() -> Path | None:
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        return None
    p = Path(dist.locate_file("cmeel.prefix/share/example-robot-data/robots"))
    return p if p.is_dir() else None


HUMANOIDS = [
    ("talos_data/robots/talos_reduced.urdf", "right_sole_link"),
    ("talos_data/robots/talos_full_v2.urdf", "right_sole_link"),
    ("icub_description/robots/icub.urdf", "r_sole"),
    ("icub_description/robots/icub_reduced.urdf", "r_sole"),
    ("g1_description/urdf/g1_29dof_rev_1_0.urdf", "right_ankle_roll_link"),
    ("g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf", "right_ankle_roll_link"),
    ("romeo_description/urdf/romeo.urdf", "r_sole"),
    ("simple_humanoid_description/urdf/simple_humanoid.urdf", "r_ankle"),
    ("human_description/robots/human.urdf", "right_foot"),
]


def _humanoid(rel: str, support: str):
    base = _erd()
    if base is None or not (base / rel).is_file():
        pytest.skip("example-robot-data not installed")
    return sescid.load_robot(base / rel, support)


_FAST = {0, 2, 4}  #: TALOS, iCub, G1 in the default run; the others under slow
_CASES = [
    pytest.param(*h, id=h[0].split("/")[-1], marks=() if i in _FAST else pytest.mark.slow)
    for i, h in enumerate(HUMANOIDS)
]


@pytest.mark.parametrize(("rel", "support"), _CASES)
def test_public_humanoid_com_equals_pinocchio(rel, support):
    """Every public humanoid loads; its CoM equals Pinocchio's to 1e-12 m at random poses."""
    from oracle import PinOracle

    robot = _humanoid(rel, support)
    mimic = {
        b.joint_name: (robot.joint_names[b.joint], b.multiplier, b.offset)
        for b in robot.model.bodies
        if b.joint >= 0 and b.joint_name not in robot.joint_names
    }
    oracle = PinOracle(robot.model_path, support, robot.joint_names, mimic)
    q = np.random.default_rng(0).uniform(-0.5, 0.5, (5, robot.nq))
    np.testing.assert_allclose(robot.com(q), oracle.com(q), rtol=0, atol=1e-12)


@pytest.mark.slow
def test_icub_sole_from_collada_mesh():
    """iCub's foot mesh (Collada, Y up) gives a sole longer in x than in y, centred in y."""
    robot = _humanoid("icub_description/robots/icub.urdf", "r_sole")
    sx, sy = robot.sole.size
    assert sx > 1.5 * sy and abs(robot.sole_centre[1]) < 0.01 and abs(robot.floor) < 1e-3


@pytest.mark.slow
@pytest.mark.parametrize(("rel", "support"), [HUMANOIDS[0], HUMANOIDS[2], HUMANOIDS[4]])
def test_public_humanoid_pipeline(rel, support, tmp_path):
    """simulate → identify (MAP) → poses → export on TALOS, iCub, G1: poses clear of the floor,
    export reproduces the fit's CoP to ≤ 1e-9 m."""
    robot = _humanoid(rel, support)
    assert robot.sole is not None and robot.free_sole is not None
    plan = sescid.plan_poses(robot, count=40, n_candidates=1000, n_test=300, seed=0)
    rot, org = robot.forward(plan.q)
    free = robot.free_sole
    corners = org[:, None, free.body] + np.einsum("nij,cj->nci", rot[:, free.body], free.corners)
    assert np.all(corners[..., 2] > robot.floor + 0.005)
    exempt = set(ground_checks(robot, collision_capsules(robot)).exempt)
    for s in robot.shapes:
        if s.role == "collision" and s.vertices is not None and s.body != 0:
            if robot.body_names[s.body] in exempt:
                continue
            z = org[:, s.body, 2:3] + rot[:, s.body, 2, :] @ s.vertices.T
            assert np.all(z > robot.floor), robot.body_names[s.body]
    assert _export_cop_error(robot, tmp_path) <= 1e-9
    assert math.isfinite(plan.expected_error)
