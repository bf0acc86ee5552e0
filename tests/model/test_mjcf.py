"""MJCF input (through MuJoCo's compiler) and MJCF export."""

from __future__ import annotations

import dataclasses
import importlib.metadata
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from fitting import identify_consistent
from mjcf_gen import mujoco_com, mujoco_geom_poses, random_mjcf

from sescid.cli import cli
from sescid.errors import MissingExtraError, ModelError, OptionError
from sescid.estimation.solvers import consistent
from sescid.io import export_mjcf, export_model, load_fit
from sescid.model import load_model
from sescid.model.mjcf import build_mjcf_model as build_mjcf
from sescid.model.urdf import build_urdf_model as build_urdf
from sescid.robot import Robot, load_robot
from sescid.robots import embedded_path
from sescid.sesc import sesc_vectors

mujoco = pytest.importorskip("mujoco")


def _load(path, support) -> Robot:
    return load_robot(path, support)


def _urdf_to_mjcf(urdf_text: str) -> str:
    spec = mujoco.MjSpec.from_string(urdf_text)
    spec.compiler.fusestatic = False  # keep massless links (r_sole) and the root link as bodies
    spec.compiler.discardvisual = False
    return spec.to_xml()


@pytest.fixture(scope="module")
def op2_mjcf(tmp_path_factory) -> Path:
    """The embedded OP2 URDF converted to MJCF by MuJoCo."""
    path = tmp_path_factory.mktemp("op2") / "op2.xml"
    path.write_text(_urdf_to_mjcf(embedded_path("op2").read_text()))
    return path


# --- loading -------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", range(30))
def test_random_tree_com_equals_mujoco(tmp_path, seed):
    """Random MJCF trees: sescid's CoM equals MuJoCo's subtree CoM in the support frame."""
    xml, frames = random_mjcf(seed)
    path = tmp_path / "r.xml"
    path.write_text(xml)
    rng = np.random.default_rng(seed)
    support = frames[rng.integers(len(frames))]
    robot = _load(path, support)
    q = rng.uniform(-2.5, 2.5, (25, robot.nq))
    ref = mujoco_com(path, support, robot.joint_names, q, seed)
    assert np.abs(robot.com(q) - ref).max() <= 1e-12


@pytest.mark.parametrize("seed", range(12))
def test_random_tree_frames_and_inertias_equal_mujoco(tmp_path, seed):
    """Random MJCF trees re-rooted anywhere: every body and site frame in the support frame is
    MuJoCo's (xpos/xmat, site_xpos/xmat), and every body's inertial (CoM, inertia in body
    axes, ``inertia_parts``) MuJoCo's xipos/ximat·diag(body_inertia)·ximatᵀ."""
    from mjcf_gen import _mujoco_states

    from sescid.model import inertia_parts

    xml, frames = random_mjcf(seed)
    path = tmp_path / "r.xml"
    path.write_text(xml)
    rng = np.random.default_rng(50 + seed)
    support = frames[rng.integers(len(frames))]
    robot = _load(path, support)
    q = rng.uniform(-2.5, 2.5, (5, robot.nq))
    rot, org = robot.forward(q)
    parts = inertia_parts(robot.model)
    states = _mujoco_states(path, support, robot.joint_names, q, seed)
    for k, (m, data, r_s, o_s, root) in enumerate(states):
        bodies = [b for b in range(m.nbody) if m.body_rootid[b] == root]
        sites = [s for s in range(m.nsite) if m.site_bodyid[s] in bodies]
        checked = 0
        for kind, ids, xpos, xmat in (
            ("body", bodies, data.xpos, data.xmat),
            ("site", sites, data.site_xpos, data.site_xmat),
        ):
            for i in ids:
                name = getattr(m, kind)(i).name or f"{kind}{i}"
                if name not in robot.model.link_frames:  # a site named like a body
                    continue
                r_lk, o_lk = robot.link_poses(q[k : k + 1], name)
                np.testing.assert_allclose(r_lk[0], r_s.T @ xmat[i].reshape(3, 3), atol=1e-12)
                np.testing.assert_allclose(o_lk[0], r_s.T @ (xpos[i] - o_s), atol=1e-12)
                checked += 1
        assert checked == len(bodies) + len(sites) - sum(
            (m.site(s).name or f"site{s}") not in robot.model.link_frames for s in sites
        )
        for b in bodies:
            if not m.body_mass[b] > 0:
                continue
            sb = robot.model.link_frames[m.body(b).name or f"body{b}"][0]
            c_ref = r_s.T @ (data.xipos[b] - o_s)
            i_ref = r_s.T @ data.ximat[b].reshape(3, 3)
            i_ref = i_ref @ np.diag(m.body_inertia[b]) @ i_ref.T
            hits = [
                (rot[k, sb] @ c + org[k, sb], rot[k, sb] @ i_c @ rot[k, sb].T)
                for _, c, i_c in parts[sb]
                if np.allclose(rot[k, sb] @ c + org[k, sb], c_ref, atol=1e-12, rtol=0)
            ]
            assert hits, (seed, b)
            np.testing.assert_allclose(hits[0][1], i_ref, atol=1e-14)


_HAND = """<mujoco model="hand">
  <compiler angle="degree"/>
  <worldbody>
    <body name="base" pos="0 0 1">
      <freejoint name="float"/>
      <inertial pos="0 0 0" mass="2" diaginertia="1 1 1"/>
      <body name="arm" pos="0.1 0 0">
        <joint name="a1" axis="0 0 2" pos="0.01 0 0" range="-90 45"/>
        <joint axis="0 1 0" pos="0 0.02 0" ref="30"/>
        <inertial pos="0.2 0 0" mass="1" diaginertia="1 1 1"/>
        <site name="tip" pos="0.4 0 0" euler="0 0 90"/>
        <body name="hand" pos="0.4 0 0">
          <inertial pos="0 0 0" mass="0.5" diaginertia="1 1 1"/>
        </body>
      </body>
      <body name="other" pos="-0.1 0 0">
        <joint name="b1" axis="1 0 0"/>
        <geom type="sphere" size="0.1" density="1000"/>
      </body>
    </body>
  </worldbody>
  <equality><joint joint1="b1" joint2="a1" polycoef="0.1 -2 0 0 0"/></equality>
</mujoco>
"""


def test_hand_model_structure(tmp_path):
    """A hand-written MJCF: names, chain of hinge frames, mimic, limits in rad, merged bodies."""
    path = tmp_path / "hand.xml"
    path.write_text(_HAND)
    model = build_mjcf(path, "base")
    assert model.format == "mjcf" and model.path == path.resolve() and model.model_root == "base"
    assert model.joint_names == ["a1", "joint2"]  # document order; unnamed: joint<MuJoCo id>
    assert any("float" in n for n in model.notes)  # the free root joint is dropped, with a note
    names = [b.name for b in model.bodies]
    assert names == ["base", "arm:a1", "arm", "other"]
    assert [b.frame_only for b in model.bodies] == [False, True, False, False]
    inter, arm, other = model.bodies[1], model.bodies[2], model.bodies[3]
    assert inter.mass == 0 and inter.joint == 0 and np.allclose(inter.axis, [0, 0, 1])
    np.testing.assert_allclose(inter.trans_const, [0.11, 0, 0], atol=1e-15)
    np.testing.assert_allclose(arm.trans_const, [-0.01, 0.02, 0], atol=1e-15)  # pos2 − pos1
    assert arm.offset == pytest.approx(-math.radians(30), abs=1e-15)  # rotation = q − ref
    assert arm.mass == 1.5 and arm.links == ("arm", "hand", "tip")
    # hand (0.5 kg at 0.4 m) and arm (1 kg at 0.2 m), in the frame on the 2nd hinge's axis
    np.testing.assert_allclose(arm.com, [(0.2 + 0.2) / 1.5, -0.02, 0], atol=1e-15)
    assert other.multiplier == -2 and other.offset == 0.1 and other.joint == 0
    assert other.mass == pytest.approx(1000 * 4 / 3 * math.pi * 0.001, rel=1e-12)
    np.testing.assert_allclose(model.joint_limits[0], [-math.pi / 2, math.pi / 4], rtol=1e-15)
    assert np.all(np.isinf(model.joint_limits[1]))
    b, x = model.link_frames["tip"]
    assert b == 2
    np.testing.assert_allclose(x[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)


def test_site_support_matches_mujoco(tmp_path):
    """A site as support: the support frame takes the site's pose (MuJoCo's site_xpos/xmat)."""
    path = tmp_path / "hand.xml"
    path.write_text(_HAND)
    robot = _load(path, "tip")
    q = np.random.default_rng(1).uniform(-2, 2, (50, robot.nq))
    ref = mujoco_com(path, "tip", robot.joint_names, q)
    assert np.abs(robot.com(q) - ref).max() <= 1e-12
    assert robot.body_names[0] == "arm"


def test_op2_mjcf_matches_urdf_and_mujoco(op2_mjcf):
    """OP2 URDF → MJCF by MuJoCo: CoM equals sescid's URDF CoM (6-digit XML) and MuJoCo's."""
    robot = _load(op2_mjcf, "r_sole")
    urdf = Robot(build_urdf(embedded_path("op2"), "r_sole"), "op2")
    assert sorted(robot.joint_names) == sorted(urdf.joint_names)
    assert robot.body_names == urdf.body_names
    q = np.random.default_rng(2).uniform(-1, 1, (300, urdf.nq))
    qm = q[:, [urdf.joint_names.index(n) for n in robot.joint_names]]
    # MuJoCo's to_xml writes 6 significant digits (e.g. axis 0.707107): ~3e-9 m measured
    assert np.abs(robot.com(qm) - urdf.com(q)).max() <= 1e-8
    ref = mujoco_com(op2_mjcf, "r_sole", robot.joint_names, qm)
    assert np.abs(robot.com(qm) - ref).max() <= 1e-12


def _erd_robots() -> Path | None:
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        return None
    path = Path(dist.locate_file("cmeel.prefix/share/example-robot-data/robots"))
    return path if path.is_dir() else None


def test_talos_missing_meshes(tmp_path):
    """TALOS (example-robot-data) via MuJoCo, meshes missing: loads; CoM equals MuJoCo's."""
    robots = _erd_robots()
    if robots is None:
        pytest.skip("example-robot-data not installed")
    urdf = (robots / "talos_data/robots/talos_reduced.urdf").read_text()
    xml = _urdf_to_mjcf(urdf.replace("package://example-robot-data/robots/", f"{robots}/"))
    full = tmp_path / "full.xml"  # meshes found: MuJoCo's reference
    full.write_text(xml)
    bare = tmp_path / "bare.xml"  # mesh paths relative to tmp_path: all missing
    bare.write_text(xml.replace(f"{robots}/", ""))
    robot = _load(bare, "right_sole_link")
    assert robot.nq == 32 and any("mesh" in n for n in robot.model.notes)
    q = np.random.default_rng(3).uniform(-1, 1, (100, robot.nq))
    ref = mujoco_com(full, "right_sole_link", robot.joint_names, q)
    assert np.abs(robot.com(q) - ref).max() <= 1e-12


# --- errors --------------------------------------------------------------------------------
_ONE = """<mujoco><worldbody><body name="a"><geom size="0.1"/>
<body name="b" pos="0 0 1"><joint name="j" {attrs}/><geom size="0.1"/>
<body name="c" pos="0 0 1"><joint name="k"/><geom size="0.1"/></body></body></body>
</worldbody>{extra}</mujoco>"""


@pytest.mark.parametrize(
    ("text", "support", "match"),
    [
        (None, "a", "MJCF file not found"),
        ("<mujoco><worldbody><body></worldbody>", "a", "malformed MJCF"),
        ('<robot name="x"/>', "a", "not an MJCF"),
        (
            '<mujoco><worldbody><body name="a"><geom size="0.1"/></body></worldbody></mujoco>',
            "world",
            "unknown support frame 'world'",
        ),
        (_ONE.format(attrs="", extra=""), "zz", "unknown support frame 'zz'"),
        (_ONE.format(attrs='type="slide"', extra=""), "a", "'j' is a slide joint"),
        (_ONE.format(attrs='type="ball"', extra=""), "a", "'j' is a ball joint"),
        (
            _ONE.format(
                attrs="",
                extra='<equality><joint name="e" joint1="k" joint2="j" polycoef="0 1 0.5 0 0"/>'
                "</equality>",
            ),
            "a",
            "equality 'e'.*polycoef",
        ),
        (
            '<mujoco><asset><mesh name="m" file="gone.stl"/></asset><worldbody><body name="a">'
            '<geom size="0.1"/><body name="b"><joint/><geom type="mesh" mesh="m"/></body></body>'
            "</worldbody></mujoco>",
            "a",
            "body 'b' has a mesh geom whose file .*gone.stl is missing",
        ),
    ],
)
def test_errors(tmp_path, text, support, match):
    """Bad input: one-line ModelError naming the file and the culprit."""
    path = tmp_path / "m.xml"
    if text is not None:
        path.write_text(text)
    with pytest.raises(ModelError, match=match) as info:
        build_mjcf(path, support)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


# --- export --------------------------------------------------------------------------------
def _perturbed(robot: Robot, seed: int):
    rng = np.random.default_rng(seed)
    masses = robot.masses * rng.uniform(0.8, 1.2, len(robot.masses))
    coms = np.array([b.com for b in robot.model.bodies]) + rng.normal(0, 0.005, (len(masses), 3))
    return masses, coms, sesc_vectors(consistent.consistent_model(robot, masses, coms))


def test_export_round_trip_op2(op2_mjcf, tmp_path):
    """Consistent fit on the OP2 MJCF → export → reload: same CoP (≤ 1e-9 m), same masses."""
    robot = _load(op2_mjcf, "r_sole")
    _, _, r_true = _perturbed(robot, 4)
    rng = np.random.default_rng(5)
    q = rng.uniform(-1, 1, (400, robot.nq))
    fit = identify_consistent(robot, q, robot.cop(q, r_true), box_margin=0.5)
    out = tmp_path / "op2_fit.xml"
    assert export_model(fit, out) == []
    back = _load(out, "r_sole")
    q2 = rng.uniform(-1, 1, (400, robot.nq))
    assert np.abs(back.cop(q2) - fit.predict_cop(q2)).max() <= 1e-9
    masses, _ = consistent.fit_inertials(fit)
    np.testing.assert_allclose(back.masses, masses, rtol=1e-14)
    # everything but the <inertial> lines (and the added comment) is byte-identical
    src = [ln for ln in op2_mjcf.read_text().splitlines() if "<inertial" not in ln]
    new = [ln for ln in out.read_text().splitlines() if "<inertial" not in ln]
    assert [ln for ln in new if "identified by sescid" not in ln] == src
    assert len(new) == len(src) + 1


@pytest.mark.parametrize("seed", range(8))
def test_export_random_trees(tmp_path, seed):
    """Random trees (geom-inferred inertias, merged bodies, hinge chains): exact round trip."""
    xml, frames = random_mjcf(seed)
    path = tmp_path / "r.xml"
    path.write_text(xml)
    support = frames[seed % len(frames)]
    robot = _load(path, support)
    masses, coms, r_true = _perturbed(robot, seed)
    q = np.random.default_rng(seed).uniform(-1, 1, (200, robot.nq))
    fit = identify_consistent(robot, q, robot.cop(q, r_true), box_margin=0.5)
    truth = dataclasses.replace(fit.inertials, masses=masses, coms=coms)
    fit = dataclasses.replace(fit, inertials=truth)  # the truth
    out = tmp_path / "out.xml"
    export_mjcf(fit, out)
    back = _load(out, support)
    assert np.abs(back.cop(q) - robot.cop(q, r_true)).max() <= 1e-9
    np.testing.assert_allclose(back.masses, masses, rtol=1e-14, atol=1e-300)


def test_export_refuses_mass_between_hinges(tmp_path):
    """A fit that gives mass to a frame between two hinges of one MJCF body: ModelError."""
    path = tmp_path / "hand.xml"
    path.write_text(_HAND)
    robot = _load(path, "base")
    q = np.random.default_rng(6).uniform(-1, 1, (50, robot.nq))
    fit = identify_consistent(robot, q, robot.cop(q), box_margin=0.5)
    masses, coms = fit.inertials.masses.copy(), fit.inertials.coms.copy()
    masses[robot.body_names.index("arm:a1")] = 0.1
    fit = dataclasses.replace(
        fit, inertials=dataclasses.replace(fit.inertials, masses=masses, coms=coms)
    )
    with pytest.raises(ModelError, match="'arm:a1', a massless frame between two hinges"):
        export_mjcf(fit, tmp_path / "out.xml")
    assert not (tmp_path / "out.xml").exists()


def test_consistent_pins_frames_between_hinges(tmp_path):
    """Data that a mass on 'arm:a1' would fit best: the fit keeps it at 0 kg and exports."""
    path = tmp_path / "hand.xml"
    path.write_text(_HAND)
    robot = _load(path, "base")
    frame = robot.body_names.index("arm:a1")
    r_true = robot.sesc_vectors()
    r_true[frame] += [0.0, 0.03, 0.02]  # r of a frame with mass: no massless frame reproduces it
    rng = np.random.default_rng(7)
    q = rng.uniform(-1.5, 1.5, (200, robot.nq))
    cop = robot.cop(q, r_true)
    free = dataclasses.replace(  # control: the same tree without the flag puts mass there
        robot.model,
        bodies=[dataclasses.replace(b, frame_only=False) for b in robot.model.bodies],
    )
    fit_free = identify_consistent(Robot(free, str(path)), q, cop, box_margin=0.5)
    assert fit_free.inertials.masses[frame] > 1e-3
    fit = identify_consistent(robot, q, cop, box_margin=0.5)
    masses, coms = consistent.fit_inertials(fit)
    assert masses[frame] == 0.0 and np.all(coms[frame] == 0.0)
    assert not any("arm:a1" in c for c in fit.inertials.active_constraints)
    assert masses.sum() == pytest.approx(robot.total_mass, rel=1e-12)
    out = tmp_path / "out.xml"
    export_mjcf(fit, out)
    back = _load(out, "base")
    q2 = rng.uniform(-1.5, 1.5, (200, robot.nq))
    assert np.abs(back.cop(q2) - fit.predict_cop(q2)).max() <= 1e-9
    fit_floor = identify_consistent(robot, q, cop, box_margin=0.5, mass_floor=0.2)
    assert fit_floor.inertials.masses[frame] == 0.0  # a mass floor does not apply to it


def test_random_trees_cover_the_features(tmp_path):
    """The generator's 30 trees include hinge chains, mimics, locked hinges, free roots, sites."""
    seen = set()
    for seed in range(30):
        xml, frames = random_mjcf(seed)
        path = tmp_path / f"r{seed}.xml"
        path.write_text(xml)
        model = build_mjcf(path, frames[-1])
        notes = model.notes
        seen |= {"chain"} if any(b.frame_only for b in model.bodies) else set()
        seen |= {"mimic"} if any(b.multiplier != 1 for b in model.bodies) else set()
        seen |= {"locked"} if 'polycoef="' in xml and "joint2" not in xml.split("\n")[-3] else set()
        seen |= {"free"} if any("root_free" in n for n in notes) else set()
        seen |= {"site"} if frames[-1].startswith("s") else set()
        seen |= {"unnamed"} if any(n.startswith("joint") for n in model.joint_names) else set()
    assert seen == {"chain", "mimic", "locked", "free", "site", "unnamed"}


# --- shapes --------------------------------------------------------------------------------
_SHAPES = """<mujoco model="shapes">
  <asset><mesh name="tet" vertex="0 0 0 1 0 0 0 1 0 0 0 1" scale="0.1 0.2 0.3"/></asset>
  <worldbody>
    <body name="base">
      <geom type="box" size="0.1 0.2 0.3" euler="10 20 30"/>
      <body name="leg" pos="0 0 -0.3">
        <joint name="h1" axis="0 1 0"/>
        <joint name="h2" axis="1 0 0" pos="0 0 -0.05"/>
        <geom type="capsule" size="0.03" fromto="0 0 0 0.1 0 -0.3"/>
        <geom type="cylinder" size="0.04 0.1" pos="0 0.05 -0.1" contype="0" conaffinity="0"/>
        <geom type="ellipsoid" size="0.02 0.03 0.04" pos="0.02 0 -0.2"/>
        <geom type="mesh" mesh="tet" pos="0.01 0.02 0.03" euler="0 40 0"/>
        <geom type="sphere" size="0.05" pos="0 0 -0.4" mass="0.3"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_shapes_follow_mujoco_geoms(tmp_path):
    """Geoms become Shapes whose frames (and mesh vertices) follow MuJoCo's geoms, any pose."""
    path = tmp_path / "shapes.xml"
    path.write_text(_SHAPES)
    robot = _load(path, "leg")
    shapes = robot.model.shapes
    assert [s.kind for s in shapes] == ["box", "capsule", "cylinder", "box", "mesh", "sphere"]
    assert [s.role for s in shapes].count("visual") == 1 and shapes[2].role == "visual"
    np.testing.assert_allclose(shapes[1].size, [0.03, math.hypot(0.1, 0.3)], rtol=1e-12)
    np.testing.assert_allclose(shapes[3].size, [0.04, 0.06, 0.08], rtol=1e-12)
    assert shapes[4].mesh == "tet" and shapes[4].vertices.shape == (4, 3)
    m = mujoco.MjModel.from_xml_path(str(path))
    q = np.random.default_rng(8).uniform(-2, 2, (20, robot.nq))
    ref = mujoco_geom_poses(path, "leg", robot.joint_names, q)
    rot, org = robot.forward(q)
    for g, s in enumerate(shapes):
        pose = np.einsum("nij,jk->nik", rot[:, s.body], s.pose[:3])
        pose[:, :, 3] += org[:, s.body]
        np.testing.assert_allclose(pose, ref[:, g, :3], atol=1e-12)
    v = m.mesh_vert[: m.mesh_vertnum[0]]  # the mesh in MuJoCo's geom frame
    for n in range(len(q)):
        world = v @ ref[n, 4, :3, :3].T + ref[n, 4, :3, 3]
        b = shapes[4].body
        mine = shapes[4].vertices @ rot[n, b].T + org[n, b]
        np.testing.assert_allclose(mine, world, atol=1e-12)


def test_shape_hulls_match_mujoco_aabb(tmp_path):
    """Random trees: per-body collision hulls equal the hulls of MuJoCo's geom AABBs."""
    from sescid.model import body_hulls

    for seed in range(6):
        xml, frames = random_mjcf(seed)
        path = tmp_path / f"r{seed}.xml"
        path.write_text(xml)
        robot = _load(path, frames[seed % len(frames)])
        m = mujoco.MjModel.from_xml_path(str(path))
        q0 = np.zeros((1, robot.nq))
        rot, org = robot.forward(q0)
        ref = mujoco_geom_poses(path, robot.support, robot.joint_names, q0)[0]
        expect: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        for g, s in zip(range(1, m.ngeom), robot.model.shapes, strict=False):  # 0: floor
            x = rot[0, s.body].T @ ref[g, :3, :3]  # geom frame in the body frame
            c = x @ m.geom_aabb[g, :3] + rot[0, s.body].T @ (ref[g, :3, 3] - org[0, s.body])
            h = np.abs(x) @ m.geom_aabb[g, 3:]
            if s.kind == "sphere":  # MuJoCo's AABB of a rotated sphere is the sphere's cube
                h = np.full(3, m.geom_size[g, 0])
            lo, hi = expect.get(s.body, (c - h, c + h))
            expect[s.body] = (np.minimum(lo, c - h), np.maximum(hi, c + h))
        got = body_hulls(robot.model.shapes, "collision")
        assert got.keys() == expect.keys()
        for b in got:
            np.testing.assert_allclose(got[b], expect[b], atol=1e-12)


# --- extras, format dispatch, CLI ------------------------------------------------------------
def test_missing_mujoco_is_a_missing_extra(tmp_path, monkeypatch):
    """Without mujoco, reading an MJCF raises MissingExtraError naming the mujoco extra."""
    path = tmp_path / "hand.xml"
    path.write_text(_HAND)
    monkeypatch.setitem(sys.modules, "mujoco", None)  # import mujoco → ImportError
    with pytest.raises(MissingExtraError, match=r"reading MJCF needs the mujoco extra") as info:
        load_model(path, "base")
    assert info.value.extra == "mujoco"


def test_export_model_format(tmp_path, op2):
    """export_model: the model's own format by default; a URDF ↔ MJCF switch is refused."""
    path = tmp_path / "hand.xml"
    path.write_text(_HAND)
    robot = _load(path, "base")
    q = np.random.default_rng(9).uniform(-1, 1, (60, robot.nq))
    fit = identify_consistent(robot, q, robot.cop(q), box_margin=0.5)
    with pytest.raises(OptionError, match="format: cannot write URDF from the MJCF"):
        export_model(fit, tmp_path / "out.urdf", "urdf")
    export_model(fit, tmp_path / "out.xml", "mjcf")
    assert _load(tmp_path / "out.xml", "base").total_mass == pytest.approx(robot.total_mass)
    q = np.random.default_rng(9).uniform(-0.3, 0.3, (60, op2.nq))
    fit = identify_consistent(op2, q, op2.cop(q))
    with pytest.raises(OptionError, match="format: cannot write MJCF from the URDF"):
        export_model(fit, tmp_path / "op2.xml", "mjcf")
    export_model(fit, tmp_path / "op2.urdf")
    assert (tmp_path / "op2.urdf").read_text().startswith("<?xml")


def _cli(*args):
    result = CliRunner().invoke(cli, [str(a) for a in args])
    assert "Traceback" not in result.output
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    return result


def test_cli_end_to_end_on_generated_mjcf(tmp_path):
    """CLI info → simulate → identify → export on a generated MJCF; export's CoP ≤ 1e-9 m off."""
    xml, _ = random_mjcf(3)
    path = tmp_path / "robot.xml"
    path.write_text(xml)
    robot = _load(path, "b1")
    assert any(b.frame_only for b in robot.model.bodies)  # a hinge chain: pinned frames
    res = _cli("info", "--robot", path, "--support", "b1")
    assert res.exit_code == 0, res.output
    assert all(name in res.output for name in robot.body_names + robot.joint_names)
    data, fit_file, out = tmp_path / "sim.csv", tmp_path / "fit.json", tmp_path / "fit.xml"
    res = _cli("simulate", "--robot", path, "--support", "b1", "--count", 200, "--out", data)
    assert res.exit_code == 0, res.output
    res = _cli(
        "identify", data, "--robot", path, "--support", "b1", "--method", "consistent",
        "--box-margin", 0.5, "--out", fit_file,
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    res = _cli("export", fit_file, "--format", "urdf", "--out", tmp_path / "no.urdf")
    assert res.exit_code == 2 and "--format: cannot write URDF" in res.output
    assert not (tmp_path / "no.urdf").exists()
    res = _cli("export", fit_file, "--out", out)
    assert res.exit_code == 0, res.output
    fit = load_fit(fit_file)
    assert fit.robot.model.format == "mjcf"
    assert all(
        fit.inertials.masses[b] == 0 for b, bd in enumerate(robot.model.bodies) if bd.frame_only
    )
    back = _load(out, "b1")
    q = np.random.default_rng(10).uniform(-1.5, 1.5, (300, robot.nq))
    assert np.abs(back.cop(q) - fit.predict_cop(q)).max() <= 1e-9
