"""Pose planning for the real-robot experiment: stable, collision-free candidates, D-optimal choice.

Pipeline (all vectorised across poses, SI units, radians):

1. **Candidates** — joint angles uniform within limits. For the embedded OP2 the limits are the
   paper's Table 2 converted to servo angles (the model's convention;
   ``robots/op2_paper_limits.csv``: ``paper = sign · servo + offset``) ∩ the URDF limits.
2. **Static stability** — the model's CoP (``robot.cop``) inside a box around the support-frame
   origin (default ``|x|, |y| < 0.023 m`` as the paper), or inside the sole rectangle shrunk by a
   margin (the OP2 sole is 0.105 × 0.066 m centred on ``r_sole``).
3. **No self-collision** — every link's ``<collision>`` boxes, cylinders and spheres (meshes are
   ignored) are approximated by capsules; pairs of parent/child bodies and pairs that already
   overlap at the zero pose are skipped (capsule–capsule distances, a compiled loop with early
   exit; ``collision_free_mask_numpy`` is the plain-numpy reference). **Ground clearance**: every
   capsule of a body other than the support body stays above the ground, and the free sole's
   corners above ``clearance``.
4. **Selection** — D-optimal (greedy, then Fedorov exchange) on ``log det M``, ``M = Σ AᵢᵀAᵢ``,
   ``Aᵢ = Φ_xy(qᵢ) V`` the x/y regressor projected on an orthonormal basis ``V`` of the
   identifiable subspace (from the candidate pool). Each candidate's ``Aᵢ M⁻¹ Aᵢᵀ`` is kept up to
   date by rank-2 Woodbury updates, so each step costs O(n p) instead of O(n p²); exchange passes
   search a shortlist of the most informative candidates, refreshed every pass.
5. **Expected error** — least squares on K poses with CoP noise σ predicts the noise-free CoP of
   fresh poses with RMS error ``σ · sqrt(trace(Φ_test M⁻¹ Φ_testᵀ) / rows)``.
6. **Ordering** — nearest neighbour then 2-opt on the joint-space (Euclidean, rad) path.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import resources

import numba
import numpy as np

from .errors import SescidError
from .estimate import structural_null_directions
from .robot import Robot

PAPER_COP_BOX = 0.023  #: m, half-width of the paper's CoP acceptance box (|x|, |y| < 0.023)
OP2_SOLE_SIZE = (0.105, 0.066)  #: m, OP2 sole rectangle (length x, width y), centred on the sole
DEFAULT_CLEARANCE = 0.005  #: m, free sole corners above the ground
DEFAULT_NOISE = 0.00493  #: m, CoP noise σ for the expected error (the paper's)
MX28_CENTER = 2048  #: MX-28 position register at servo angle 0
MX28_COUNTS = 4096  #: MX-28 counts per turn
_CAPSULE_RMAX = 0.025  #: m, largest capsule radius used to cover a box cross-section


# --- limits and conventions ---------------------------------------------------------------
@dataclass(frozen=True)
class PaperConvention:
    """The paper's joint-angle convention for the OP2: ``paper = sign · servo + offset``."""

    joint_names: list[str]
    sign: np.ndarray  #: (nq,) ±1
    offset: np.ndarray  #: (nq,) rad
    paper_limits: np.ndarray  #: (nq, 2) the paper's Table 2 limits, rad, paper convention
    servo_limits: np.ndarray  #: (nq, 2) the same in servo angles, rad

    def to_paper(self, q) -> np.ndarray:
        """Servo angles (n, nq) [rad] → paper angles (n, nq) [rad]."""
        return np.asarray(q, dtype=float) * self.sign + self.offset

    def to_servo(self, q_paper) -> np.ndarray:
        """Paper angles (n, nq) [rad] → servo angles (n, nq) [rad]."""
        return (np.asarray(q_paper, dtype=float) - self.offset) * self.sign


def op2_paper_convention() -> PaperConvention:
    """The OP2 paper convention and Table 2 limits (``robots/op2_paper_limits.csv``)."""
    path = resources.files("sescid.robots").joinpath("op2_paper_limits.csv")
    with path.open() as fh:
        rows = list(csv.DictReader(fh))
    f = np.array(
        [
            [float(r[k]) for k in ("paper_sign_vs_servo", "paper_offset_deg")]
            + [float(r[k]) for k in ("paper_min_deg", "paper_max_deg")]
            + [float(r[k]) for k in ("servo_min_deg", "servo_max_deg")]
            for r in rows
        ]
    )
    return PaperConvention(
        joint_names=[r["joint"] for r in rows],
        sign=f[:, 0],
        offset=np.radians(f[:, 1]),
        paper_limits=np.radians(f[:, 2:4]),
        servo_limits=np.radians(f[:, 4:6]),
    )


def paper_convention(robot: Robot) -> PaperConvention | None:
    """The paper convention in ``robot.joint_names`` order for the embedded OP2, else None."""
    if robot.source != "op2":
        return None
    pc = op2_paper_convention()
    idx = [pc.joint_names.index(j) for j in robot.joint_names]
    return PaperConvention(
        joint_names=robot.joint_names,
        sign=pc.sign[idx],
        offset=pc.offset[idx],
        paper_limits=pc.paper_limits[idx],
        servo_limits=pc.servo_limits[idx],
    )


def sampling_limits(robot: Robot, paper: bool = True, range_deg: float | None = None) -> np.ndarray:
    """(nq, 2) sampling limits [rad]: URDF limits ∩ the paper's Table 2 (OP2, ``paper``) ∩ ±range.

    Continuous joints are limited to ±π.
    """
    lim = np.clip(robot.joint_limits, -math.pi, math.pi)
    pc = paper_convention(robot) if paper else None
    if pc is not None:
        lim = np.column_stack(
            [
                np.maximum(lim[:, 0], pc.servo_limits[:, 0]),
                np.minimum(lim[:, 1], pc.servo_limits[:, 1]),
            ]
        )
    if range_deg is not None:
        if not range_deg > 0:
            raise SescidError(f"range_deg must be > 0, got {range_deg}")
        r = math.radians(range_deg)
        lim = np.column_stack([np.maximum(lim[:, 0], -r), np.minimum(lim[:, 1], r)])
    bad = np.flatnonzero(lim[:, 0] > lim[:, 1])
    if bad.size:
        raise SescidError(f"joint '{robot.joint_names[bad[0]]}': empty sampling range")
    return lim


def mx28_ticks(q) -> np.ndarray:
    """Servo angles (n, nq) [rad] → Dynamixel MX-28 position ticks (int, 0–4095, 2048 = 0)."""
    ticks = np.rint(MX28_CENTER + np.asarray(q, dtype=float) * MX28_COUNTS / (2 * math.pi))
    bad = np.argwhere((ticks < 0) | (ticks > MX28_COUNTS - 1))
    if bad.size:
        i, j = bad[0]
        raise SescidError(f"pose {i}, joint {j}: {q[i, j]:g} rad is outside the MX-28 range 0–4095")
    return ticks.astype(np.int64)


# --- stability and clearance -----------------------------------------------------------------
def cop_half_extents(
    robot: Robot,
    cop_box: float | tuple[float, float] | None = PAPER_COP_BOX,
    margin: float | None = None,
    sole_size: tuple[float, float] | None = None,
) -> np.ndarray:
    """(2,) half-extents [m] of the allowed CoP rectangle around the support-frame origin.

    ``margin`` given: the sole rectangle (``sole_size``; the OP2's by default) shrunk by it;
    otherwise the box ``cop_box`` (a half-width, or (x, y) half-widths).
    """
    if margin is not None:
        if sole_size is None:
            if robot.source != "op2":
                raise SescidError("a support-polygon margin needs the sole size (sole_size)")
            sole_size = OP2_SOLE_SIZE
        half = np.asarray(sole_size, dtype=float) / 2 - margin
        what = f"sole {sole_size[0]:g} x {sole_size[1]:g} m shrunk by {margin:g} m"
    else:
        if cop_box is None:
            raise SescidError("give a CoP box or a support-polygon margin")
        half = np.broadcast_to(np.asarray(cop_box, dtype=float), (2,)).copy()
        what = f"CoP box {cop_box}"
    if not np.all(np.isfinite(half)) or np.any(half <= 0):
        raise SescidError(f"{what} leaves no room for the CoP")
    return half


def stable_mask(robot: Robot, q, half_extents) -> tuple[np.ndarray, np.ndarray]:
    """(mask (n,), cop (n, 2) [m]): model CoP strictly inside the rectangle ±half_extents."""
    cop = robot.cop(q)
    return np.all(np.abs(cop) < np.asarray(half_extents), axis=1), cop


def free_sole(robot: Robot) -> str | None:
    """The sole frame of the free foot (OP2: the other sole), or None if not known."""
    if robot.source != "op2":
        return None
    return {"r_sole": "l_sole", "l_sole": "r_sole"}.get(robot.support)


def sole_corners(robot: Robot, q, sole: str, sole_size=OP2_SOLE_SIZE) -> np.ndarray:
    """(n, 4, 3) corners [m] of the sole rectangle of frame ``sole`` in the support frame."""
    rot, pos = robot.link_poses(q, sole)
    hx, hy = np.asarray(sole_size, dtype=float) / 2
    local = np.array([[hx, hy, 0.0], [hx, -hy, 0.0], [-hx, hy, 0.0], [-hx, -hy, 0.0]])
    return pos[:, None, :] + np.einsum("nij,cj->nci", rot, local)


# --- collision shapes ------------------------------------------------------------------------
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


def collision_capsules(robot: Robot) -> Capsules:
    """Capsules from the URDF's ``<collision>`` boxes, cylinders and spheres (meshes ignored)."""
    import yourdfpy

    urdf = yourdfpy.URDF.load(
        str(robot.urdf_path),
        build_scene_graph=False,
        build_collision_scene_graph=False,
        load_meshes=False,
        load_collision_meshes=False,
    )
    body, p0, p1, rad, links = [], [], [], [], []
    n_mesh = 0
    for link in urdf.robot.links:
        if link.name not in robot.model.link_frames:
            continue
        b, x_link = robot.model.link_frames[link.name]
        for col in link.collisions:
            g = col.geometry
            t = x_link @ (np.eye(4) if col.origin is None else np.asarray(col.origin, float))
            if g.box is not None:
                e0, e1, r = box_capsules(g.box.size)
            elif g.cylinder is not None:
                rho, length = float(g.cylinder.radius), float(g.cylinder.length)
                if length < 2 * rho:  # a disc: cover its bounding box
                    e0, e1, r = box_capsules((2 * rho, 2 * rho, length))
                else:
                    h = length / 2 - rho
                    e0, e1, r = np.array([[0, 0, -h]]), np.array([[0, 0, h]]), rho
            elif g.sphere is not None:
                e0 = e1 = np.zeros((1, 3))
                r = float(g.sphere.radius)
            else:
                n_mesh += 1
                continue
            for a0, a1 in zip(e0, e1, strict=True):
                body.append(b)
                p0.append(t[:3, :3] @ a0 + t[:3, 3])
                p1.append(t[:3, :3] @ a1 + t[:3, 3])
                rad.append(r)
                links.append(link.name)
    notes = []
    if n_mesh:
        notes.append(f"{n_mesh} mesh collision element(s) ignored (only boxes/cylinders/spheres)")
    cap = Capsules(
        body=np.array(body, dtype=np.int64),
        p0=np.array(p0).reshape(-1, 3),
        p1=np.array(p1).reshape(-1, 3),
        radius=np.array(rad, dtype=float),
        link=links,
        pairs=np.zeros((0, 2), dtype=np.int64),
        notes=notes,
    )
    if not body:
        cap.notes.append("no collision shapes: self-collision is not checked")
        return cap
    parent = np.array([bd.parent for bd in robot.model.bodies])
    i, j = np.triu_indices(len(body), k=1)
    bi, bj = cap.body[i], cap.body[j]
    keep = (bi != bj) & (parent[bi] != bj) & (parent[bj] != bi)
    i, j = i[keep], j[keep]
    rot, org = robot.forward(np.zeros((1, robot.nq)))
    w0, w1 = cap.world(rot, org)
    d = segment_distance(w0[:, i], w1[:, i], w0[:, j], w1[:, j])[0]
    touch = d < cap.radius[i] + cap.radius[j]
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


@numba.njit(cache=True, nogil=True)
def _first_contact(w0, w1, reach, pi, pj, out):  # pragma: no cover - compiled
    """out[k] = index of the first capsule pair closer than its reach in pose k, or −1.

    Closest points of two segments (clamped parameters, as in ``segment_distance``).
    """
    eps = 1e-18
    for k in range(w0.shape[0]):
        out[k] = -1
        for m in range(pi.shape[0]):
            i = pi[m]
            j = pj[m]
            d1x = w1[k, i, 0] - w0[k, i, 0]
            d1y = w1[k, i, 1] - w0[k, i, 1]
            d1z = w1[k, i, 2] - w0[k, i, 2]
            d2x = w1[k, j, 0] - w0[k, j, 0]
            d2y = w1[k, j, 1] - w0[k, j, 1]
            d2z = w1[k, j, 2] - w0[k, j, 2]
            rx = w0[k, i, 0] - w0[k, j, 0]
            ry = w0[k, i, 1] - w0[k, j, 1]
            rz = w0[k, i, 2] - w0[k, j, 2]
            a = d1x * d1x + d1y * d1y + d1z * d1z
            e = d2x * d2x + d2y * d2y + d2z * d2z
            f = d2x * rx + d2y * ry + d2z * rz
            c = d1x * rx + d1y * ry + d1z * rz
            b = d1x * d2x + d1y * d2y + d1z * d2z
            denom = a * e - b * b
            s = 0.0
            if a > eps and denom > 1e-12 * max(a * e, eps):
                s = min(max((b * f - c * e) / denom, 0.0), 1.0)
            if e <= eps:  # second segment is a point
                s = min(max(-c / a, 0.0), 1.0) if a > eps else 0.0
            t = (b * s + f) / e if e > eps else 0.0
            if t < 0.0:
                t = 0.0
                s = min(max(-c / a, 0.0), 1.0) if a > eps else 0.0
            elif t > 1.0:
                t = 1.0
                s = min(max((b - c) / a, 0.0), 1.0) if a > eps else 0.0
            dx = rx + d1x * s - d2x * t
            dy = ry + d1y * s - d2y * t
            dz = rz + d1z * s - d2z * t
            if dx * dx + dy * dy + dz * dz < reach[m] * reach[m]:
                out[k] = m
                break


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
        _first_contact(np.ascontiguousarray(w0), np.ascontiguousarray(w1), reach, pi, pj, out[s:])
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


def ground_clear_mask(
    robot: Robot, q, cap: Capsules, rot, org, clearance: float, sole_size=OP2_SOLE_SIZE
) -> np.ndarray:
    """(n,) True where all non-support capsules are above z = 0 and the free sole's corners
    (OP2: the other sole) above ``clearance`` [m]."""
    n = rot.shape[0]
    ok = np.ones(n, dtype=bool)
    moving = cap.body != 0
    if moving.any():
        w0, w1 = cap.world(rot, org)
        low = np.minimum(w0[..., 2], w1[..., 2]) - cap.radius
        ok &= np.all(low[:, moving] > 0.0, axis=1)
    free = free_sole(robot)
    if free is not None:
        ok &= np.all(sole_corners(robot, q, free, sole_size)[..., 2] > clearance, axis=1)
    return ok


# --- candidates -------------------------------------------------------------------------------
@dataclass
class Candidates:
    """Stable, collision-free, ground-clear poses sampled uniformly within ``limits``."""

    q: np.ndarray  #: (n, nq) rad
    cop: np.ndarray  #: (n, 2) model CoP, m
    limits: np.ndarray  #: (nq, 2) sampling limits, rad
    half_extents: np.ndarray  #: (2,) CoP rectangle, m
    n_sampled: int  #: raw poses drawn
    n_stable: int  #: of which statically stable
    n_ground: int  #: of which also clear of the ground
    n_free: int  #: of which also free of self-collision (= accepted, before truncation)
    capsules: Capsules | None = None

    @property
    def acceptance(self) -> float:
        """Fraction of raw uniform poses that are stable, ground-clear and collision free."""
        return self.n_free / max(self.n_sampled, 1)

    def summary(self) -> str:
        s = max(self.n_sampled, 1)
        return (
            f"{self.n_sampled} uniform poses: {self.n_stable / s:.2%} stable, "
            f"{self.n_ground / s:.2%} also ground-clear, {self.n_free / s:.2%} also free of "
            f"self-collision ({self.n_free} accepted)"
        )


def candidates(
    robot: Robot,
    n: int,
    seed: int | np.random.Generator = 0,
    *,
    limits: np.ndarray | None = None,
    half_extents=None,
    clearance: float = DEFAULT_CLEARANCE,
    sole_size=OP2_SOLE_SIZE,
    chunk: int = 100_000,
    max_sampled: int = 200_000_000,
    progress: Callable[[int, int], None] | None = None,
) -> Candidates:
    """Draw ``n`` accepted poses (uniform within ``limits``, default ``sampling_limits(robot)``).

    ``half_extents``: CoP rectangle (default the paper's ±0.023 m box). Raises SescidError when
    the acceptance rate would need more than ``max_sampled`` raw poses.
    """
    if n < 1:
        raise SescidError(f"number of candidates must be ≥ 1, got {n}")
    rng = np.random.default_rng(seed)
    lim = sampling_limits(robot) if limits is None else np.asarray(limits, dtype=float)
    half = cop_half_extents(robot) if half_extents is None else np.asarray(half_extents, float)
    cap = collision_capsules(robot)
    qs, cops = [], []
    n_sampled = n_stable = n_ground = n_free = 0
    width = lim[:, 1] - lim[:, 0]
    while n_free < n:
        q = lim[:, 0] + width * rng.random((chunk, robot.nq))
        n_sampled += chunk
        ok, cop = stable_mask(robot, q, half)
        q, cop = q[ok], cop[ok]
        n_stable += len(q)
        if len(q):
            rot, org = robot.forward(q)
            g = ground_clear_mask(robot, q, cap, rot, org, clearance, sole_size)
            q, cop, rot, org = q[g], cop[g], rot[g], org[g]
            n_ground += len(q)
            f = collision_free_mask(cap, rot, org)
            q, cop = q[f], cop[f]
            n_free += len(q)
            qs.append(q)
            cops.append(cop)
        if progress is not None:
            progress(min(n_free, n), n)
        rate = n_free / n_sampled
        if n_sampled >= 1_000_000 and (rate == 0 or n / rate > max_sampled):
            raise SescidError(
                f"only {n_free} of {n_sampled} uniform poses are stable and collision free "
                f"({rate:.2e}); {n} candidates would need more than {max_sampled} samples — "
                "widen the CoP box or the joint ranges"
            )
    return Candidates(
        q=np.concatenate(qs)[:n],
        cop=np.concatenate(cops)[:n],
        limits=lim,
        half_extents=half,
        n_sampled=n_sampled,
        n_stable=n_stable,
        n_ground=n_ground,
        n_free=n_free,
        capsules=cap,
    )


# --- information and selection ----------------------------------------------------------------
def identifiable_basis(robot: Robot, q, rtol: float = 1e-6, chunk: int = 50_000) -> np.ndarray:
    """(3N, p) orthonormal basis of the span of the x/y regressor rows over poses ``q``."""
    ata = np.zeros((3 * len(robot.body_names),) * 2)
    for s in range(0, len(q), chunk):
        x = robot.regressor(q[s : s + chunk]).reshape(-1, ata.shape[0])
        ata += x.T @ x
    w, v = np.linalg.eigh(ata)
    keep = np.sqrt(np.clip(w, 0, None)) > rtol * math.sqrt(w[-1])
    return v[:, keep][:, ::-1]


def projected_regressor(robot: Robot, q, basis: np.ndarray, chunk: int = 50_000) -> np.ndarray:
    """(n, 2, p) x/y regressor in the coordinates of ``basis``: A = Φ_xy V."""
    out = np.empty((len(q), 2, basis.shape[1]))
    for s in range(0, len(q), chunk):
        out[s : s + chunk] = robot.regressor(q[s : s + chunk]) @ basis
    return out


def _logdet2(s: np.ndarray) -> np.ndarray:
    """log det(I + S) for S (n, 2, 2) symmetric (nan where not positive)."""
    det = (1.0 + s[:, 0, 0]) * (1.0 + s[:, 1, 1]) - s[:, 0, 1] * s[:, 1, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log(np.where(det > 0, det, np.nan))


def _inv2(g: np.ndarray) -> np.ndarray:
    det = g[0, 0] * g[1, 1] - g[0, 1] * g[1, 0]
    return np.array([[g[1, 1], -g[0, 1]], [-g[1, 0], g[0, 0]]]) / det


def _quad(w: np.ndarray, g: np.ndarray) -> np.ndarray:
    """W_j G W_jᵀ (n, 2, 2) for W (n, 2, 2) and a symmetric G (2, 2)."""
    w0, w1 = w[:, :, 0], w[:, :, 1]  # (n, 2): columns of each W_j
    t0 = w0 * g[0, 0] + w1 * g[1, 0]
    t1 = w0 * g[0, 1] + w1 * g[1, 1]
    out = np.empty_like(w)
    for i in range(2):
        for j in range(i, 2):
            out[:, i, j] = t0[:, i] * w0[:, j] + t1[:, i] * w1[:, j]
            out[:, j, i] = out[:, i, j]
    return out


def _sandwich(a: np.ndarray, minv: np.ndarray) -> np.ndarray:
    """S_i = A_i M⁻¹ A_iᵀ (n, 2, 2) for A (n, 2, p)."""
    n, _, p = a.shape
    y = (a.reshape(2 * n, p) @ minv).reshape(n, 2, p)
    out = np.empty((n, 2, 2))
    out[:, 0, 0] = np.einsum("np,np->n", y[:, 0], a[:, 0])
    out[:, 1, 1] = np.einsum("np,np->n", y[:, 1], a[:, 1])
    out[:, 0, 1] = out[:, 1, 0] = np.einsum("np,np->n", y[:, 0], a[:, 1])
    return out


def information(a: np.ndarray) -> np.ndarray:
    """M = Σ AᵢᵀAᵢ (p, p) for A (k, 2, p)."""
    x = a.reshape(-1, a.shape[-1])
    return x.T @ x


@dataclass
class Selection:
    """K poses chosen from a pool, and the log-determinant of their information matrix."""

    index: np.ndarray  #: (K,) indices into the pool, in choice order
    logdet: float  #: log det M (M restricted to the identifiable subspace)
    exchanges: int = 0  #: accepted exchanges after the greedy start
    passes: int = 0  #: exchange passes


class _Design:
    """Rank-2 bookkeeping for D-optimal search over candidates A (n, 2, p).

    Keeps M⁻¹ and, for every candidate, S_i = A_i M⁻¹ A_iᵀ (2 × 2) current under additions and
    removals (Woodbury), so a step costs O(n p) instead of O(n p²).
    """

    def __init__(self, a: np.ndarray, minv: np.ndarray):
        self.a = a
        self.x = a.reshape(-1, a.shape[-1])
        self.minv = minv
        self.s = _sandwich(a, minv)
        self.chosen = np.zeros(len(a), dtype=bool)

    def _w(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        u = self.minv @ self.a[i].T  # (p, 2)
        return u, (self.x @ u).reshape(len(self.a), 2, 2)

    def add(self, i: int) -> None:
        u, w = self._w(i)
        g_inv = _inv2(np.eye(2) + self.s[i])
        self.s = self.s - _quad(w, g_inv)
        self.minv = self.minv - u @ g_inv @ u.T
        self.chosen[i] = True

    def best_add(self) -> int:
        gain = _logdet2(self.s)
        gain[self.chosen] = -np.inf
        return int(np.nanargmax(gain))

    def try_exchange(self, i_out: int, tol: float = 1e-10) -> int | None:
        """Swap chosen ``i_out`` for the candidate that raises log det most; its index or None."""
        h = np.eye(2) - self.s[i_out]
        det_h = h[0, 0] * h[1, 1] - h[0, 1] * h[1, 0]
        if not det_h > 0:
            return None
        h_inv = _inv2(h)
        u, w = self._w(i_out)
        s_minus = self.s + _quad(w, h_inv)  # S_j once i_out is removed
        gain = _logdet2(s_minus) + math.log(det_h)
        gain[self.chosen] = -np.inf
        j = int(np.nanargmax(gain))
        if not gain[j] > tol:
            return None
        self.minv = self.minv + u @ h_inv @ u.T
        self.s = s_minus
        self.chosen[i_out] = False
        self.add(j)
        return j


def select_d_optimal(
    a: np.ndarray,
    k: int,
    seed: int | np.random.Generator = 0,
    max_passes: int = 20,
    shortlist: int = 2000,
) -> Selection:
    """Choose ``k`` distinct rows of A (n, 2, p) maximising log det Σ AᵢᵀAᵢ: greedy + exchange.

    Greedy over all candidates from a tiny ridge (δ I), then Fedorov exchange passes: each chosen
    pose in turn is swapped for the candidate that raises log det most, until a pass makes no
    improvement. An exchange pass searches the ``shortlist`` candidates of largest
    log det(I + A_i M⁻¹ A_iᵀ) (the most informative ones given the current choice; refreshed every
    pass). S_i = A_i M⁻¹ A_iᵀ is kept current by rank-2 Woodbury updates throughout.
    """
    n, _, p = a.shape
    if not 1 <= k <= n:
        raise SescidError(f"cannot choose {k} poses from {n} candidates")
    rng = np.random.default_rng(seed)
    x = a.reshape(2 * n, p)
    delta = 1e-8 * float(np.einsum("ij,ij->", x, x)) / (n * p)
    st = _Design(a, np.eye(p) / delta)
    order = []
    for _ in range(k):
        i = st.best_add()
        st.add(i)
        order.append(i)
    minv = st.minv
    exchanges = passes = 0
    for passes in range(1, max_passes + 1):  # noqa: B007
        m = information(a[order])
        if np.linalg.matrix_rank(m) == p:  # drop the ridge once the design is non-singular
            minv = np.linalg.inv(m)
        score = _logdet2(_sandwich(a, minv))
        score[order] = -np.inf
        score = np.nan_to_num(score, nan=-np.inf)
        n_short = min(shortlist, n - k)
        top = np.argpartition(-score, n_short - 1)[:n_short] if n_short > 0 else np.zeros(0, int)
        idx = np.concatenate([np.asarray(order), top])
        sub = _Design(a[idx], minv)
        sub.chosen[:k] = True
        pos_sub = list(range(k))
        improved = False
        for pos in rng.permutation(k):
            j = sub.try_exchange(pos_sub[pos])
            if j is not None:
                pos_sub[pos] = j
                exchanges += 1
                improved = True
        order = [int(idx[i]) for i in pos_sub]
        minv = sub.minv
        if not improved:
            break
    sign, logdet = np.linalg.slogdet(information(a[order]))
    return Selection(
        index=np.array(order),
        logdet=float(logdet) if sign > 0 else -math.inf,
        exchanges=exchanges,
        passes=passes,
    )


def expected_cop_error(a_sel: np.ndarray, c_test: np.ndarray, sigma: float) -> float:
    """Expected RMS error [m] of least-squares CoP predictions on fresh poses.

    ``a_sel`` (K, 2, p) projected regressor of the chosen poses, ``c_test`` = Σ_t A_tᵀA_t / rows
    over test poses, ``sigma`` CoP noise [m]: σ · sqrt(trace(M⁻¹ c_test)). inf if M is singular.
    """
    m = information(a_sel)
    try:
        chol = np.linalg.cholesky(m)
    except np.linalg.LinAlgError:
        return math.inf
    z = np.linalg.solve(chol, np.linalg.solve(chol, c_test).T)
    val = float(np.trace(z))
    return sigma * math.sqrt(val) if val > 0 else math.inf


def per_row_information(a_test: np.ndarray) -> np.ndarray:
    """c_test = Σ_t A_tᵀA_t / rows for A_test (n, 2, p)."""
    return information(a_test) / (2 * len(a_test))


def random_cop_error(
    a_pool: np.ndarray, k: int, c_test: np.ndarray, sigma: float, draws: int = 50, seed=0
) -> np.ndarray:
    """Expected CoP errors [m] (draws,) of ``k`` poses drawn at random from the pool."""
    rng = np.random.default_rng(seed)
    return np.array(
        [
            expected_cop_error(a_pool[rng.choice(len(a_pool), k, replace=False)], c_test, sigma)
            for _ in range(draws)
        ]
    )


# --- ordering ---------------------------------------------------------------------------------
def path_length(q, start=None) -> float:
    """Total joint-space (Euclidean, rad) length of the path start → q[0] → … → q[-1]."""
    q = np.asarray(q, dtype=float)
    pts = q if start is None else np.vstack([np.asarray(start, dtype=float)[None], q])
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())


def order_poses(q, start=None) -> np.ndarray:
    """Permutation of poses q (K, nq) that keeps consecutive poses close: nearest neighbour from
    ``start`` (default the all-zero pose), then 2-opt (open path, start fixed)."""
    q = np.asarray(q, dtype=float)
    k = len(q)
    start = np.zeros(q.shape[1]) if start is None else np.asarray(start, dtype=float)
    pts = np.vstack([start[None], q])  # node 0 = start
    d = np.linalg.norm(pts[:, None, :] - pts[None, :, :], axis=2)
    path = [0]
    free = np.ones(k + 1, dtype=bool)
    free[0] = False
    for _ in range(k):
        dist = np.where(free, d[path[-1]], np.inf)
        nxt = int(np.argmin(dist))
        path.append(nxt)
        free[nxt] = False
    path = np.array(path)
    # 2-opt: reverse path[i..j] (1 ≤ i < j ≤ k); the open end has no edge after path[k].
    ii, jj = np.triu_indices(k + 1, k=1)
    sel = ii >= 1
    ii, jj = ii[sel], jj[sel]
    for _ in range(50 * k):
        prev, first, last = path[ii - 1], path[ii], path[jj]
        nxt_ok = jj < k
        after = path[np.minimum(jj + 1, k)]
        old = d[prev, first] + np.where(nxt_ok, d[last, after], 0.0)
        new = d[prev, last] + np.where(nxt_ok, d[first, after], 0.0)
        gain = old - new
        best = int(np.argmax(gain))
        if gain[best] <= 1e-12:
            break
        i, j = ii[best], jj[best]
        path[i : j + 1] = path[i : j + 1][::-1].copy()
    return path[1:] - 1


# --- the whole plan -----------------------------------------------------------------------------
@dataclass
class PosePlan:
    """K chosen poses in visiting order, with what the choice is expected to achieve."""

    q: np.ndarray  #: (K, nq) rad, ordered
    cop: np.ndarray  #: (K, 2) model CoP, m
    method: str  #: "d-optimal" or "random"
    expected_error: float  #: m, expected noise-free CoP error of least squares on these poses
    random_error: float  #: m, the same for K random candidates (median over draws)
    sigma: float  #: m, CoP noise assumed
    rank: int  #: dimension p of the identifiable subspace
    logdet: float
    path_unordered: float  #: rad, joint-space path length in selection order
    path_ordered: float  #: rad, after ordering
    candidates: Candidates
    selection: Selection
    basis: np.ndarray  #: (3N, p)
    a_pool: np.ndarray = field(repr=False)  #: (n, 2, p)
    c_test: np.ndarray = field(repr=False)  #: (p, p)


def min_poses(robot: Robot) -> int:
    """Fewest poses that can determine all identifiable combinations (2 equations each)."""
    p = 3 * len(robot.body_names) - len(structural_null_directions(robot))
    return math.ceil(p / 2)


def plan_poses(
    robot: Robot,
    count: int = 38,
    select: str = "d-optimal",
    seed: int = 0,
    *,
    n_candidates: int = 20_000,
    n_test: int = 2_000,
    sigma: float = DEFAULT_NOISE,
    limits: np.ndarray | None = None,
    half_extents=None,
    clearance: float = DEFAULT_CLEARANCE,
    random_draws: int = 50,
    progress: Callable[[int, int], None] | None = None,
) -> PosePlan:
    """Sample candidates, choose ``count`` poses (``select`` = "d-optimal" | "random"), order them.

    The expected error is computed on ``n_test`` further candidates (held out from the pool).
    """
    if select not in ("d-optimal", "random"):
        raise SescidError(f"unknown selection '{select}' (d-optimal or random)")
    need = min_poses(robot)
    if count < need:
        raise SescidError(
            f"--count {count} is too few: {robot.name} has {2 * need} identifiable combinations "
            f"(about), which need at least {need} poses (2 equations each)"
        )
    if count > n_candidates:
        raise SescidError(f"cannot choose {count} poses from {n_candidates} candidates")
    cand = candidates(
        robot,
        n_candidates + n_test,
        seed,
        limits=limits,
        half_extents=half_extents,
        clearance=clearance,
        progress=progress,
    )
    pool_q, test_q = cand.q[:n_candidates], cand.q[n_candidates:]
    basis = identifiable_basis(robot, pool_q)
    a_pool = projected_regressor(robot, pool_q, basis)
    c_test = per_row_information(projected_regressor(robot, test_q, basis))
    rng = np.random.default_rng(seed)
    if select == "d-optimal":
        sel = select_d_optimal(a_pool, count, seed)
    else:
        idx = rng.choice(n_candidates, count, replace=False)
        sign, ld = np.linalg.slogdet(information(a_pool[idx]))
        sel = Selection(index=idx, logdet=float(ld) if sign > 0 else -math.inf)
    q_sel = pool_q[sel.index]
    perm = order_poses(q_sel)
    rand = random_cop_error(a_pool, count, c_test, sigma, random_draws, rng)
    return PosePlan(
        q=q_sel[perm],
        cop=cand.cop[:n_candidates][sel.index][perm],
        method=select,
        expected_error=expected_cop_error(a_pool[sel.index], c_test, sigma),
        random_error=float(np.median(rand)),
        sigma=sigma,
        rank=basis.shape[1],
        logdet=sel.logdet,
        path_unordered=path_length(q_sel, np.zeros(robot.nq)),
        path_ordered=path_length(q_sel[perm], np.zeros(robot.nq)),
        candidates=cand,
        selection=sel,
        basis=basis,
        a_pool=a_pool,
        c_test=c_test,
    )


def design_curve(
    a_pool: np.ndarray,
    c_test: np.ndarray,
    ks,
    sigma: float = DEFAULT_NOISE,
    seed: int = 0,
    draws: int = 50,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, np.ndarray]:
    """Expected CoP error [m] vs K: D-optimal, and random (median, 10th/90th percentile)."""
    ks = np.asarray(ks, dtype=int)
    dopt, med, lo, hi = [], [], [], []
    for n_done, k in enumerate(ks):
        if progress is not None:
            progress(n_done, len(ks))
        sel = select_d_optimal(a_pool, int(k), seed)
        dopt.append(expected_cop_error(a_pool[sel.index], c_test, sigma))
        r = random_cop_error(a_pool, int(k), c_test, sigma, draws, seed)
        med.append(np.median(r))
        lo.append(np.percentile(r, 10))
        hi.append(np.percentile(r, 90))
    if progress is not None:
        progress(len(ks), len(ks))
    return {
        "k": ks,
        "d_optimal": np.array(dopt),
        "random_median": np.array(med),
        "random_p10": np.array(lo),
        "random_p90": np.array(hi),
    }


def design_figure(curve: dict[str, np.ndarray], path, title: str | None = None) -> None:
    """PNG of expected CoP error [mm] vs number of poses, D-optimal vs random."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .io import atomic_path

    k = curve["k"]
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.plot(k, curve["d_optimal"] * 1e3, "o-", color="C0", label="D-optimal")
    ax.plot(k, curve["random_median"] * 1e3, "s-", color="C1", label="random (median)")
    ax.fill_between(
        k,
        curve["random_p10"] * 1e3,
        curve["random_p90"] * 1e3,
        color="C1",
        alpha=0.25,
        label="random 10–90 %",
    )
    ax.set_xlabel("number of poses K")
    ax.set_ylabel("expected CoP error on fresh poses [mm]")
    ax.set_yscale("log")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    ax.set_title(title or "Pose selection: expected noise-free CoP error")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
