"""Self-collision: collision shapes covered by capsules, capsule pairs checked per pose.

Every collision box, cylinder, capsule and sphere of the model (``RobotModel.shapes``) is covered by
capsules fixed in its body frame; pairs of parent/child bodies (through bodies without shapes:
a joint split into several bodies) and pairs that already overlap at the zero pose are skipped.
The per-pose check is a compiled loop with early exit (``collision_free_mask``);
``collision_free_mask_numpy`` is the plain-numpy reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sescid.model.geometry import BOX, CAPSULE, CYLINDER, MESH, SPHERE
from sescid.planning.feasibility.capsule_kernels import first_contact_kernel
from sescid.robot import Robot

_CAPSULE_RMAX = 0.025  #: m, largest capsule radius used to cover a box cross-section


@dataclass
class Capsules:
    """Collision capsules, each fixed in a body frame: segment p0–p1 [m] and radius [m]."""

    body: np.ndarray  #: (C,) body index
    p0: np.ndarray  #: (C, 3) m, body frame
    p1: np.ndarray  #: (C, 3) m, body frame
    radius: np.ndarray  #: (C,) m
    link: list[str]  #: URDF link of each capsule
    pairs: np.ndarray  #: (P, 2) capsule pairs checked for self-collision
    skipped_zero: list[tuple[str, str]] = field(default_factory=list)  #: bodies touching at q = 0
    notes: list[str] = field(default_factory=list)
    from_mesh: np.ndarray | None = None  #: (C,) bool: a mesh's bounding capsule

    def world(self, rot: np.ndarray, org: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Segment ends (n, C, 3) [m] in the support frame from body rotations/origins."""
        r = rot[:, self.body]
        o = org[:, self.body]
        return o + np.einsum("ncij,cj->nci", r, self.p0), o + np.einsum("ncij,cj->nci", r, self.p1)


def box_capsules(size) -> tuple[np.ndarray, np.ndarray, float]:
    """Capsules covering a box centred at 0 (axes = box axes): (ends0 (k,3), ends1 (k,3), radius).

    The segments run along the longest side; a grid of at most 4 × 4 of them covers the cross
    section with radius ≤ 25 mm (thin plates are thickened to the grid's radius).
    """
    size = np.asarray(size, dtype=float)
    order = np.argsort(-size)
    a, b, c = size[order]
    r_target = min(c / 2, _CAPSULE_RMAX)
    nb = max(1, min(4, math.ceil(b / (2 * r_target) - 1e-9)))
    nc = max(1, min(4, math.ceil(c / (2 * r_target) - 1e-9)))
    r = max(b / nb, c / nc) / 2
    ob = np.linspace(-(b / 2 - r), b / 2 - r, nb) if nb > 1 else np.zeros(1)
    oc = np.linspace(-(c / 2 - r), c / 2 - r, nc) if nc > 1 else np.zeros(1)
    h = max(a / 2 - r, 0.0)
    gb, gc = (g.ravel() for g in np.meshgrid(ob, oc, indexing="ij"))
    k = gb.size
    e0 = np.zeros((k, 3))
    e1 = np.zeros((k, 3))
    for e, s in ((e0, -h), (e1, h)):
        e[:, order[0]] = s
        e[:, order[1]] = gb
        e[:, order[2]] = gc
    return e0, e1, r


def shape_capsules(shapes) -> tuple[Capsules, int, int]:
    """(capsules, meshes covered, meshes without vertices) covering ``shapes``: boxes,
    cylinders, capsules and spheres, and one bounding covering per mesh whose vertices are
    loaded (``mesh_capsules``); ``pairs`` is left empty."""
    body, p0, p1, rad, links, meshy = [], [], [], [], [], []
    n_mesh = n_mesh_capsules = 0
    for shape in shapes:
        t = shape.pose
        if shape.kind == BOX:
            e0, e1, r = box_capsules(shape.size)
        elif shape.kind == CYLINDER:
            rho, length = float(shape.size[0]), float(shape.size[1])
            if length < 2 * rho:  # a disc: cover its bounding box
                e0, e1, r = box_capsules((2 * rho, 2 * rho, length))
            else:
                h = length / 2 - rho
                e0, e1, r = np.array([[0, 0, -h]]), np.array([[0, 0, h]]), rho
        elif shape.kind == CAPSULE:
            h = float(shape.size[1]) / 2
            e0, e1, r = np.array([[0, 0, -h]]), np.array([[0, 0, h]]), float(shape.size[0])
        elif shape.kind == SPHERE:
            e0 = e1 = np.zeros((1, 3))
            r = float(shape.size[0])
        elif shape.kind == MESH and shape.vertices is not None:
            local = (shape.vertices - t[:3, 3]) @ t[:3, :3]
            e0, e1, r = mesh_capsules(local)
            n_mesh_capsules += 1
        else:
            n_mesh += 1
            continue
        for a0, a1 in zip(e0, e1, strict=True):
            meshy.append(shape.kind == MESH)
            body.append(shape.body)
            p0.append(t[:3, :3] @ a0 + t[:3, 3])
            p1.append(t[:3, :3] @ a1 + t[:3, 3])
            rad.append(r)
            links.append(shape.link)
    cap = Capsules(
        body=np.array(body, dtype=np.int64),
        p0=np.array(p0).reshape(-1, 3),
        p1=np.array(p1).reshape(-1, 3),
        radius=np.array(rad, dtype=float),
        link=links,
        pairs=np.zeros((0, 2), dtype=np.int64),
        from_mesh=np.array(meshy, dtype=bool),
    )
    return cap, n_mesh_capsules, n_mesh


def collision_capsules(robot: Robot) -> Capsules:
    """Capsules from the model's collision boxes, cylinders, capsules, spheres, and one bounding
    capsule per mesh whose vertices are loaded (``mesh_capsules``; unloaded meshes ignored)."""
    cap, n_mesh_capsules, n_mesh = shape_capsules(s for s in robot.shapes if s.role == "collision")
    notes = list(robot.geometry_notes)
    if n_mesh_capsules:
        notes.append(
            f"{n_mesh_capsules} mesh collision shape(s) covered by capsules around "
            "their principal-axis boxes (self-collision; the floor check uses their vertices)"
        )
    if n_mesh:
        notes.append(
            f"{n_mesh} mesh collision element(s) without vertices ignored: not checked for "
            "self-collision"
        )
    cap.notes = notes
    if not len(cap.body):
        cap.notes.append("no collision shapes: self-collision is not checked")
        return cap
    parent = shape_parents([bd.parent for bd in robot.model.bodies], cap.body)
    i, j = np.triu_indices(len(cap.body), k=1)
    bi, bj = cap.body[i], cap.body[j]
    keep = (bi != bj) & (parent[bi] != bj) & (parent[bj] != bi)
    i, j = i[keep], j[keep]
    rot, org = robot.forward(np.zeros((1, robot.nq)))
    w0, w1 = cap.world(rot, org)
    d = segment_distance(w0[:, i], w1[:, i], w0[:, j], w1[:, j])[0]
    touch = d < cap.radius[i] + cap.radius[j]
    touch = _whole_mesh_pairs(cap, i, j, touch)
    names = robot.body_names
    cap.skipped_zero = sorted(
        {(names[a], names[b]) for a, b in zip(cap.body[i[touch]], cap.body[j[touch]], strict=True)}
    )
    if cap.skipped_zero:
        cap.notes.append(
            f"{len(cap.skipped_zero)} body pair(s) overlap at q = 0 and are not checked"
        )
    cap.pairs = np.column_stack([i[~touch], j[~touch]])
    return cap


def shape_parents(parents: list[int], shaped: np.ndarray) -> np.ndarray:
    """(N,) each body's nearest ancestor that has collision capsules (−1: none). Bodies without
    shapes are passed through: a joint split into several bodies (an MJCF body with three hinges,
    a URDF hip of three massless links) joins the bodies on either side, which MuJoCo's parent
    filter also lets overlap."""
    has = np.zeros(len(parents), dtype=bool)
    has[np.asarray(shaped, dtype=np.int64)] = True
    out = np.full(len(parents), -1, dtype=np.int64)
    for b, p in enumerate(parents):  # parents come before their children
        if p >= 0:
            out[b] = p if has[p] else out[p]
    return out


def _whole_mesh_pairs(cap: Capsules, i, j, touch) -> np.ndarray:
    """Capsule pairs to skip: those touching at q = 0, and every pair of mesh capsules of a body
    pair some of whose capsules touch there (a mesh's capsule grid is one covering)."""
    if cap.from_mesh is None or not cap.from_mesh.any() or not touch.any():
        return touch
    mesh = cap.from_mesh[i] | cap.from_mesh[j]
    nb = int(cap.body.max()) + 1
    key = np.minimum(cap.body[i], cap.body[j]) * nb + np.maximum(cap.body[i], cap.body[j])
    return touch | (mesh & np.isin(key, key[touch & mesh]))


MESH_CELL = 0.08  #: m, target cross-section cell of the capsules covering a mesh's box
_MESH_GRID = 3  #: at most this many cells per cross-section side


def mesh_capsules(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Capsules (ends0 (k, 3), ends1 (k, 3), radius) containing every vertex (k, 3) [m].

    The vertices' principal-axis box is split across its two shorter sides into a grid of at
    most 3 × 3 cells of about ``MESH_CELL``; one capsule per cell runs the box's full length with
    the radius of the cell's half-diagonal, so the whole box (hence the mesh hull) is covered.
    """
    v = np.asarray(vertices, dtype=float)
    c = v.mean(axis=0)
    _, _, vt = np.linalg.svd(v - c, full_matrices=False)
    if vt.shape[0] < 3:  # fewer than 3 independent directions: complete the basis
        vt = np.linalg.qr(np.vstack([vt, np.eye(3)]).T)[0].T[:3]
    loc = (v - c) @ vt.T
    lo, hi = loc.min(axis=0), loc.max(axis=0)
    mid, size = (lo + hi) / 2, hi - lo
    order = np.argsort(-size)
    a, b, cc = size[order]
    nb = int(min(_MESH_GRID, max(1, math.ceil(b / MESH_CELL - 1e-9))))
    nc = int(min(_MESH_GRID, max(1, math.ceil(cc / MESH_CELL - 1e-9))))
    r = 0.5 * math.hypot(b / nb, cc / nc) + 1e-9
    gb = (np.arange(nb) + 0.5) * b / nb - b / 2
    gc = (np.arange(nc) + 0.5) * cc / nc - cc / 2
    gb, gc = (g.ravel() for g in np.meshgrid(gb, gc, indexing="ij"))
    e0 = np.zeros((gb.size, 3))
    e1 = np.zeros((gb.size, 3))
    for e, sgn in ((e0, -a / 2), (e1, a / 2)):
        e[:, order[0]] = sgn
        e[:, order[1]] = gb
        e[:, order[2]] = gc
    return c + (e0 + mid) @ vt, c + (e1 + mid) @ vt, r


def segment_distance(p0, p1, q0, q1) -> np.ndarray:
    """Distance [m] between segments p0–p1 and q0–q1; arrays (..., 3) → (...)."""
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = np.einsum("...i,...i", d1, d1)
    e = np.einsum("...i,...i", d2, d2)
    f = np.einsum("...i,...i", d2, r)
    c = np.einsum("...i,...i", d1, r)
    b = np.einsum("...i,...i", d1, d2)
    eps = 1e-18
    a_ok, e_ok = a > eps, e > eps
    a_s = np.where(a_ok, a, 1.0)
    e_s = np.where(e_ok, e, 1.0)
    denom = a * e - b * b
    par = denom > 1e-12 * np.maximum(a * e, eps)
    s = np.where(par, np.clip((b * f - c * e) / np.where(par, denom, 1.0), 0.0, 1.0), 0.0)
    s = np.where(e_ok, s, np.clip(-c / a_s, 0.0, 1.0))  # second segment is a point
    s = np.where(a_ok, s, 0.0)
    t = np.where(e_ok, (b * s + f) / e_s, 0.0)
    lo, hi = t < 0.0, t > 1.0
    s = np.where(lo, np.clip(-c / a_s, 0.0, 1.0), s)
    s = np.where(hi, np.clip((b - c) / a_s, 0.0, 1.0), s)
    s = np.where(a_ok, s, 0.0)
    t = np.clip(t, 0.0, 1.0)
    diff = r + d1 * s[..., None] - d2 * t[..., None]
    return np.sqrt(np.einsum("...i,...i", diff, diff))


def first_contact(cap: Capsules, rot, org, chunk: int = 4096) -> np.ndarray:
    """(n,) index into ``cap.pairs`` of the first intersecting capsule pair, −1 if none.

    ``rot``, ``org``: body rotations/origins from ``robot.forward``. Compiled, early exit.
    """
    n = rot.shape[0]
    out = np.full(n, -1, dtype=np.int64)
    if not len(cap.pairs):
        return out
    pi = np.ascontiguousarray(cap.pairs[:, 0])
    pj = np.ascontiguousarray(cap.pairs[:, 1])
    reach = cap.radius[pi] + cap.radius[pj]
    for s in range(0, n, chunk):
        w0, w1 = cap.world(rot[s : s + chunk], org[s : s + chunk])
        first_contact_kernel(
            np.ascontiguousarray(w0), np.ascontiguousarray(w1), reach, pi, pj, out[s:]
        )
    return out


def collision_free_mask(cap: Capsules, rot, org) -> np.ndarray:
    """(n,) True where no checked capsule pair intersects (bodies' rot/org from robot.forward)."""
    return first_contact(cap, rot, org) < 0


def collision_free_mask_numpy(cap: Capsules, rot, org, chunk: int = 2000) -> np.ndarray:
    """Same as ``collision_free_mask`` with numpy arrays over all pairs (reference, slower)."""
    n = rot.shape[0]
    ok = np.ones(n, dtype=bool)
    if not len(cap.pairs):
        return ok
    i, j = cap.pairs[:, 0], cap.pairs[:, 1]
    reach = cap.radius[i] + cap.radius[j]
    for s in range(0, n, chunk):
        w0, w1 = cap.world(rot[s : s + chunk], org[s : s + chunk])
        d = segment_distance(w0[:, i], w1[:, i], w0[:, j], w1[:, j])
        ok[s : s + chunk] = np.all(d >= reach, axis=1)
    return ok
