"""USD export: a UsdPhysics layer read back with pxr holds every link's exported mass, CoM and
inertia (rebuilt from the principal moments and axes) to float32 precision; the standalone body
tree puts the whole-body CoM where the fit does; an override layer over the robot's own USD,
refused for another robot's; the same bytes twice; a one-line error without the extra."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import sescid
from sescid.errors import MissingExtraError, ModelError
from sescid.estimation.result.validation import perturbed_sesc
from sescid.io import export_usd
from sescid.io.export import exported_parts
from sescid.robots import example_path

pxr = pytest.importorskip("pxr")
from pxr import Gf, Usd, UsdGeom, UsdPhysics  # noqa: E402

pin = pytest.importorskip("pinocchio")
TALOS = (
    Path(pin.__file__).parents[4]
    / "share/example-robot-data/robots/talos_data/robots/talos_reduced.urdf"
)
HUMANOID = example_path("humanoid")
F32 = 2.0**-23  # float32 relative precision


def _consistent(path, support, fraction=0.04):
    robot = sescid.load_robot(path, support=support)
    sim = sescid.simulate(
        robot, 300, r_true=perturbed_sesc(robot, fraction, seed=1), seed=2, stable=True
    )
    return sescid.to_consistent(sescid.identify(robot, sim.q, sim.cop))


@pytest.fixture(scope="module")
def talos():
    if not TALOS.is_file():
        pytest.skip("example-robot-data's TALOS not installed")
    return _consistent(TALOS, "right_sole_link")


def _read(path: Path) -> dict[str, tuple[float, np.ndarray, np.ndarray, str]]:
    """name → (mass, CoM, inertia rebuilt from the principal moments and axes, prim path)."""
    stage = Usd.Stage.Open(str(path))
    out = {}
    for prim in stage.Traverse():
        if not prim.HasAPI(UsdPhysics.MassAPI):
            continue
        api = UsdPhysics.MassAPI(prim)
        q = api.GetPrincipalAxesAttr().Get()
        rot = np.array(Gf.Matrix3d(Gf.Rotation(Gf.Quatd(q)))).T  # Gf: row vectors
        d = np.array(api.GetDiagonalInertiaAttr().Get(), dtype=float)
        com = np.array(api.GetCenterOfMassAttr().Get(), dtype=float)
        out[prim.GetName()] = (
            float(api.GetMassAttr().Get()),
            com,
            rot @ np.diag(d) @ rot.T,
            str(prim.GetPath()),
        )
    return out


def _same(read, parts):
    assert set(read) == {p.link for p in parts}
    for p in parts:
        mass, com, tensor, _ = read[p.link]
        assert abs(mass - p.mass) <= F32 * p.mass
        assert np.abs(com - p.com).max() <= F32 * max(np.abs(p.com).max(), 1e-30)
        scale = np.abs(p.inertia).max()
        assert np.abs(tensor - p.inertia).max() <= 4 * F32 * scale


def test_standalone_layer_reads_back_to_float32_precision(talos, tmp_path):
    """Every link's mass, CoM and inertia (principal decomposition rebuilt) equal the exported
    values to float32 precision; the body tree's transforms give the fit's whole-body CoM."""
    out = tmp_path / "talos.usda"
    export_usd(talos, out, repair_inertia=True)
    parts, _ = exported_parts(talos, repair_inertia=True)
    read = _read(out)
    _same(read, parts)
    assert any(np.count_nonzero(p.inertia - np.diag(np.diag(p.inertia))) for p in parts)
    stage = Usd.Stage.Open(str(out))
    assert (
        UsdGeom.GetStageMetersPerUnit(stage) == 1
        and UsdPhysics.GetStageKilogramsPerUnit(stage) == 1
    )
    cache = UsdGeom.XformCache()
    first = np.zeros(3)
    for mass, com, _, path in read.values():
        world = np.array(cache.GetLocalToWorldTransform(stage.GetPrimAtPath(path))).T
        first += mass * (world[:3, :3] @ com + world[:3, 3])
    total = sum(v[0] for v in read.values())
    want = talos.predict_com(np.zeros((1, talos.robot.nq)))[0]
    assert np.abs(first / total - want).max() < 1e-6  # float32 values, metres


def test_over_the_robots_usd_and_refused_for_another_robot(talos, tmp_path):
    """An override layer over the robot's own USD (prims matched by name): the composed stage
    holds the exported values; another robot's USD is refused naming the links, nothing written."""
    robot_usd = tmp_path / "robot" / "talos_robot.usdc"
    robot_usd.parent.mkdir()
    export_usd(talos, robot_usd, repair_inertia=True)
    out = tmp_path / "layers" / "talos_masses.usda"
    out.parent.mkdir()
    export_usd(talos, out, over=robot_usd, repair_inertia=True)
    text = out.read_text()
    assert "@../robot/talos_robot.usdc@" in text and 'over "' in text and 'def "' not in text
    parts, _ = exported_parts(talos, repair_inertia=True)
    _same(_read(out), parts)
    other = _consistent(HUMANOID, "r_sole", fraction=0.15) if HUMANOID.is_file() else None
    if other is None:
        pytest.skip("no MJCF humanoid")
    wrong = tmp_path / "humanoid_masses.usda"
    with pytest.raises(ModelError, match=r"talos_robot.usdc: \d+ of the \d+ links with mass"):
        export_usd(other, wrong, over=robot_usd)
    assert not wrong.exists() and not list(tmp_path.glob(".humanoid*"))


@pytest.mark.parametrize("suffix", [".usda", ".usdc"])
def test_same_fit_same_bytes(talos, tmp_path, suffix):
    a, b = tmp_path / f"a{suffix}", tmp_path / f"b{suffix}"
    export_usd(talos, a, repair_inertia=True)
    export_usd(talos, b, repair_inertia=True)
    assert a.read_bytes() == b.read_bytes()


def test_without_the_extra_one_line_naming_it(talos, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pxr", None)
    with pytest.raises(MissingExtraError, match=r"pip install 'sescid\[usd\]'"):
        export_usd(talos, tmp_path / "x.usda", repair_inertia=True)
    assert not (tmp_path / "x.usda").exists()


def test_cli_writes_usd_not_xml(talos, tmp_path):
    """`export fit.json --out robot.usda` writes a USD layer (it used to write XML into it)."""
    from click.testing import CliRunner

    from sescid.cli import cli as main

    fit = tmp_path / "fit.json"
    sescid.save_fit(talos, fit)
    out = tmp_path / "robot.usda"
    res = CliRunner().invoke(main, ["export", str(fit), "--out", str(out), "--repair-inertia"])
    assert res.exit_code == 0, res.output
    assert out.read_text().startswith("#usda 1.0") and "PhysicsMassAPI" in out.read_text()
    res = CliRunner().invoke(main, ["export", str(fit), "--out", str(tmp_path / "r.urdf"),
                                    "--over", str(out), "--repair-inertia"])  # fmt: skip
    assert res.exit_code == 2 and "--over applies to a USD output" in res.output
