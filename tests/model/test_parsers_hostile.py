"""Absurd or unsupported model files: a one-line ModelError naming the file and the element,
or a note where statics is unaffected; MJCF ``<include>`` read from any working directory;
re-rooting deep trees without touching the recursion limit."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest
from click.testing import CliRunner
from mjcf_gen import mujoco_com

import sescid
from sescid.cli import cli
from sescid.errors import ModelError
from sescid.model import Edge, Frame, Graph, LinkInertial, inertia_issue, load_model, reroot

_I = '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>'


def _urdf(b_link: str = f'<inertial><mass value="1"/>{_I}</inertial>', extra: str = "") -> str:
    return (
        f'<?xml version="1.0"?><robot name="r"><link name="a"><inertial><mass value="1"/>{_I}'
        f'</inertial></link><link name="b">{b_link}</link>{extra}<joint name="j" type="revolute">'
        '<parent link="a"/><child link="b"/><origin xyz="0 0 1"/><axis xyz="0 0 1"/></joint>'
        "</robot>"
    )


def _refused(path, match: str) -> str:
    with pytest.raises(ModelError, match=match) as info:
        load_model(path, "a")
    msg = str(info.value)
    assert str(path) in msg and "\n" not in msg, msg
    return msg


# --- URDF -----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("b_link", "extra", "match"),
    [
        ("", f'<link name="c"><inertial><mass value="5"/>{_I}</inertial></link>', "2 separate"),
        ("", '<link name="c"/>', r"2 separate trees \(roots 'a', 'c'\)"),
        ("", '<joint name="k" type="fixed"><parent link="b"/><child link="a"/></joint>', "loop"),
        (f'<inertial><mass value="-1"/>{_I}</inertial>', "", "link 'b' has an invalid mass -1"),
        (f'<inertial><mass value="inf"/>{_I}</inertial>', "", "link 'b' has an invalid mass"),
        (
            '<inertial><mass value="1"/><inertia ixx="nan" ixy="0" ixz="0" iyy="1" iyz="0" '
            'izz="1"/></inertial>',
            "",
            "link 'b' inertia has a non-finite number",
        ),
        ('<inertial><mass value="abc"/></inertial>', "", "<link> 'b' .*'abc'"),
        (
            '<collision><geometry><box size="-1 1 1"/></geometry></collision>',
            "",
            r"link 'b' collision box size must be 3 number\(s\) ≥ 0 m",
        ),
        ('<visual><geometry><box size="1 1"/></geometry></visual>', "", "visual box size"),
        ('<visual><geometry><sphere radius="-0.1"/></geometry></visual>', "", "sphere radius"),
        (
            '<visual><geometry><mesh filename="m.stl" scale="1 nan 1"/></geometry></visual>',
            "",
            "link 'b' visual mesh scale has a non-finite number",
        ),
    ],
)
def test_urdf_refused(tmp_path, b_link, extra, match):
    """Two roots (massive or massless), loops, negative/infinite masses, NaN inertias, broken
    numbers and shapes: refused, naming the file and the link."""
    path = tmp_path / "bad.urdf"
    path.write_text(_urdf(b_link, extra))
    _refused(path, match)


def test_urdf_empty_name(tmp_path):
    path = tmp_path / "bad.urdf"
    path.write_text(_urdf().replace('name="b"', 'name=""').replace('link="b"', 'link=""'))
    _refused(path, "a <link> element has no name")


@pytest.mark.parametrize(
    ("inertia", "issue"),
    [
        ('ixx="-1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"', "negative principal moment"),
        ('ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="5"', "triangle inequality"),
        ('ixx="1" ixy="2" ixz="0" iyy="1" iyz="0" izz="1"', "negative principal moment"),
    ],
)
def test_urdf_unphysical_inertia_is_noted(tmp_path, inertia, issue):
    """Statics does not use inertia tensors: an unphysical one loads, with a note naming it."""
    path = tmp_path / "odd.urdf"
    path.write_text(_urdf(f'<inertial><mass value="1"/><inertia {inertia}/></inertial>'))
    model = load_model(path, "a")
    assert [b.mass for b in model.bodies] == [1.0, 1.0]
    assert any("link 'b' inertia" in n and issue in n for n in model.notes), model.notes


def test_inertia_rule_against_closed_forms():
    """inertia_issue: a solid box, a rod and a point mass are physical; a broken one is not."""
    m, a, b, c = 2.0, 0.3, 0.2, 0.1
    box = m / 12 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    rot = np.linalg.qr(np.random.default_rng(0).normal(size=(3, 3)))[0]
    assert inertia_issue(rot @ box @ rot.T) is None
    assert inertia_issue(np.diag([1.0, 1.0, 0.0])) is None  # a thin rod along z: A + B = C …
    assert inertia_issue(np.zeros((3, 3))) is None  # a point mass
    noise = np.array([[0.0, 0.0, 2.4e-35], [0.0, 0.0, 0.0], [2.4e-35, 0.0, 0.0]])
    assert inertia_issue(noise) is None  # iCub's head: rounding noise on a point mass
    assert "triangle" in inertia_issue(np.diag([0.0, 0.0, 1.0]))  # … but not (0, 0, 1)
    assert "symmetric" in inertia_issue(np.array([[1.0, 0.5, 0], [0, 1, 0], [0, 0, 1]]))
    assert "non-finite" in inertia_issue(np.diag([1.0, math.nan, 1.0]))


_XACRO = (
    '<?xml version="1.0"?><robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
    '<xacro:property name="m" value="1"/><link name="a"><inertial><mass value="${m}"/>'
    f"{_I}</inertial></link></robot>"
)


@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("robot.urdf.xacro", _XACRO),
        ("robot.urdf", _XACRO),  # namespace tags in a .urdf
        ("robot.urdf", _XACRO.replace(' xmlns:xacro="http://www.ros.org/wiki/xacro"', "")),
        ("robot.urdf", _urdf().replace('<origin xyz="0 0 1"/>', '<origin xyz="0 0 ${h}"/>')),
    ],
)
def test_xacro_is_recognised(tmp_path, name, text):
    """A xacro file (by name, namespace, unbound ``xacro:`` prefix or ``${…}``): one line
    that says to expand it with xacro, from the API and from the CLI."""
    path = tmp_path / name
    path.write_text(text)
    msg = _refused(path, "a xacro file")
    assert f"`xacro {name} > robot.urdf`" in msg
    res = CliRunner().invoke(cli, ["info", "--robot", str(path), "--support", "a"])
    assert res.exit_code == 2 and "a xacro file" in res.output and "Traceback" not in res.output


# --- MJCF -----------------------------------------------------------------------------------
_ROBOT = """<mujoco model="m"><worldbody><body name="a"><geom size="0.1"/>
<body name="b" pos="0 0 1"><joint name="j"/>{inner}</body></body></worldbody></mujoco>"""


@pytest.mark.parametrize(
    ("inner", "match"),
    [
        ('<geom size="0.1" pos="nan 0 0"/>', r"<geom> pos=\"nan 0 0\" has a non-finite number"),
        ('<inertial pos="inf 0 0" mass="1" diaginertia="1 1 1"/>', "<inertial> pos="),
        ('<geom size="0.1"/><site name="s" quat="1 0 nan 0"/>', "<site name='s'> quat="),
        (
            '<inertial pos="0 0 0" mass="-1" diaginertia="1 1 1"/>',
            r"mass and inertia .*; element 'b', line 2\)",
        ),
        (
            '<inertial pos="0 0 0" mass="1" diaginertia="1 1 5"/>',
            r"A \+ B >= C.*; element 'b', line 2\)",
        ),
        ('<geom size="-0.1"/>', "size 0 must be positive"),
    ],
)
def test_mjcf_refused(tmp_path, capfd, inner, match):
    """Non-finite numbers are caught before MuJoCo (which would only print a warning) and name
    the element; MuJoCo's own refusals keep the element and line it names."""
    path = tmp_path / "bad.xml"
    path.write_text(_ROBOT.format(inner=inner))
    _refused(path, match)
    assert "WARNING" not in capfd.readouterr().out


def _included_robot(tmp_path, nan: bool = False):
    """A robot whose bodies, mesh asset and meshdir come from included files in sub-folders."""
    (tmp_path / "model" / "parts").mkdir(parents=True)
    (tmp_path / "model" / "meshes").mkdir()
    (tmp_path / "model" / "meshes" / "tet.obj").write_text(
        "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    )
    (tmp_path / "model" / "robot.xml").write_text(
        '<mujoco model="inc"><compiler meshdir="meshes"/><include file="parts/assets.xml"/>'
        '<worldbody><body name="base"><freejoint/><geom size="0.1" mass="2"/>'
        '<include file="parts/leg.xml"/></body></worldbody></mujoco>'
    )
    (tmp_path / "model" / "parts" / "assets.xml").write_text(
        '<mujoco><asset><mesh name="tet" file="tet.obj"/></asset></mujoco>'
    )
    pos = "nan" if nan else "0.05"
    (tmp_path / "model" / "parts" / "leg.xml").write_text(
        f'<mujoco><body name="leg" pos="0 {pos} -0.2"><joint name="hip" axis="0 1 0"/>'
        '<geom type="capsule" size="0.03 0.1" mass="0.7"/><body name="foot" pos="0 0 -0.3">'
        '<joint name="ankle" axis="1 0 0" pos="0 0.01 0"/><geom type="mesh" mesh="tet"/>'
        '<site name="sole" pos="0 0 -0.05"/></body></body></mujoco>'
    )
    return tmp_path / "model" / "robot.xml"


def test_mjcf_include_from_any_working_directory(tmp_path, monkeypatch):
    """A model split over included files (one included inside <body>, meshes through meshdir)
    reads the same from its own folder, another folder, by relative path: MuJoCo's CoM."""
    mujoco = pytest.importorskip("mujoco")
    path = _included_robot(tmp_path)
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    robot = sescid.load_robot(path, "sole")
    assert robot.joint_names == ["hip", "ankle"] and not robot.model.notes[1:]
    assert any(s.kind == "mesh" and s.vertices is not None for s in robot.model.shapes)
    q = np.random.default_rng(3).uniform(-1.5, 1.5, (20, robot.nq))
    ref = mujoco_com(path, "sole", robot.joint_names, q)
    assert np.abs(robot.com(q) - ref).max() <= 1e-12
    m = mujoco.MjModel.from_xml_path(str(path))
    assert robot.total_mass == pytest.approx(float(m.body_subtreemass[1]), rel=1e-12)
    monkeypatch.chdir(tmp_path)
    again = sescid.load_robot("model/robot.xml", "sole")
    assert np.array_equal(again.com(q), robot.com(q))


def test_mjcf_nan_in_an_included_file(tmp_path, capfd):
    path = _included_robot(tmp_path, nan=True)
    with pytest.raises(ModelError, match=r"leg\.xml: <body name='leg'> pos=\"0 nan -0.2\""):
        load_model(path, "sole")
    assert "WARNING" not in capfd.readouterr().out


# --- the walk -------------------------------------------------------------------------------
def test_deep_trees_keep_the_recursion_limit(tmp_path, monkeypatch):
    """A 3000-link URDF chain re-rooted at its tip, and a 20 000-frame graph: no recursion,
    the recursion limit untouched; the chain's CoM equals the closed form of a planar chain."""

    def forbidden(_):
        raise AssertionError("the loader changed the recursion limit")

    monkeypatch.setattr(sys, "setrecursionlimit", forbidden)
    n = 3000
    links = "".join(
        f'<link name="l{i}"><inertial><origin xyz="0 0 0.01"/><mass value="0.1"/>{_I}'
        "</inertial></link>"
        for i in range(n)
    )
    joints = "".join(
        f'<joint name="j{i}" type="{"fixed" if i % 3 == 0 else "revolute"}">'
        f'<parent link="l{i - 1}"/><child link="l{i}"/>'
        '<origin xyz="0 0 0.02" rpy="0.001 0 0"/><axis xyz="1 0 0"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        for i in range(1, n)
    )
    path = tmp_path / "chain.urdf"
    path.write_text(f'<robot name="chain">{links}{joints}</robot>')
    robot = sescid.load_robot(path, f"l{n - 1}")
    assert (
        robot.nq == sum(1 for i in range(1, n) if i % 3)
        and robot.model.bodies[-1].links[-1] == "l0"
    )
    q = np.random.default_rng(0).uniform(-0.01, 0.01, (2, robot.nq))
    # closed form: a planar chain (every rotation about x), CoM in l0's frame, then the tip's
    for qk, com in zip(q, robot.com(q), strict=True):
        step = np.full(n, 0.001)
        step[0] = 0.0
        step[[i for i in range(1, n) if i % 3]] += qk
        phi = np.cumsum(step)  # angle of link i's frame about x
        yz = lambda a, d: d * np.column_stack([-np.sin(a), np.cos(a)])  # noqa: E731
        origin = np.vstack([[0.0, 0.0], np.cumsum(yz(phi[:-1], 0.02), axis=0)])
        c0 = (origin + yz(phi, 0.01)).mean(axis=0)
        d, a = c0 - origin[-1], phi[-1]
        tip = [0.0, np.cos(a) * d[0] + np.sin(a) * d[1], -np.sin(a) * d[0] + np.cos(a) * d[1]]
        np.testing.assert_allclose(com, tip, atol=1e-11)

    pytest.importorskip("mujoco")
    k = 200  # MJCF nests bodies in XML: a deep chain through the same walk
    xml = "".join(
        f'<body name="c{i}" pos="0 0.01 0.02"><joint name="h{i}" axis="1 0.2 0"/>'
        '<geom size="0.01" mass="0.1"/>'
        for i in range(k)
    )
    mjcf = tmp_path / "chain.xml"
    mjcf.write_text(
        f"<mujoco><worldbody><body name='base'><geom size='0.1'/>{xml}"
        + "</body>" * (k + 1)
        + "</worldbody></mujoco>"
    )
    chain = sescid.load_robot(mjcf, f"c{k - 1}")
    q = np.random.default_rng(1).uniform(-0.5, 0.5, (3, chain.nq))
    ref = mujoco_com(mjcf, f"c{k - 1}", chain.joint_names, q)
    assert chain.nq == k and np.abs(chain.com(q) - ref).max() <= 1e-12

    m = 20_000
    one = LinkInertial(1.0, np.eye(4), None)
    frames = {f"f{i}": Frame(f"f{i}", one) for i in range(m)}
    step = np.eye(4)
    step[2, 3] = 1.0
    edges = [Edge("", f"f{i - 1}", f"f{i}", step) for i in range(1, m)]
    bodies, where = reroot(Graph(tmp_path / "g", frames, edges), f"f{m - 1}")
    assert len(bodies) == 1 and bodies[0].mass == m
    assert bodies[0].com[2] == pytest.approx(-(m - 1) / 2) and where["f0"][1][2, 3] == 1 - m


def test_mjcf_pair_geoms_are_collision_geometry(tmp_path):
    """Feet that collide only through explicit <contact><pair> (contype = conaffinity = 0, a
    common MuJoCo Playground style) are collision shapes, not visual ones."""
    pytest.importorskip("mujoco")
    path = tmp_path / "pairs.xml"
    path.write_text(
        '<mujoco><worldbody><geom name="floor" type="plane" size="1 1 .1"/><body name="a">'
        '<geom name="torso" size="0.1" contype="0" conaffinity="0"/><body name="foot" pos="0 0 -1">'
        '<joint name="j"/><geom name="sole" type="box" size=".1 .05 .01" contype="0" '
        'conaffinity="0"/></body></body></worldbody><contact><pair geom1="floor" geom2="sole"/>'
        "</contact></mujoco>"
    )
    shapes = load_model(path, "a").shapes
    assert [(s.link, s.role) for s in shapes] == [("a", "visual"), ("foot", "collision")]
