"""Support candidates of any model: its feet, found from the tree and the geometry, with their
lowest faces and the frames on them a robot can stand on.

The model is read rooted at its own root link (``model_root``) and posed at q = 0 in the file's
world frame (z up; an MJCF root body's own rotation applied). The bodies whose geometry
(collision, else visual) reaches within ``FOOT_BAND`` of the robot's height of its lowest point
are the low bodies; each chain of them (a foot, its toes, an ankle link reaching low) is one
foot, whose body is the one with the largest face under it (``model.sole.footprint``), or,
when none has a face under it (a foot tilted at q = 0), the largest flat face
(``model.sole.largest_footprint``). A foot's frames (links welded into it, MJCF sites on
it) are ranked by ``model.sole.level_check``: level frames on the sole plane (a sole frame),
then level frames above it (a foot frame), then level frames at the edge of the face under them
(a sole-corner site), then the others.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sescid.errors import ModelError
from sescid.model.sole import (
    CONTACT_TOL,
    body_points,
    footprint,
    largest_footprint,
    level_check,
)
from sescid.model.tree import Body, RobotModel, rot_axis

#: low bodies reach within this share of the robot's height of its lowest point at q = 0
FOOT_BAND = 0.05
#: m: a level frame this close to the sole plane is a sole frame
ON_SOLE = 0.002
#: m²: a foot's largest flat face is at least this (10 x 10 mm): a shin's line is no sole
MIN_FACE = 1e-4
#: a frame whose origin lies beyond this share of the half-length or half-width of the face
#: under it from the face's middle is at its edge (a sole-corner site; iCub's r_sole, above its
#: ankle, lies at 0.63 of the half-length)
EDGE = 0.9


@dataclass(frozen=True)
class FootCandidate:
    """One foot of a model and the frames on it (lengths in m)."""

    body: str  #: the foot's body (its main link)
    size: tuple[float, float]  #: the lowest face under its best frame, along that frame's x, y
    #: (frame, height above the sole plane [m], level) for each frame on the foot, best first
    frames: tuple[tuple[str, float, bool], ...]
    #: the frames whose origin lies at the edge of the face under them (a sole-corner site)
    edge: tuple[str, ...] = ()

    @property
    def support(self) -> str:
        """The frame to give as the support: the best-ranked one."""
        return self.frames[0][0] if self.frames else self.body

    def describe(self) -> str:
        """One line: the foot, its sole and its frames."""
        parts = []
        for name, h, level in self.frames[:4]:
            where = "on the sole" if abs(h) <= ON_SOLE else f"{h * 1e3:+.0f} mm"
            edge = ", at its edge" if level and name in self.edge else ""
            parts.append(f"{name} ({where}{', level' if level else ', not level'}{edge})")
        more = " …" if len(self.frames) > 4 else ""
        if self.frames and self.frames[0][2] and self.support in self.edge:
            more += " (no level frame near the sole's middle: the CoP box stays centred on it)"
        return (
            f"{self.body}: lowest face {self.size[0]:.3f} x {self.size[1]:.3f} m; frames: "
            + ", ".join(parts)
            + more
        )


def root_frame(path: str | Path) -> tuple[str, np.ndarray]:
    """(the model file's root link or top body, its rotation (3, 3) in the file's world)."""
    from sescid.model.load import model_format

    path = Path(path)
    if model_format(path) == "mjcf":
        from sescid.model.mjcf import compile_mjcf, object_names

        _, m = compile_mjcf(path, [])
        names = object_names(m, "body", m.nbody, "body")
        roots = sorted({int(m.body_rootid[b]) for b in range(1, m.nbody)})
        if not roots:
            raise ModelError(f"{path}: no body")
        mass = {r: sum(m.body_mass[b] for b in range(m.nbody) if m.body_rootid[b] == r)
                for r in roots}  # fmt: skip
        root = max(roots, key=lambda r: (mass[r], -r))
        rot = np.zeros(9)
        import mujoco

        mujoco.mju_quat2Mat(rot, np.asarray(m.body_quat[root], dtype=float))
        return names[root], rot.reshape(3, 3)
    from sescid.model.urdf_check import check_urdf
    from sescid.model.urdf_parse import load_urdf

    urdf = load_urdf(path)
    error: ModelError | None = None
    for link in urdf.robot.links:
        try:
            return check_urdf(path, urdf, link.name).root, np.eye(3)
        except ModelError as exc:  # a dropped world link: try the next
            error = exc
    raise error or ModelError(f"{path}: no link")


def zero_pose(bodies: list[Body]) -> tuple[np.ndarray, np.ndarray]:
    """Body rotations (N, 3, 3) and origins (N, 3) [m] at q = 0 in the root body's frame."""
    n = len(bodies)
    rot, org = np.zeros((n, 3, 3)), np.zeros((n, 3))
    for i, b in enumerate(bodies):  # parents come before their children
        if b.parent < 0:
            rot[i] = np.eye(3)
            continue
        p = b.parent
        turn = rot_axis(b.axis, b.sign * b.offset) if b.joint >= 0 else np.eye(3)
        rot[i] = rot[p] @ b.rot_const @ turn
        org[i] = org[p] + rot[p] @ b.trans_const
    return rot, org


def find_feet(model: RobotModel, up: np.ndarray | None = None) -> list[FootCandidate]:
    """The model's feet (module docstring), ordered by their body's index. ``model`` is rooted
    at any frame; ``up`` (3, 3): the root body's rotation in the world (default: identity)."""
    from sescid.model.meshes import with_mesh_vertices

    shapes = model.shapes
    if model.format == "urdf":
        shapes = with_mesh_vertices(shapes, model.path)[0]
    rot, org = zero_pose(model.bodies)
    r0 = np.eye(3) if up is None else np.asarray(up, dtype=float)
    rot = np.einsum("ij,njk->nik", r0, rot)
    org = org @ r0.T
    n = len(model.bodies)
    low = np.full(n, np.inf)
    high = np.full(n, -np.inf)
    shaped = np.zeros(n, dtype=bool)
    for b in range(n):
        p, _ = body_points(shapes, b, rot[b], org[b])
        shaped[b] = p is not None
        z = org[b, 2:3] if p is None else p[:, 2]
        low[b], high[b] = float(z.min()), float(z.max())
    height = float(high.max() - low.min())
    if not height > 0:
        return []
    cand = [b for b in range(n) if shaped[b] and low[b] <= low.min() + FOOT_BAND * height]
    frames = {b: {k: x for k, (bb, x) in model.link_frames.items() if bb == b} for b in cand}
    # the face under each body (world −z at q = 0), else its largest (a foot tilted at q = 0)
    down = {b: footprint(shapes, b, rot[b].T) for b in cand}
    face = {b: largest_footprint(shapes, b, [x[:3, :3] for x in frames[b].values()])
            for b in cand}  # fmt: skip
    out = []
    for group in _chains(model.bodies, cand, shaped):
        flat = [b for b in group if down[b] >= MIN_FACE]
        best = max(flat or group, key=lambda b: (down[b] if flat else face[b], -low[b], -b))
        if face[best] >= MIN_FACE:
            out.append((best, _foot(model, shapes, best, frames[best])))
    return [f for _, f in sorted(out, key=lambda t: t[0])]


def _chains(bodies: list[Body], cand: list[int], shaped: np.ndarray) -> list[list[int]]:
    """The candidate bodies grouped by tree adjacency: parent and child, through bodies without
    geometry (a joint split into several bodies)."""
    parent = np.full(len(bodies), -1)
    for i, b in enumerate(bodies):  # parents come before their children
        p = b.parent
        parent[i] = -1 if p < 0 else p if shaped[p] else parent[p]
    group = {b: b for b in cand}

    def find(b: int) -> int:
        while group[b] != b:
            b = group[b]
        return b

    for b in cand:
        if parent[b] in group:
            group[find(b)] = find(int(parent[b]))
    out: dict[int, list[int]] = {}
    for b in cand:
        out.setdefault(find(b), []).append(b)
    return [sorted(v) for _, v in sorted(out.items())]


def _foot(model: RobotModel, shapes, b: int, on_body: dict) -> FootCandidate:
    """The foot of body ``b``: its frames ranked by ``level_check`` and their height above the
    lowest face under them (module docstring); the size is that of the best frame's face."""
    ranked = []
    for name, x in on_body.items():
        chk = level_check(shapes, b, x, on_body)
        pts, _ = body_points(shapes, b, x[:3, :3].T, -x[:3, :3].T @ x[:3, 3])
        assert pts is not None
        h = -float(pts[:, 2].min())  # the frame above the lowest point under its −z
        touch = pts[pts[:, 2] < pts[:, 2].min() + CONTACT_TOL]
        ext = touch[:, :2].max(axis=0) - touch[:, :2].min(axis=0)
        mid = (touch[:, :2].max(axis=0) + touch[:, :2].min(axis=0)) / 2
        edge = bool(np.any(np.abs(mid) > EDGE * ext / 2))
        # level frames on the sole, then level ones above it, then level ones at the face's
        # edge (a corner site is no sole frame), then the rest
        rank = 3 if not chk.level else 2 if edge else 0 if abs(h) <= ON_SOLE else 1
        # ties: the frame nearer the middle of the face under it, then by name
        off = float(np.hypot(*mid))
        size = (float(ext[0]), float(ext[1]))
        ranked.append((rank, round(abs(h), 4), round(off, 4), name, h, chk.level, size, edge))
    ranked.sort()
    frames = tuple((name, h, level) for *_, name, h, level, _, _ in ranked)
    edges = tuple(r[3] for r in ranked if r[7])
    size = ranked[0][6] if ranked else (0.0, 0.0)
    return FootCandidate(model.bodies[b].name, size, frames, edges)


def frame_up(path: str | Path, frame: str) -> np.ndarray:
    """(3,) the z axis of frame ``frame`` in the model file's world (z up) at q = 0: (0, 0, 1)
    for a frame held upright; the CMU humanoid's y-up root gives (0, −1, 0)."""
    from sescid.model.load import load_model

    root, up = root_frame(path)
    model = load_model(path, root)
    if frame not in model.link_frames:
        raise ModelError(f"{Path(path).name}: no frame '{frame}'")
    b, x = model.link_frames[frame]
    rot, _ = zero_pose(model.bodies)
    return up @ rot[b] @ x[:3, 2]


def support_candidates(path: str | Path) -> list[FootCandidate]:
    """The feet of the model file ``path`` (``find_feet`` on the model rooted at its root)."""
    from sescid.model.load import load_model

    root, up = root_frame(path)
    return find_feet(load_model(path, root), up)


__all__ = ["FOOT_BAND", "FootCandidate", "find_feet", "frame_up", "root_frame",
           "support_candidates", "zero_pose"]  # fmt: skip
