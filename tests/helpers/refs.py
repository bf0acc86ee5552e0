"""Independent references for the planning tests: lowest geometry points from MuJoCo (MJCF
geoms) and Pinocchio + coal (URDF collision meshes), CoMs from MuJoCo and Pinocchio, the
compliant CoP written out from its formulas, example-robot-data paths."""

from __future__ import annotations

import importlib.metadata
import math
from pathlib import Path

import numpy as np
import pytest
from humanoid_gen import HumanoidSpec, humanoid_mjcf
from mjcf_gen import _mujoco_states

G = 9.80665

# Load the kinematics kernels in this thread: kinematics.compile.load_group's first-call check
# (outside its lock) lets a second worker thread call a kernel not yet swapped (RecursionError)
# when the first load happens inside ordered_map's threads (reported; not the planner's file).
from sescid.kinematics.compile import GROUP, load_group  # noqa: E402

load_group(GROUP)


def erd(rel: str) -> Path:
    """A model of example-robot-data (skip when the package is not installed)."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("example-robot-data not installed")
    path = Path(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")) / rel
    if not path.is_file():
        pytest.skip(f"{rel} not in example-robot-data")
    return path


def write_humanoid(directory: Path, spec: HumanoidSpec | None = None, name="humanoid") -> Path:
    """The synthetic feet-only-collision humanoid as an MJCF file."""
    path = directory / f"{name}.xml"
    path.write_text(humanoid_mjcf(spec))
    return path


def _geom_lowest(model, data, g: int, rot: np.ndarray, pos: np.ndarray) -> float:
    """Lowest z [m] of MuJoCo geom g in the support frame (rot, pos: the support in the world)."""
    import mujoco

    r = rot.T @ data.geom_xmat[g].reshape(3, 3)
    c = rot.T @ (data.geom_xpos[g] - pos)
    size = model.geom_size[g]
    kind = model.geom_type[g]
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return c[2] - size[0]
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return c[2] - abs(r[2, 2]) * size[1] - size[0]
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return c[2] - abs(r[2, 2]) * size[1] - size[0] * math.sqrt(max(0.0, 1 - r[2, 2] ** 2))
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
        return float(((corners * size) @ r.T + c)[:, 2].min())
    raise AssertionError(f"geom type {kind} not handled by the reference")


def mj_lowest(path: Path, support: str, joint_names, q, skip_body: str) -> np.ndarray:
    """(n,) lowest point [m], support-frame z, of every body but ``skip_body`` and the world:
    its collision geoms, else its visual geoms, else its origin — from MuJoCo's own kinematics."""
    return np.min(list(mj_body_lowest(path, support, joint_names, q, skip_body).values()), axis=0)


def mj_body_lowest(
    path: Path, support: str, joint_names, q, skip_body: str, only: set[str] | None = None
) -> dict:
    """Body name → (n,) its lowest point [m] by the rule of ``mj_lowest`` (``only``: these
    bodies only)."""
    out: dict[str, list[float]] = {}
    for model, data, rot, pos, _ in _mujoco_states(path, support, joint_names, q, 0):
        for b in range(1, model.nbody):
            name = model.body(b).name
            if name == skip_body or (only is not None and name not in only):
                continue
            geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == b]
            coll = [g for g in geoms if model.geom_contype[g] or model.geom_conaffinity[g]]
            use = coll or geoms
            if use:
                low = min(_geom_lowest(model, data, g, rot, pos) for g in use)
            else:
                low = float((rot.T @ (data.xpos[b] - pos))[2])
            out.setdefault(name, []).append(low)
    return {k: np.array(v) for k, v in out.items()}


def mj_geom_corners(path: Path, support: str, joint_names, q, geom: str) -> np.ndarray:
    """(n, 8, 3) corners of a box geom in the support frame, m (MuJoCo)."""
    out = []
    for model, data, rot, pos, _ in _mujoco_states(path, support, joint_names, q, 0):
        g = model.geom(geom).id
        r = rot.T @ data.geom_xmat[g].reshape(3, 3)
        c = rot.T @ (data.geom_xpos[g] - pos)
        corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
        out.append((corners * model.geom_size[g]) @ r.T + c)
    return np.array(out)


class PinGeometry:
    """Collision-mesh vertices of a URDF in its support frame, by Pinocchio + coal (assimp)."""

    def __init__(self, urdf: Path, robot):
        import pinocchio as pin
        from oracle import PinOracle

        self.pin = pin
        mimic = {
            b.joint_name: (robot.joint_names[b.joint], b.multiplier, b.offset)
            for b in robot.model.bodies
            if b.joint >= 0 and b.joint_name not in robot.joint_names
        }
        self.oracle = PinOracle(urdf, robot.support, robot.joint_names, mimic)
        share = Path(urdf).resolve().parents[4]  # …/share, holding example-robot-data/
        self.geom = pin.buildGeomFromUrdf(
            self.oracle.model, str(urdf), pin.GeometryType.COLLISION, package_dirs=[str(share)]
        )
        self.gdata = pin.GeometryData(self.geom)
        self.shapes = [g.geometry for g in self.geom.geometryObjects]

    @staticmethod
    def _low(geo, rot: np.ndarray, t: np.ndarray) -> float:
        """Lowest z of a coal shape placed by (rot, t) in the support frame."""
        kind = type(geo).__name__
        if hasattr(geo, "vertices"):
            return float((np.asarray(geo.vertices()) @ rot.T + t)[:, 2].min())
        if kind == "Box":
            c = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
            return float(((c * np.asarray(geo.halfSide)) @ rot.T + t)[:, 2].min())
        if kind == "Sphere":
            return float(t[2] - geo.radius)
        az = rot[2, 2]
        if kind == "Cylinder":
            rim = geo.radius * math.sqrt(max(0.0, 1 - az * az))
            return float(t[2] - abs(az) * geo.halfLength - rim)
        if kind == "Capsule":
            return float(t[2] - abs(az) * geo.halfLength - geo.radius)
        raise AssertionError(f"coal shape {kind} not handled by the reference")

    def lowest(self, q: np.ndarray, skip_links: set[str]) -> tuple[np.ndarray, dict]:
        """(n,) lowest vertex z [m] over the collision meshes not on ``skip_links``, and per
        link the (n,) lowest z of its meshes."""
        pin, o = self.pin, self.oracle
        per: dict[str, np.ndarray] = {}
        for k, qk in enumerate(q):
            qp = o.q_pin(qk)
            pin.forwardKinematics(o.model, o.data, qp)
            pin.updateFramePlacements(o.model, o.data)
            pin.updateGeometryPlacements(o.model, o.data, self.geom, self.gdata)
            sup = o.data.oMf[o.frame]
            for i, g in enumerate(self.geom.geometryObjects):
                link = o.model.frames[g.parentFrame].name
                m = self.gdata.oMg[i]
                rot = sup.rotation.T @ m.rotation
                t = sup.rotation.T @ (m.translation - sup.translation)
                z = self._low(self.shapes[i], rot, t)
                arr = per.setdefault(link, np.full(len(q), np.inf))
                arr[k] = min(arr[k], z)
        low = np.min([v for n, v in per.items() if n not in skip_links], axis=0)
        return low, per


def compliant_cop_by_hand(com, jac, weight, kp, k_pad, contacts, floor, factor=2.0):
    """The dynamic CoP of ``planning.compliance`` written out pose by pose (no vectorisation):
    sag δq = −(W/kp) ∂c_z/∂q, tilt u = (K − W h)⁻¹ W (c' − p̄), e = c' + h u,
    e_dyn = c + factor (e − c)."""
    out = []
    d = contacts - contacts.mean(axis=0)
    k_mat = k_pad * (d.T @ d)
    for c, j in zip(com, jac, strict=True):
        dq = -(weight / kp) * j[2]
        cs = c[:2] + j[:2] @ dq
        h = c[2] - floor
        u = np.linalg.solve(k_mat - weight * h * np.eye(2), weight * (cs - contacts.mean(axis=0)))
        e = cs + h * u
        out.append(c[:2] + factor * (e - c[:2]))
    return np.array(out)
