"""MJCF (MuJoCo XML) → the same re-rooted body tree ``model.urdf.build_model`` makes from a URDF.

The file is compiled by MuJoCo itself (``mujoco.MjSpec``), and every number is taken from the
compiled ``MjModel`` (full double precision, angles in radians, inertia inferred from geoms where
the body has no ``<inertial>``), so the CoM sescid computes is MuJoCo's own ``subtree_com``.

How MJCF maps onto ``RobotModel`` (see ``sescid.model.tree`` for the frame conventions):

- the robot is the subtree of the top-level body (child of ``<worldbody>``) that holds the support
  frame; other top-level bodies are ignored. The top-level body's own joints (a free joint, or
  anything else that attaches it to the world) are dropped: CoM and CoP are expressed in the
  support frame, which does not see them;
- a body with no joint is welded into its parent (masses and CoMs merged, like URDF fixed
  joints);
- a hinge is a revolute joint. MuJoCo rotates a body about ``joint pos`` (body frame), so a body
  with hinges j_1 … j_k becomes a chain of k sescid bodies: the frame of the i-th sits on the axis
  of j_i, the first k − 1 are massless frames (``Body.frame_only``: MJCF cannot give them mass, so
  the consistent step pins their mass and first moment to 0) named ``"<body>:<joint>"``, the last
  is named after the MJCF body and carries its mass. The MJCF body frame is ``Trans(−pos_k)`` in
  that last frame;
- joint angles are ``qpos``; MuJoCo rotates by ``qpos − ref``, so the mimic offset of an
  ordinary joint is ``−ref``;
- an active ``<equality><joint joint1 joint2 polycoef>`` makes joint1 a mimic of joint2:
  ``qpos1 − ref1 = c0 + c1 (qpos2 − ref2)`` (multiplier c1, offset c0 − c1·ref2 plus joint2's own
  offset); a nonzero c2…c4 raises ModelError; with no joint2, joint1 is locked at ``ref1 + c0``
  and welds its body (a constant rotation);
- slide and ball joints (and a free joint below the top level) raise ModelError;
- joint limits: ``range`` when the joint is limited (radians after compilation), ±inf otherwise;
- sites are massless frames welded to their body: ``link_frames`` holds every MJCF body and every
  site, and either can be the support frame (a site gives the support frame its own pose).
  Unnamed bodies are called ``body<id>``, unnamed sites ``site<id>``, unnamed joints
  ``joint<id>`` (MuJoCo's ids: document order). A site named like a body is left out of
  ``link_frames`` (the body wins);
- mesh assets whose file cannot be found are dropped with their geoms (before compiling),
  provided every body that had such a geom has an explicit ``<inertial>``; otherwise ModelError.
  A note in ``RobotModel.notes`` says so;
- geoms become ``Shape``s in their sescid body's frame: role "collision" when ``contype`` or
  ``conaffinity`` ≠ 0 or a ``<contact><pair>`` names the geom, else "visual"; box, sphere,
  cylinder and capsule keep their kind (sizes as ``Shape`` documents: full box sides,
  cylinder/capsule radius and full segment length), an ellipsoid is covered by its bounding
  box, a mesh carries the compiled vertices (MuJoCo's own, scaled, in the body frame); planes,
  height fields and SDFs are left out.

Compiling and its checks live in ``mjcf_compile`` (``compiler fusestatic`` and ``alignfree`` off,
so every body keeps its own frame as written), the joint mapping in ``mjcf_joints``; here the
bodies, hinges and sites become a ``Graph`` that ``tree.reroot`` (the walk URDF uses too) roots
at the support frame.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np

from sescid.errors import ModelError
from sescid.model.geometry import BOX, CAPSULE, CYLINDER, MESH, SPHERE, Shape, ShapeRole
from sescid.model.graph import Edge, Frame, Graph, LinkInertial
from sescid.model.mjcf_compile import compile_mjcf, mujoco_module
from sescid.model.mjcf_joints import MjcfJoints, robot_joints
from sescid.model.tree import RobotModel, rooted_model, rot_axis


def quat_rotation(quat) -> np.ndarray:
    """(3, 3) rotation of a unit quaternion (w, x, y, z) (not normalised here)."""
    w, x, y, z = (float(v) for v in quat)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _pose(pos, quat) -> np.ndarray:
    """4×4 transform from a position (3,) and a unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(v) for v in quat)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    out = np.eye(4)
    out[:3, :3] = quat_rotation((w / n, x / n, y / n, z / n))
    out[:3, 3] = np.asarray(pos, dtype=float)
    return out


def _trans(v) -> np.ndarray:
    out = np.eye(4)
    out[:3, 3] = np.asarray(v, dtype=float)
    return out


def object_names(model: Any, kind: str, count: int, prefix: str) -> list[str]:
    """Every object's name by MuJoCo id (``<prefix><id>`` for an unnamed one), e.g.
    ``object_names(m, "body", m.nbody, "body")``."""
    return [getattr(model, kind)(i).name or f"{prefix}{i}" for i in range(count)]


#: the private names ``io.export.mjcf`` imports today (shims: use the public ones)
_mujoco, _names = mujoco_module, object_names


def _unique(names: list[str]) -> None:
    seen: set[str] = set()
    for i, n in enumerate(names):
        while n in seen:
            n += "_"
        names[i] = n
        seen.add(n)


def _support_body(path: Path, m: Any, support: str, bodies: list[str], sites: list[str]) -> int:
    """The MuJoCo id of the body that holds the support frame (a body or a site)."""
    if support in bodies[1:]:
        return bodies.index(support, 1)
    if support in sites:
        b = int(m.site_bodyid[sites.index(support)])
        if b == 0:
            raise ModelError(
                f"{path}: support site '{support}' is on the world body, not the robot"
            )
        return b
    frames = sorted(bodies[1:]) + sorted(sites)
    raise ModelError(
        f"{path}: unknown support frame '{support}' (bodies and sites: "
        f"{', '.join(frames[:12])}" + (", …)" if len(frames) > 12 else ")")
    )


def _body_frames(m: Any, b: int, name: str, prev: str | None, joints: MjcfJoints, names):
    """The frames and edges one MJCF body adds: a hinge chain (massless frames between its
    live hinges, the body's own frame last) or a weld to ``prev``; locked hinges are constant
    rotations folded into the transforms."""
    frames: list[Frame] = []
    edges: list[Edge] = []
    hinges = [j for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b])]
    hinges = [] if prev is None else hinges
    pending = _pose(m.body_pos[b], m.body_quat[b])  # transform since the last hinge frame
    for i, j in enumerate(hinges):
        jpos, axis = np.asarray(m.jnt_pos[j], float), np.asarray(m.jnt_axis[j], float)
        axis = axis / np.linalg.norm(axis)
        c, k, o = joints.drive[j]
        if c < 0:  # locked by an equality without joint2: a constant rotation
            rot = np.eye(4)
            rot[:3, :3] = rot_axis(axis, o)
            pending = pending @ _trans(jpos) @ rot @ _trans(-jpos)
            continue
        last = all(joints.drive[jj][0] < 0 for jj in hinges[i + 1 :])
        node = name if last else f"{name}:{names[j]}"
        if not last:
            frames.append(Frame(node, None, frame_only=True))
        assert prev is not None
        edges.append(
            Edge(names[j], prev, node, pending @ _trans(jpos), _trans(-jpos), axis, (c, k, o))
        )
        prev, pending = node, np.eye(4)
    if prev is not None and prev != name:  # no live hinge: welded into its parent
        edges.append(Edge("", prev, name, pending))
    elif edges:  # locked hinges after the last live one move the body frame in the last node
        e = edges[-1]
        assert e.after is not None
        edges[-1] = dataclasses.replace(e, after=e.after @ pending)
    inertia = np.diag(np.asarray(m.body_inertia[b], dtype=float))
    ipose = _pose(m.body_ipos[b], m.body_iquat[b])
    frames.append(Frame(name, LinkInertial(float(m.body_mass[b]), ipose, inertia)))
    return frames, edges


def mjcf_graph(path: Path, m: Any, in_robot: list[int], joints: MjcfJoints) -> Graph:
    """The robot's bodies (and hinge frames), hinges and sites as a format-neutral graph."""
    bodies = object_names(m, "body", m.nbody, "body")
    names = object_names(m, "joint", m.njnt, "joint")
    _unique(names)
    graph = Graph(path, {}, [])
    for b in in_robot:
        prev = bodies[m.body_parentid[b]] if b != in_robot[0] else None
        frames, edges = _body_frames(m, b, bodies[b], prev, joints, names)
        graph.frames |= {f.name: f for f in frames}
        graph.edges += edges
    robot = set(in_robot)
    for s, site in enumerate(object_names(m, "site", m.nsite, "site")):
        b = int(m.site_bodyid[s])
        if b in robot and site not in graph.frames:
            graph.frames[site] = Frame(site)
            graph.edges.append(Edge("", bodies[b], site, _pose(m.site_pos[s], m.site_quat[s])))
    return graph


def build_mjcf_model(path: str | Path, support: str) -> RobotModel:
    """Compile an MJCF file with MuJoCo and build the body tree rooted at ``support``.

    ``support``: an MJCF body or site name. ``RobotModel.notes`` receives informational lines
    (dropped meshes and root joints). See the module doc for the mapping.
    """
    path = Path(path)
    notes: list[str] = []
    spec, m = compile_mjcf(path, notes)
    body_names = object_names(m, "body", m.nbody, "body")
    joint_names = object_names(m, "joint", m.njnt, "joint")
    _unique(joint_names)
    sup = _support_body(path, m, support, body_names, object_names(m, "site", m.nsite, "site"))
    root = int(m.body_rootid[sup])
    in_robot = [b for b in range(1, m.nbody) if int(m.body_rootid[b]) == root]
    joints = robot_joints(path, m, in_robot, joint_names)
    graph = mjcf_graph(path, m, in_robot, joints)
    return rooted_model(
        graph,
        support,
        lambda frames: _shapes(spec, m, body_names, set(in_robot), frames),
        name=spec.modelname or path.stem,
        format="mjcf",
        joint_names=joints.names,
        joint_limits=joints.limits,
        model_root=body_names[root],
        notes=notes + joints.notes,
    )


def _shapes(spec, m, body_names, in_robot: set[int], link_frames) -> list[Shape]:
    """The robot's geoms as ``Shape``s in their sescid body frames (see the module doc)."""
    mujoco = mujoco_module()
    gt = mujoco.mjtGeom
    files = {mesh.name: mesh.file for mesh in spec.meshes}
    paired = set(m.pair_geom1[: m.npair].tolist()) | set(m.pair_geom2[: m.npair].tolist())
    out = []
    for g in range(m.ngeom):
        bid = int(m.geom_bodyid[g])
        if bid not in in_robot:
            continue
        b, x = link_frames[body_names[bid]]
        pose = x @ _pose(m.geom_pos[g], m.geom_quat[g])
        collides = m.geom_contype[g] or m.geom_conaffinity[g] or g in paired
        role: ShapeRole = "collision" if collides else "visual"
        size = np.asarray(m.geom_size[g], dtype=float)
        kind, mesh, verts = None, "", None
        t = m.geom_type[g]
        if t == gt.mjGEOM_BOX or t == gt.mjGEOM_ELLIPSOID:  # an ellipsoid: its bounding box
            kind, size = BOX, 2 * size
        elif t == gt.mjGEOM_SPHERE:
            kind, size = SPHERE, size[:1]
        elif t == gt.mjGEOM_CYLINDER:
            kind, size = CYLINDER, np.array([size[0], 2 * size[1]])
        elif t == gt.mjGEOM_CAPSULE:
            kind, size = CAPSULE, np.array([size[0], 2 * size[1]])
        elif t == gt.mjGEOM_MESH and m.geom_dataid[g] >= 0:
            k = int(m.geom_dataid[g])
            mname = m.mesh(k).name
            mesh = files.get(mname, "") or mname
            v = np.asarray(m.mesh_vert[m.mesh_vertadr[k] : m.mesh_vertadr[k] + m.mesh_vertnum[k]])
            kind, size, verts = MESH, np.zeros(0), v.astype(float) @ pose[:3, :3].T + pose[:3, 3]
        if kind is None:  # plane, height field, SDF
            continue
        out.append(Shape(kind, role, b, body_names[bid], pose, size, mesh, vertices=verts))
    return out


__all__ = ["build_mjcf_model", "compile_mjcf", "mjcf_graph", "mujoco_module", "object_names"]
