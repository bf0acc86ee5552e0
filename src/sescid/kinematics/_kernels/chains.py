"""The chain of rotations and origins of every body for a block of poses: the compiled kernel
beside its numpy twin, and the regressor, forward kinematics and one-pose CoM built on it."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from sescid.kinematics._kernels.trig import (
    MAX_ANGLE,
    joint_trig,
    reducible,
    sin_cos1m,
    trig_numpy,
    trig_poly_numpy,
)
from sescid.kinematics.compile import GROUP, compiled, lazy_njit, prefer_kernels
from sescid.kinematics.tree import Tree, as_poses

#: poses per block of the compiled chain (keeps the block's rotations in cache)
CHAIN_BLOCK = 1024


class Workspace:
    """Pre-allocated block buffers, reused across blocks (one per thread of use)."""

    def __init__(self, tree: Tree, block: int = CHAIN_BLOCK):
        nb = tree.parent.shape[0]
        self.block = block
        self.rot = np.empty((nb, 3, 3, block))
        self.s = np.empty((nb, block))
        self.c1 = np.empty((nb, block))
        self._buffers: dict[str, np.ndarray] = {}

    def buffer(self, name: str, shape: tuple[int, ...]) -> np.ndarray:
        """A named scratch array, reallocated only when the shape changes."""
        buf = self._buffers.get(name)
        if buf is None or buf.shape != shape:
            buf = self._buffers[name] = np.empty(shape)
        return buf


@lazy_njit(GROUP, cache=True, nogil=True)
def chain_block(s, c1, tree, rot):
    """Rotations of every body for a block of poses, structure-of-arrays.

    s, c1: (N, B) sin θ and 1 − cos θ of each body's joint; tree: ``Tree.arrays``;
    rot: (N, 3, 3, B) with rot[b, j, i, k] = R_b[i, j] at pose k. Only the non-zero entries (z)
    of M_b = C_b Rot(a, θ) are visited: M_b[nz_k[z], nz_j[z]] = a0 + a1 sin θ + a2 (1 − cos θ).
    """
    parent, root_r, nz_ptr = tree.parent, tree.root_r, tree.nz_ptr
    nz_k, nz_j, nz_a = tree.nz_k, tree.nz_j, tree.nz_a
    nb, nbk = s.shape
    m = np.empty(nbk)
    for b in range(nb):
        p = parent[b]
        if p < 0:
            for j in range(3):
                for i in range(3):
                    v = root_r[i, j]
                    for k in range(nbk):
                        rot[b, j, i, k] = v
            continue
        for j in range(3):
            for i in range(3):
                for k in range(nbk):
                    rot[b, j, i, k] = 0.0
        for z in range(nz_ptr[b], nz_ptr[b + 1]):
            kk = nz_k[z]
            jj = nz_j[z]
            a0 = nz_a[z, 0]
            a1 = nz_a[z, 1]
            a2 = nz_a[z, 2]
            if a1 == 0.0 and a2 == 0.0:
                for i in range(3):
                    for k in range(nbk):
                        rot[b, jj, i, k] += rot[p, kk, i, k] * a0
            else:
                for k in range(nbk):
                    m[k] = a0 + a1 * s[b, k] + a2 * c1[b, k]
                for i in range(3):
                    for k in range(nbk):
                        rot[b, jj, i, k] += rot[p, kk, i, k] * m[k]


@lazy_njit(GROUP, cache=True, nogil=True)
def origins_block(rot, parent, t, root_o, org):
    """Org (N, 3, B): body origins, o_b = o_p + R_p t_b, from rot (N, 3, 3, B)."""
    nb = parent.shape[0]
    nbk = rot.shape[3]
    for b in range(nb):
        p = parent[b]
        for i in range(3):
            if p < 0:
                for k in range(nbk):
                    org[b, i, k] = root_o[i]
                continue
            for k in range(nbk):
                org[b, i, k] = (
                    org[p, i, k]
                    + rot[p, 0, i, k] * t[b, 0]
                    + rot[p, 1, i, k] * t[b, 1]
                    + rot[p, 2, i, k] * t[b, 2]
                )


@lazy_njit(GROUP, cache=True, nogil=True)
def _com_one(q, ints, reals, r, out):
    """Out (1, k) = the first k of root_o + Σ_b R_b r_b at one pose: the chain and the sum in
    one call. False (out untouched) when q is not finite, an angle is beyond MAX_ANGLE or q, r
    do not fit the tree.

    The tree comes packed (``Tree.packed``) so the call checks five arguments, not thirteen:
    ints = [N, nnz, parent (N), jcol (N), nz_ptr (N + 1), nz_k (nnz), nz_j (nnz)],
    reals = [coef (N), off (N), nz_a (3·nnz), root_r (9), root_o (3)].
    """
    nb = ints[0]
    nnz = ints[1]
    o_par, o_jc, o_ptr = 2, 2 + nb, 2 + 2 * nb
    o_k = o_ptr + nb + 1
    o_j = o_k + nnz
    o_a, o_rr = 2 * nb, 2 * nb + 3 * nnz
    if r.shape[0] != nb or r.shape[1] != 3 or out.shape[1] > 3:
        return False
    for j in range(q.shape[0]):
        if not math.isfinite(q[j]):
            return False
    rot = np.empty((nb, 3, 3))
    for b in range(nb):
        p = ints[o_par + b]
        if p < 0:
            for i in range(3):
                for j in range(3):
                    rot[b, i, j] = reals[o_rr + 3 * i + j]
            continue
        s, c1 = 0.0, 0.0
        jc = ints[o_jc + b]
        if jc >= 0:
            theta = reals[b] * q[jc] + reals[nb + b]
            if not abs(theta) < MAX_ANGLE:  # numpy's exact reduction: the caller's path
                return False
            s, c1 = sin_cos1m(theta)
        for i in range(3):
            for j in range(3):
                rot[b, i, j] = 0.0
        for z in range(ints[o_ptr + b], ints[o_ptr + b + 1]):
            kk = ints[o_k + z]
            jj = ints[o_j + z]
            m = reals[o_a + 3 * z] + reals[o_a + 3 * z + 1] * s + reals[o_a + 3 * z + 2] * c1
            for i in range(3):
                rot[b, i, jj] += rot[p, i, kk] * m
    for i in range(out.shape[1]):  # the CoM's one summation order (``cop``)
        acc = reals[o_rr + 9 + i]
        for b in range(nb):
            for j in range(3):
                acc += rot[b, i, j] * r[b, j]
        out[0, i] = acc
    return True


def com_one(tree: Tree, q: np.ndarray, r: np.ndarray, k: int = 3) -> np.ndarray | None:
    """The first k of the CoM, (1, k), at one pose q (nq,) float64 C-contiguous, for SESC
    vectors r (N, 3) float64 C-contiguous, in one compiled call (a controller's per-pose query).
    None while the kernels are not loaded, or when q is not finite or q, r do not fit the tree
    (the caller's checked path then says what is wrong)."""
    if not compiled() or q.shape[0] != tree.nq:
        return None
    out = np.empty((1, k))
    ints, reals = tree.packed
    return out if _com_one(q, ints, reals, r, out) else None


def chain_numpy(tree: Tree, s: np.ndarray, c1: np.ndarray, rot: np.ndarray) -> None:
    """``chain_block`` in numpy, the same products and sums in the same order (the same bits):
    R_b[:, j] = Σ_k R_p[:, k] M_b[k, j] over M_b's non-zero entries, across the block's poses."""
    a = tree.nz_a
    body = np.repeat(np.arange(tree.parent.shape[0]), np.diff(tree.nz_ptr))
    mb = (a[:, 0, None] + a[:, 1, None] * s[body]) + a[:, 2, None] * c1[body]  # M_b entries
    tmp = np.empty(rot.shape[2:])
    for b in range(tree.parent.shape[0]):
        p = tree.parent[b]
        if p < 0:
            rot[b] = tree.root_r.T[:, :, None]
            continue
        rb, rp = rot[b], rot[p]
        rb[...] = 0.0
        for z in range(tree.nz_ptr[b], tree.nz_ptr[b + 1]):
            np.multiply(rp[tree.nz_k[z]], mb[z], out=tmp)
            rb[tree.nz_j[z]] += tmp


def chain(
    tree: Tree, q: np.ndarray, ws: Workspace | None = None, kernels: bool | None = None
) -> np.ndarray:
    """Rotations of a block of m ≤ ws.block poses, layout (N, 3, 3, m): [b, j, i, k] = R_b[i, j].

    ``q`` must already be validated (see ``as_poses``). The result is a view into the
    workspace, overwritten by the next call. ``kernels``: the job's path (``prefer_kernels`` of
    the whole job's size; None: this block's); numpy and the kernels give the same bits.
    """
    ws = ws or Workspace(tree, max(len(q), 1))
    m = q.shape[0]
    if m == ws.block:
        s, c1, rot = ws.s, ws.c1, ws.rot
    else:
        s, c1 = np.empty((len(tree.parent), m)), np.empty((len(tree.parent), m))
        rot = np.empty(ws.rot.shape[:3] + (m,))
    if kernels is None:
        kernels = prefer_kernels(m * len(tree.parent))
    if not kernels:
        if reducible(q):
            trig_poly_numpy(tree, q, s, c1)
        else:
            trig_numpy(tree, q, s, c1)
        chain_numpy(tree, s, c1, rot)
        return rot
    if reducible(q):
        joint_trig(np.ascontiguousarray(q.T), tree.jcol, tree.coef, tree.off, s, c1)
    else:  # huge angles: exact reduction by numpy
        trig_numpy(tree, q, s, c1)
    chain_block(s, c1, tree.arrays, rot)
    return rot


def origins(rot: np.ndarray, tree: Tree, org: np.ndarray, kernels: bool) -> None:
    """Org (N, 3, m) from rot (N, 3, 3, m): the kernel, or numpy (the same bits)."""
    if kernels:
        origins_block(rot, tree.parent, tree.t, tree.root_o, org)
        return
    for b in range(tree.parent.shape[0]):  # the kernel's sums in its order: the same bits
        p = tree.parent[b]
        if p < 0:
            org[b] = tree.root_o[:, None]
        else:
            t = tree.t[b]
            np.add(org[p], rot[p, 0] * t[0], out=org[b])
            org[b] += rot[p, 1] * t[1]
            org[b] += rot[p, 2] * t[2]


def forward(tree: Tree, q: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Rotations (n, N, 3, 3) and origins (n, N, 3) [m] of every body in the support frame."""
    q = as_poses(q, tree.nq)
    n, nb = q.shape[0], tree.parent.shape[0]
    rot_out = np.empty((n, nb, 3, 3))
    org_out = np.empty((n, nb, 3))
    ws = Workspace(tree, min(CHAIN_BLOCK, max(n, 1)))
    org = np.empty((nb, 3, ws.block))
    kernels = prefer_kernels(n * nb)
    for s0 in range(0, n, ws.block):
        blk = q[s0 : s0 + ws.block]
        rot = chain(tree, blk, ws, kernels)
        o = org[..., : len(blk)] if len(blk) == ws.block else np.empty((nb, 3, len(blk)))
        origins(rot, tree, o, kernels)
        rot_out[s0 : s0 + len(blk)] = rot.transpose(3, 0, 2, 1)
        org_out[s0 : s0 + len(blk)] = o.transpose(2, 0, 1)
    return rot_out, org_out


def regressor(tree: Tree, q: ArrayLike, rows: tuple[int, ...] = (0, 1)) -> np.ndarray:
    """SESC regressor Φ (n, len(rows), 3N): CoM[rows] = d[rows] + Φ · vec(r).

    ``rows`` picks support-frame axes: (0, 1) for the CoP (x, y), (0, 1, 2) for the full CoM.
    Reshape to (n·len(rows), 3N) for the paper's stacked 2n × 3N form (x1, y1, x2, y2, …).
    """
    q = as_poses(q, tree.nq)
    rows = list(rows)
    n, nb = q.shape[0], tree.parent.shape[0]
    out = np.empty((n, len(rows), 3 * nb))
    ws = Workspace(tree, min(CHAIN_BLOCK, max(n, 1)))
    kernels = prefer_kernels(n * nb)
    for s0 in range(0, n, ws.block):
        rot = chain(tree, q[s0 : s0 + ws.block], ws, kernels)
        # rot[b, j, i, k] → out[k, i, 3b + j]
        out[s0 : s0 + rot.shape[3]] = rot[:, :, rows, :].reshape(3 * nb, len(rows), -1).T
    return out
