"""Test helpers: random MJCF kinematic trees, and MuJoCo's own CoM in a support frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _f(*values) -> str:
    return " ".join(repr(float(v)) for v in values)


def _unit(rng, n=3) -> np.ndarray:
    v = rng.normal(size=n)
    return v / np.linalg.norm(v)


def random_mjcf(seed: int, n_bodies: int = 9) -> tuple[str, list[str]]:
    """A random MJCF robot (XML text) and the names usable as support frames.

    Covers: free or fixed root, bodies with 0–3 hinges (joint ``pos`` off the body origin,
    ``ref`` ≠ 0, degrees and radians), explicit ``<inertial>`` (diaginertia/fullinertia,
    rotated) and geom-inferred inertia, unnamed joints, sites, a joint equality coupling and a
    locked hinge (equality without joint2), a second top-level object that is not the robot.
    """
    rng = np.random.default_rng(seed)
    degree = bool(rng.integers(2))
    ang = 180 / np.pi if degree else 1.0
    parents = [-1] + [int(rng.integers(0, i)) for i in range(1, n_bodies)]
    children: list[list[int]] = [[] for _ in range(n_bodies)]
    for i, p in enumerate(parents[1:], 1):
        children[p].append(i)
    hinges: list[str] = []  # joint names (named ones) in document order
    sites: list[str] = []
    jcount = [0]

    def body_xml(i: int, indent: str) -> list[str]:
        pos = rng.uniform(-0.2, 0.2, 3) if i else rng.uniform(-1, 1, 3)
        orient = ""
        kind = rng.integers(3)
        if kind == 0:
            orient = f' quat="{_f(*rng.normal(size=4))}"'
        elif kind == 1:
            orient = f' euler="{_f(*(rng.uniform(-np.pi, np.pi, 3) * ang))}"'
        lines = [f'{indent}<body name="b{i}" pos="{_f(*pos)}"{orient}>']
        ind = indent + "  "
        if i == 0:
            if rng.integers(2):
                lines.append(f'{ind}<freejoint name="root_free"/>')
        else:
            nh = int(rng.choice([0, 1, 1, 2, 3])) if i > 1 else int(rng.integers(1, 4))
            for _ in range(nh):
                jcount[0] += 1
                named = rng.random() > 0.2
                name = f"j{jcount[0]}"
                if named:
                    hinges.append(name)
                attrs = f' name="{name}"' if named else ""
                attrs += f' axis="{_f(*_unit(rng))}" pos="{_f(*rng.uniform(-0.05, 0.05, 3))}"'
                if rng.integers(2):
                    attrs += f' ref="{_f(rng.uniform(-0.5, 0.5) * ang)}"'
                if rng.integers(2):
                    lo = rng.uniform(-2, 0)
                    attrs += f' range="{_f(lo * ang, (lo + rng.uniform(0.5, 3)) * ang)}"'
                lines.append(f"{ind}<joint{attrs}/>")
        if rng.random() < 0.65:
            m = rng.uniform(0.05, 2)
            if rng.integers(2):
                d = rng.uniform(0.001, 0.01, 3)
                inertia = f'quat="{_f(*rng.normal(size=4))}" '
                inertia += f'diaginertia="{_f(d[0] + d[1], d[1] + d[2], d[0] + d[2])}"'
            else:
                d = rng.uniform(0.001, 0.01, 3)
                rot = np.linalg.qr(rng.normal(size=(3, 3)))[0]
                full = rot @ np.diag([d[0] + d[1], d[1] + d[2], d[0] + d[2]]) @ rot.T
                inertia = f'fullinertia="{_f(*full[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]])}"'
            lines.append(
                f'{ind}<inertial pos="{_f(*rng.uniform(-0.1, 0.1, 3))}" mass="{_f(m)}" {inertia}/>'
            )
        for g in range(int(rng.integers(1, 3))):
            size = rng.uniform(0.01, 0.05, 3)
            gtype = ["box", "sphere", "capsule"][g % 3]
            lines.append(
                f'{ind}<geom type="{gtype}" size="{_f(*size)}" '
                f'pos="{_f(*rng.uniform(-0.1, 0.1, 3))}"'
                f' quat="{_f(*rng.normal(size=4))}" density="{_f(rng.uniform(500, 2000))}"/>'
            )
        if rng.random() < 0.5:
            sites.append(f"s{i}")
            lines.append(
                f'{ind}<site name="s{i}" pos="{_f(*rng.uniform(-0.1, 0.1, 3))}" '
                f'quat="{_f(*rng.normal(size=4))}"/>'
            )
        for c in children[i]:
            lines += body_xml(c, ind)
        lines.append(f"{indent}</body>")
        return lines

    body = body_xml(0, "    ")
    eq = []
    if len(hinges) >= 3:
        j1, j2 = hinges[-1], hinges[0]
        eq.append(
            f'    <joint joint1="{j1}" joint2="{j2}" polycoef="{_f(rng.uniform(-0.3, 0.3) * ang)}'
            f' {_f(rng.uniform(-1.5, 1.5))} 0 0 0"/>'
        )
        eq.append(f'    <joint joint1="{hinges[1]}" polycoef="{_f(rng.uniform(-0.5, 0.5))}"/>')
    xml = [
        f'<mujoco model="rand{seed}">',
        f'  <compiler angle="{"degree" if degree else "radian"}"/>',
        "  <worldbody>",
        '    <geom name="floor" type="plane" size="5 5 0.1"/>',
        *body,
        '    <body name="crate" pos="2 0 0"><freejoint/><geom type="box" size=".1 .1 .1"/></body>',
        "  </worldbody>",
    ]
    if eq:
        xml += ["  <equality>", *eq, "  </equality>"]
    xml.append("</mujoco>")
    return "\n".join(xml) + "\n", [f"b{i}" for i in range(n_bodies)] + sites


def _mujoco_states(path, support, joint_names, q, seed):
    """Yield (model, data, support rotation (3, 3), support origin (3,), root body id) per pose.

    ``q`` (n, len(joint_names)) sets those joints' qpos; joints coupled by an active joint
    equality follow it; every other joint (a free root, say) gets a random value.
    """
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(Path(path)))
    data = mujoco.MjData(model)
    rng = np.random.default_rng(seed)
    is_site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, support) < 0
    if is_site:
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, support)
        bid = int(model.site_bodyid[sid])
    else:
        bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, support)
    root = int(model.body_rootid[bid])
    adr = []
    for name in joint_names:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if jid < 0:  # generated name joint<id>
            jid = int(name.removeprefix("joint"))
        adr.append(int(model.jnt_qposadr[jid]))
    eqs = [
        e
        for e in range(model.neq)
        if model.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT and model.eq_active0[e]
    ]
    for qn in np.atleast_2d(q):
        qpos = model.qpos0 + rng.uniform(-1, 1, model.nq)
        for j in range(model.njnt):
            if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
                a = model.jnt_qposadr[j]
                qpos[a + 3 : a + 7] /= np.linalg.norm(qpos[a + 3 : a + 7])
        qpos[adr] = qn
        for _ in range(len(eqs)):  # chains of couplings settle in as many passes
            for e in eqs:
                j1, j2 = model.eq_obj1id[e], model.eq_obj2id[e]
                a1 = model.jnt_qposadr[j1]
                c = model.eq_data[e, :5]
                x = (
                    0.0
                    if j2 < 0
                    else qpos[model.jnt_qposadr[j2]] - model.qpos0[model.jnt_qposadr[j2]]
                )
                qpos[a1] = (
                    model.qpos0[a1] + c[0] + c[1] * x + c[2] * x**2 + c[3] * x**3 + c[4] * x**4
                )
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        if is_site:
            pos, rot = data.site_xpos[sid], data.site_xmat[sid].reshape(3, 3)
        else:
            pos, rot = data.xpos[bid], data.xmat[bid].reshape(3, 3)
        yield model, data, rot, pos, root


def mujoco_com(path: str | Path, support: str, joint_names: list[str], q: np.ndarray, seed=0):
    """MuJoCo's CoM (n, 3) of the support's top-level subtree, in the support frame, m.

    Joint values as in ``_mujoco_states``.
    """
    out = [
        rot.T @ (data.subtree_com[root] - pos)
        for _, data, rot, pos, root in _mujoco_states(path, support, joint_names, q, seed)
    ]
    return np.array(out).reshape(-1, 3)


def mujoco_geom_poses(path, support: str, joint_names: list[str], q: np.ndarray, seed=0):
    """MuJoCo's geom frames (n, ngeom, 4, 4) in the support frame, m (joints as in mujoco_com)."""
    out = []
    for model, data, rot, pos, _ in _mujoco_states(path, support, joint_names, q, seed):
        poses = np.tile(np.eye(4), (model.ngeom, 1, 1))
        poses[:, :3, :3] = rot.T @ data.geom_xmat.reshape(-1, 3, 3)
        poses[:, :3, 3] = (data.geom_xpos - pos) @ rot
        out.append(poses)
    return np.array(out)
