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
  ``conaffinity`` ≠ 0 or when a ``<contact><pair>`` names them, else "visual"; box, sphere,
  cylinder and capsule keep their kind (sizes as ``Shape`` documents: full box sides,
  cylinder/capsule radius and full segment length), an ellipsoid is covered by its bounding
  box, a mesh carries the compiled vertices (MuJoCo's own, scaled, in the body frame); planes,
  height fields and SDFs are left out.

``compiler fusestatic`` and ``alignfree`` are switched off before compiling so that every body
keeps its own frame as written (neither changes the physics).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from xml.etree import ElementTree

import numpy as np

from sescid.errors import MissingExtraError, ModelError
from sescid.model.geometry import BOX, CAPSULE, CYLINDER, MESH, SPHERE, Shape
from sescid.model.tree import Body, RobotModel, inv_transform, rot_axis
from sescid.model.urdf import _main_link


def _mujoco():
    """The ``mujoco`` module, imported on first use (MissingExtraError without the extra)."""
    try:
        import mujoco
    except ImportError:
        raise MissingExtraError("reading MJCF", "mujoco") from None
    return mujoco


def _pose(pos, quat) -> np.ndarray:
    """4×4 transform from a position (3,) and a unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(v) for v in quat)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    out = np.eye(4)
    out[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    out[:3, 3] = np.asarray(pos, dtype=float)
    return out


def _trans(v) -> np.ndarray:
    out = np.eye(4)
    out[:3, 3] = np.asarray(v, dtype=float)
    return out


def _first_line(exc: Exception) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _mesh_file(spec, mesh, base: Path) -> Path | None:
    """Where MuJoCo would look for a mesh asset's file (None: the mesh has no file)."""
    name = mesh.file
    if not name:
        return None
    f = Path(name)
    if spec.strippath:
        f = Path(f.name)
    if f.is_absolute():
        return f
    meshdir = Path(spec.meshdir or spec.compiler.meshdir or "")
    return (
        f if f.is_absolute() else (base / meshdir / f if not meshdir.is_absolute() else meshdir / f)
    )


def compile_mjcf(path: str | Path, notes: list[str] | None = None):
    """Parse and compile an MJCF file → (MjSpec, MjModel); see the module doc for the edits.

    ``notes`` (a list), when given, receives one line per dropped mesh.
    """
    mujoco = _mujoco()
    path = Path(path)
    if not path.is_file():
        raise ModelError(f"{path}: MJCF file not found")
    try:  # strict XML first: one clear line for a broken file
        root = ElementTree.parse(path).getroot()
    except (ElementTree.ParseError, OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"{path}: malformed MJCF (XML: {exc})") from None
    if root.tag != "mujoco":
        raise ModelError(f"{path}: not an MJCF file (root element <{root.tag}>, not <mujoco>)")
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except Exception as exc:
        raise ModelError(f"{path}: malformed MJCF ({_first_line(exc)})") from None
    spec.compiler.fusestatic = False
    spec.compiler.alignfree = False

    # Mesh assets whose files are missing: drop them and their geoms (mass from <inertial>).
    missing = {}
    for mesh in list(spec.meshes):
        f = _mesh_file(spec, mesh, path.parent)
        if f is not None and not f.is_file():
            missing[mesh.name] = (mesh, f)
    if missing:
        from_geom = (
            spec.compiler.inertiafromgeom == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE
        )
        dropped: dict[str, int] = {}
        for geom in list(spec.geoms):
            if geom.type != mujoco.mjtGeom.mjGEOM_MESH or geom.meshname not in missing:
                continue
            body = geom.parent
            bname = body.name or "<unnamed body>"
            if body.name != "world" and (from_geom or not body.explicitinertial):
                raise ModelError(
                    f"{path}: body '{bname}' has a mesh geom whose file "
                    f"{missing[geom.meshname][1]} is missing and no explicit <inertial> "
                    "(its mass would come from that mesh)"
                )
            dropped[bname] = dropped.get(bname, 0) + 1
            spec.delete(geom)
        for mesh, _ in missing.values():
            spec.delete(mesh)
        if notes is not None:
            example = next(iter(missing.values()))[1]
            notes.append(
                f"{path}: {len(missing)} mesh file(s) not found (e.g. {example}); "
                f"dropped {sum(dropped.values())} mesh geom(s) of {len(dropped)} bodies "
                "(their masses come from explicit <inertial> elements)"
            )
    try:
        model = spec.compile()
    except Exception as exc:
        raise ModelError(f"{path}: MuJoCo cannot compile the MJCF ({_first_line(exc)})") from None
    return spec, model


def _names(model, kind: str, count: int, prefix: str) -> list[str]:
    return [getattr(model, kind)(i).name or f"{prefix}{i}" for i in range(count)]


def build_model(path: str | Path, support: str) -> RobotModel:
    """Compile an MJCF file with MuJoCo and build the body tree rooted at ``support``.

    ``support``: an MJCF body or site name. ``RobotModel.notes`` receives informational lines
    (dropped meshes and root joints). See the module doc for the mapping.
    """
    mujoco = _mujoco()
    path = Path(path)
    notes: list[str] = []
    spec, m = compile_mjcf(path, notes)
    hinge, free = mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_FREE
    body_names = _names(m, "body", m.nbody, "body")
    site_names = _names(m, "site", m.nsite, "site")
    joint_names_all = _names(m, "joint", m.njnt, "joint")
    _unique(joint_names_all)

    # Support frame: a body (not the world) or a site.
    if support in body_names[1:]:
        sup_body = body_names.index(support, 1)
    elif support in site_names:
        sup_body = int(m.site_bodyid[site_names.index(support)])
    else:
        frames = sorted(body_names[1:]) + sorted(site_names)
        raise ModelError(
            f"{path}: unknown support frame '{support}' (bodies and sites: "
            f"{', '.join(frames[:12])}" + (", …)" if len(frames) > 12 else ")")
        )
    if sup_body == 0:
        raise ModelError(f"{path}: support site '{support}' is on the world body, not the robot")
    root = int(m.body_rootid[sup_body])
    in_robot = [b for b in range(1, m.nbody) if int(m.body_rootid[b]) == root]

    # Joints of the robot: the top-level body's are dropped; hinges only below it.
    dropped = []
    for b in in_robot:
        for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]):
            jt = m.jnt_type[j]
            if b == root:
                dropped.append(joint_names_all[j])
            elif jt == free:
                raise ModelError(
                    f"{path}: joint '{joint_names_all[j]}' is a free joint below the top-level "
                    "body; only a free root joint is supported"
                )
            elif jt != hinge:
                kind = mujoco.mjtJoint(jt).name.removeprefix("mjJNT_").lower()
                raise ModelError(
                    f"{path}: joint '{joint_names_all[j]}' is a {kind} joint; only hinge joints "
                    "are supported (the SESC form needs rotations only)"
                )
    if dropped:
        notes.append(
            f"{path}: joints of the top-level body '{body_names[root]}' dropped "
            f"({', '.join(dropped)}): the support frame does not see them"
        )
    robot_joints = [
        j
        for b in in_robot
        if b != root
        for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b])
    ]
    robot_set = set(robot_joints)

    # Joint equalities: joint1 follows a polynomial of joint2 (linear only).
    follows: dict[int, tuple[int, float, float]] = {}  # j1 → (j2 or −1, c1, c0)
    for e in range(m.neq):
        if m.eq_type[e] != mujoco.mjtEq.mjEQ_JOINT or not m.eq_active0[e]:
            continue
        j1, j2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        if j1 not in robot_set:
            continue
        ename = m.equality(e).name or f"equality {e}"
        coef = np.asarray(m.eq_data[e, :5], dtype=float)
        if np.any(coef[2:] != 0):
            raise ModelError(
                f"{path}: joint equality '{ename}' ({joint_names_all[j1]} from "
                f"{joint_names_all[j2] if j2 >= 0 else 'a constant'}) has nonzero polycoef "
                f"{coef[2:].tolist()} beyond the linear term; only linear couplings are supported"
            )
        if j2 >= 0 and j2 not in robot_set:
            raise ModelError(
                f"{path}: joint equality '{ename}' couples '{joint_names_all[j1]}' to "
                f"'{joint_names_all[j2]}', which is not a hinge of the robot below its root"
            )
        if j1 in follows:
            raise ModelError(f"{path}: joint '{joint_names_all[j1]}' is coupled twice")
        follows[j1] = (j2, float(coef[1]), float(coef[0]))

    independent = [j for j in robot_joints if j not in follows]
    joint_names = [joint_names_all[j] for j in independent]
    col = {j: i for i, j in enumerate(independent)}
    ref = m.qpos0[m.jnt_qposadr]
    drive: dict[int, tuple[int, float, float]] = {}  # angle = k q[col] + o (col −1: constant o)

    def resolve(j: int, seen: tuple[int, ...] = ()) -> tuple[int, float, float]:
        if j in drive:
            return drive[j]
        if j in seen:
            raise ModelError(f"{path}: joint equalities form a loop through '{joint_names_all[j]}'")
        if j not in follows:
            out = (col[j], 1.0, -float(ref[j]))
        else:
            j2, c1, c0 = follows[j]
            if j2 < 0:
                out = (-1, 0.0, c0)
            else:
                c2, k2, o2 = resolve(j2, (*seen, j))
                out = (c2, c1 * k2, c0 + c1 * o2)
        drive[j] = out
        return out

    for j in robot_joints:
        resolve(j)
    limits = np.empty((len(independent), 2))
    for i, j in enumerate(independent):
        limits[i] = m.jnt_range[j] if m.jnt_limited[j] else (-np.inf, np.inf)

    # URDF-like graph: nodes (frames with mass) and edges (fixed or hinge), parent → child.
    nodes: dict[str, tuple[float, np.ndarray]] = {}  # name → (mass, CoM in the node frame)
    edges: list[dict] = []

    def add_edge(name, parent, child, o_mat, p_mat, axis, drv):
        edges.append(
            {"name": name, "parent": parent, "child": child, "O": o_mat, "P": p_mat}
            | {"axis": axis, "drive": drv}
        )

    body_node = {}
    frame_nodes: set[str] = set()  # massless frames between two hinges of one MJCF body
    for b in in_robot:
        name = body_names[b]
        t_body = _pose(m.body_pos[b], m.body_quat[b])
        prev = body_names[m.body_parentid[b]] if b != root else None
        joints = [j for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b])]
        joints = [] if b == root else joints
        pending = t_body  # transform accumulated since the last hinge node
        for i, j in enumerate(joints):
            jpos, axis = np.asarray(m.jnt_pos[j], float), np.asarray(m.jnt_axis[j], float)
            axis = axis / np.linalg.norm(axis)
            c, k, o = drive[j]
            if c < 0:  # locked by an equality without joint2: a constant rotation
                rot = np.eye(4)
                rot[:3, :3] = rot_axis(axis, o)
                pending = pending @ _trans(jpos) @ rot @ _trans(-jpos)
                continue
            last = all(drive[jj][0] < 0 for jj in joints[i + 1 :])
            node = name if last else f"{name}:{joint_names_all[j]}"
            nodes[node] = (0.0, np.zeros(3))
            if not last:
                frame_nodes.add(node)
            add_edge(
                joint_names_all[j],
                prev,
                node,
                pending @ _trans(jpos),
                _trans(-jpos),
                axis,
                (c, k, o),
            )
            prev, pending = node, np.eye(4)
        if prev is None or prev != name:  # no (live) hinge: welded into its parent
            nodes[name] = (0.0, np.zeros(3))
            if prev is not None:
                add_edge("", prev, name, pending, np.eye(4), None, None)
        else:  # locked hinges after the last live one move the body frame in the last node
            edges[-1]["P"] = edges[-1]["P"] @ pending
        nodes[name] = (float(m.body_mass[b]), np.asarray(m.body_ipos[b], dtype=float).copy())
        body_node[b] = name
    for s in range(m.nsite):
        b = int(m.site_bodyid[s])
        if b not in body_node or site_names[s] in nodes:
            continue
        nodes[site_names[s]] = (0.0, np.zeros(3))
        add_edge(
            "",
            body_node[b],
            site_names[s],
            _pose(m.site_pos[s], m.site_quat[s]),
            np.eye(4),
            None,
            None,
        )
    name = spec.modelname or path.stem
    model = _reroot(
        path, name, nodes, edges, support, joint_names, limits, body_names[root], frame_nodes
    )
    model.shapes = _shapes(spec, m, body_names, set(in_robot), model.link_frames)
    model.notes = notes
    return model


def _shapes(spec, m, body_names, in_robot: set[int], link_frames) -> list[Shape]:
    """The robot's geoms as ``Shape``s in their sescid body frames (see the module doc)."""
    mujoco = _mujoco()
    gt = mujoco.mjtGeom
    files = {mesh.name: mesh.file for mesh in spec.meshes}
    paired = {int(g) for g in m.pair_geom1} | {int(g) for g in m.pair_geom2}  # <contact><pair>
    out = []
    for g in range(m.ngeom):
        bid = int(m.geom_bodyid[g])
        if bid not in in_robot:
            continue
        b, x = link_frames[body_names[bid]]
        pose = x @ _pose(m.geom_pos[g], m.geom_quat[g])
        collides = m.geom_contype[g] or m.geom_conaffinity[g] or g in paired
        role = "collision" if collides else "visual"
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


def _unique(names: list[str]) -> None:
    seen: set[str] = set()
    for i, n in enumerate(names):
        while n in seen:
            n += "_"
        names[i] = n
        seen.add(n)


def _reroot(
    path, model_name, nodes, edges, support, joint_names, limits, root_name, frame_nodes
) -> RobotModel:
    """Walk the graph from the support node: sescid bodies exactly as ``model.build_model``."""
    adj: dict[str, list[dict]] = {n: [] for n in nodes}
    child_edge = {}
    for e in edges:
        adj[e["parent"]].append(e)
        adj[e["child"]].append(e)
        child_edge[e["child"]] = e
    link_frames: dict[str, tuple[int, np.ndarray]] = {support: (0, np.eye(4))}
    rows = [{"name": support, "links": [support], "parent": -1, "edge": None, "sign": 1.0}]
    rows[0] |= {"axis": np.array([0.0, 0.0, 1.0]), "C": np.eye(3), "t": np.zeros(3)}

    def visit(node: str, via) -> None:
        b, x_node = link_frames[node]
        for e in adj[node]:
            if e is via:
                continue
            down = e["parent"] == node
            other = e["child"] if down else e["parent"]
            if e["drive"] is None:  # fixed
                link_frames[other] = (b, x_node @ (e["O"] if down else inv_transform(e["O"])))
                rows[b]["links"].append(other)
                visit(other, e)
                continue
            if down:  # F_new = X · O · Rot(a, q); the child frame is P in F_new
                t_const, x_other, sign = x_node @ e["O"], e["P"], 1.0
            else:  # F_new = X · P⁻¹ · Rot(a, −q); the parent frame is O⁻¹ in F_new
                t_const, x_other, sign = x_node @ inv_transform(e["P"]), inv_transform(e["O"]), -1.0
            rows.append(
                {
                    "name": other,
                    "links": [other],
                    "parent": b,
                    "edge": e,
                    "sign": sign,
                    "axis": e["axis"],
                    "C": t_const[:3, :3].copy(),
                    "t": t_const[:3, 3].copy(),
                }
            )
            link_frames[other] = (len(rows) - 1, x_other)
            visit(other, e)

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 4 * len(nodes) + 100))
    try:
        visit(support, None)
    finally:
        sys.setrecursionlimit(limit)

    class _J:  # _main_link asks only whether a node's parent edge is fixed
        def __init__(self, e):
            self.type = "fixed" if e["drive"] is None else "revolute"

    rows[0]["name"] = _main_link(
        rows[0]["links"], {k: _J(e) for k, e in child_edge.items()}, support
    )
    bodies = []
    for i, row in enumerate(rows):
        mass, first = 0.0, np.zeros(3)
        for lk in row["links"]:
            mk, ck = nodes[lk]
            if mk > 0:
                x = link_frames[lk][1]
                first += mk * (x[:3, :3] @ ck + x[:3, 3])
                mass += mk
        e = row["edge"]
        jcol, mult, off = (-1, 1.0, 0.0) if e is None else e["drive"]
        bodies.append(
            Body(
                name=row["name"],
                links=tuple(row["links"]),
                parent=row["parent"] if i else -1,
                joint=jcol,
                joint_name="" if e is None else e["name"],
                sign=row["sign"],
                multiplier=mult,
                offset=off,
                axis=row["axis"],
                rot_const=row["C"],
                trans_const=row["t"],
                mass=mass,
                com=first / mass if mass > 0 else np.zeros(3),
                frame_only=i > 0 and all(lk in frame_nodes for lk in row["links"]),
            )
        )
    if not sum(b.mass for b in bodies) > 0:
        raise ModelError(f"{path}: the robot has no mass")
    return RobotModel(
        name=model_name,
        path=path.resolve(),
        format="mjcf",
        support=support,
        joint_names=joint_names,
        joint_limits=limits,
        bodies=bodies,
        link_frames=link_frames,
        root_rotation=np.eye(3),
        root_origin=np.zeros(3),
        model_root=root_name,
    )
