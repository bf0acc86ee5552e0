"""Holding torques and their regressor rows for many poses: a compiled pass beside its numpy twin
(the same operations in the same order: the same bits), no BLAS (whose order follows the CPU).

With the support held, joint column j holds τ_j = M Σ_{b: joint(b) = j} coef_b h_b·F_b, where
F_b = Σ_{i in the subtree of b} R_i r_i (the first moment beyond the joint), h_b = (R_b a_b) × g
and g the gravity vector in the support frame (``sesc`` has the derivation). The order, on every
path: c_i = (R_i[:, 0] r_i0 + R_i[:, 1] r_i1) + R_i[:, 2] r_i2; F = c, then F[parent(b)] += F[b]
for b from the last body down; A_b = R_b a_b likewise; h = A × g component by component;
h·F = (h_x F_x + h_y F_y) + h_z F_z; τ_j += (M coef_b)·(h·F) over its bodies in index order.
"""

from __future__ import annotations

import numpy as np

from sescid.kinematics._kernels.chains import CHAIN_BLOCK, Workspace, chain, chain_block
from sescid.kinematics._kernels.trig import joint_trig, reducible
from sescid.kinematics.compile import GROUP, lazy_njit, prefer_kernels
from sescid.kinematics.tree import Tree


@lazy_njit(GROUP, cache=True, nogil=True)
def _torques_block(rot, tree, jbody, r, g, mass, buf):  # pragma: no cover - compiled
    """out[k, j] for a block's rotations rot (N, 3, 3, m) [b, j, i, k] = R_b[i, j], the tree
    (``Tree.arrays``), gravity g (m, 3), joints' bodies jbody (J, B) (−1 padded): see the module
    docstring; buf = (f (N, 3, m) scratch, out (m, J))."""
    parent, axis, coef = tree.parent, tree.axis, tree.coef
    f, out = buf
    nb = rot.shape[0]
    m = rot.shape[3]
    for b in range(nb):
        for i in range(3):
            for k in range(m):
                f[b, i, k] = (rot[b, 0, i, k] * r[b, 0] + rot[b, 1, i, k] * r[b, 1]) + rot[
                    b, 2, i, k
                ] * r[b, 2]
    for b in range(nb - 1, 0, -1):
        p = parent[b]
        for i in range(3):
            for k in range(m):
                f[p, i, k] += f[b, i, k]
    for j in range(jbody.shape[0]):
        for k in range(m):
            out[k, j] = 0.0
        for t in range(jbody.shape[1]):
            b = jbody[j, t]
            if b < 0:
                continue
            sc = mass * coef[b]
            a0, a1, a2 = axis[b, 0], axis[b, 1], axis[b, 2]
            for k in range(m):
                ax = (rot[b, 0, 0, k] * a0 + rot[b, 1, 0, k] * a1) + rot[b, 2, 0, k] * a2
                ay = (rot[b, 0, 1, k] * a0 + rot[b, 1, 1, k] * a1) + rot[b, 2, 1, k] * a2
                az = (rot[b, 0, 2, k] * a0 + rot[b, 1, 2, k] * a1) + rot[b, 2, 2, k] * a2
                hx = ay * g[k, 2] - az * g[k, 1]
                hy = az * g[k, 0] - ax * g[k, 2]
                hz = ax * g[k, 1] - ay * g[k, 0]
                out[k, j] += sc * ((hx * f[b, 0, k] + hy * f[b, 1, k]) + hz * f[b, 2, k])


def joint_bodies_padded(tree: Tree, cols: np.ndarray) -> np.ndarray:
    """(J, B) the bodies each q column drives (several for a mimic joint), −1 padded."""
    lists = [np.flatnonzero(tree.jcol == j) for j in cols]
    out = np.full((len(lists), max([len(x) for x in lists], default=0) or 1), -1, dtype=np.int64)
    for j, bodies in enumerate(lists):
        out[j, : len(bodies)] = bodies
    return out


def torques_numpy(rot, tree: Tree, jbody, r, g, mass) -> np.ndarray:
    """``_torques_block`` in numpy: the same operations in the same order."""
    f = (rot[:, 0] * r[:, 0, None, None] + rot[:, 1] * r[:, 1, None, None]) + rot[:, 2] * r[
        :, 2, None, None
    ]  # (N, 3, m)
    for b in range(rot.shape[0] - 1, 0, -1):
        f[tree.parent[b]] += f[b]
    out = np.zeros((rot.shape[3], jbody.shape[0]))
    for j in range(jbody.shape[0]):
        for b in jbody[j]:
            if b < 0:
                continue
            a = tree.axis[b]
            ax, ay, az = (rot[b, 0] * a[0] + rot[b, 1] * a[1]) + rot[b, 2] * a[2]  # (3, m)
            hx = ay * g[:, 2] - az * g[:, 1]
            hy = az * g[:, 0] - ax * g[:, 2]
            hz = ax * g[:, 1] - ay * g[:, 0]
            out[:, j] += (mass * tree.coef[b]) * ((hx * f[b, 0] + hy * f[b, 1]) + hz * f[b, 2])
    return out


def torque_values(
    tree: Tree, q: np.ndarray, r: np.ndarray, mass: float, cols: np.ndarray, g: np.ndarray
) -> np.ndarray:
    """Holding torques (n, J) [N·m] of q columns ``cols`` at validated poses q (n, nq) for SESC
    vectors r (N, 3) [m], total mass [kg] and gravity vectors g (n, 3) [m/s²] (support frame):
    compiled for a large job (or with the kernels loaded), else numpy; the same bits."""
    n, nb = q.shape[0], tree.parent.shape[0]
    rr = np.ascontiguousarray(r, dtype=float).reshape(nb, 3)
    jbody = joint_bodies_padded(tree, np.asarray(cols, dtype=np.int64))
    kernels = prefer_kernels(n * nb)
    out = np.empty((n, jbody.shape[0]))
    ws = Workspace(tree, min(CHAIN_BLOCK, max(n, 1)))
    f = np.empty((nb, 3, ws.block))
    for s in range(0, n, ws.block):
        blk = slice(s, s + ws.block)
        gb = np.ascontiguousarray(g[blk], dtype=float)
        if kernels and reducible(q[blk]):
            rot = _chain_kernel(tree, q[blk], ws)
            m = rot.shape[3]
            scratch = f[..., :m] if m == ws.block else np.empty((nb, 3, m))
            _torques_block(rot, tree.arrays, jbody, rr, gb, float(mass), (scratch, out[blk]))
        else:
            rot = chain(tree, q[blk], ws, False)
            out[blk] = torques_numpy(rot, tree, jbody, rr, gb, float(mass))
    return out


def _chain_kernel(tree: Tree, q: np.ndarray, ws: Workspace) -> np.ndarray:
    """``chain`` on the kernels (|q| < MAX_ANGLE), into the workspace."""
    m = q.shape[0]
    if m == ws.block:
        s, c1, rot = ws.s, ws.c1, ws.rot
    else:
        nb = tree.parent.shape[0]
        s, c1, rot = np.empty((nb, m)), np.empty((nb, m)), np.empty((nb, 3, 3, m))
    joint_trig(np.ascontiguousarray(q.T), tree.jcol, tree.coef, tree.off, s, c1)
    chain_block(s, c1, tree.arrays, rot)
    return rot


def torque_rows(tree: Tree, q: np.ndarray, cols: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Φ_τ (n, J, 3N) [m/s²] with τ = M Φ_τ vec(r) for q columns ``cols`` at validated poses q
    (n, nq) under gravity vectors g (n, 3) [m/s²]: row j, body i's three entries are
    Σ_{b: joint(b) = j, i in the subtree of b} coef_b h_bᵀ R_i, each h_bᵀ R_i summed as
    (h_x R_i[0] + h_y R_i[1]) + h_z R_i[2] (fixed order, numpy)."""
    from sescid.kinematics._kernels.chains import forward

    n, nb = q.shape[0], tree.parent.shape[0]
    jbody = joint_bodies_padded(tree, np.asarray(cols, dtype=np.int64))
    sub = [[b] for b in range(nb)]
    for b in range(nb - 1, 0, -1):  # children after parents: each subtree's bodies, in order
        sub[tree.parent[b]] = sorted(set(sub[tree.parent[b]]) | set(sub[b]))
    out = np.zeros((n, jbody.shape[0], nb, 3))
    for s in range(0, n, CHAIN_BLOCK):
        rot, _ = forward(tree, q[s : s + CHAIN_BLOCK])  # (m, N, 3, 3) [k, b, i, j] = R_b[i, j]
        gb = g[s : s + CHAIN_BLOCK]
        blk = out[s : s + rot.shape[0]]
        for j in range(jbody.shape[0]):
            for b in jbody[j]:
                if b < 0:
                    continue
                a = tree.axis[b]
                rb = rot[:, b]
                ax, ay, az = ((rb[:, :, 0] * a[0] + rb[:, :, 1] * a[1]) + rb[:, :, 2] * a[2]).T
                hx = ay * gb[:, 2] - az * gb[:, 1]
                hy = az * gb[:, 0] - ax * gb[:, 2]
                hz = ax * gb[:, 1] - ay * gb[:, 0]
                ri = rot[:, sub[b]]  # (m, |sub|, 3, 3)
                hr = (hx[:, None, None] * ri[:, :, 0] + hy[:, None, None] * ri[:, :, 1]) + hz[
                    :, None, None
                ] * ri[:, :, 2]
                blk[:, j, sub[b]] += tree.coef[b] * hr
    return out.reshape(n, jbody.shape[0], 3 * nb)
