"""The CoM's x, y (the level-floor CoP) or x, y, z of many poses in one compiled pass over the rows
it needs, shared out among the cores, beside its numpy twin.

Every path sums the CoM in one order, so all give the same bits: start from the root's origin,
then add R_b[i, j]·r_b[j] for bodies b in order and j = 0, 1, 2, each product and sum rounded
on its own (no FMA): the compiled pass, the single-pose kernel (``chains._com_one``) and numpy.
"""

from __future__ import annotations

import numpy as np

from sescid.errors import DataError
from sescid.kinematics._kernels.chains import CHAIN_BLOCK, Workspace, chain
from sescid.kinematics._kernels.trig import MAX_ANGLE, reducible, trig_row
from sescid.kinematics.compile import GROUP, lazy_njit, prefer_kernels
from sescid.kinematics.tree import Tree


@lazy_njit(GROUP, cache=True, nogil=True)
def _cop_xy_kernel(q, tree, r, out):
    """Out (n, k): the first k ≤ 3 of root_o + Σ R_b r_b, only those rows of each R_b, in
    blocks (tree: ``Tree.arrays``). False (out untouched) when an angle is beyond MAX_ANGLE."""
    parent, jcol, coef, off = tree.parent, tree.jcol, tree.coef, tree.off
    nz_ptr, nz_k, nz_j, nz_a = tree.nz_ptr, tree.nz_k, tree.nz_j, tree.nz_a
    root_r, root_o = tree.root_r, tree.root_o
    nb = parent.shape[0]
    n = q.shape[0]
    nr = out.shape[1]
    for k in range(n):
        for j in range(q.shape[1]):
            if not abs(q[k, j]) < MAX_ANGLE:
                return False
    blk = 128
    rot = np.empty((nb, nr, 3, blk))
    s = np.empty(blk)
    c1 = np.empty(blk)
    acc = np.empty((nr, blk))
    qt = np.empty((q.shape[1], blk))
    for s0 in range(0, n, blk):
        w = min(blk, n - s0)
        for k in range(w):
            for j in range(q.shape[1]):
                qt[j, k] = q[s0 + k, j]
        for i in range(nr):
            acc[i, :] = root_o[i]
        for b in range(nb):
            p = parent[b]
            if p < 0:
                for i in range(nr):
                    for j in range(3):
                        rot[b, i, j, :] = root_r[i, j]
            else:
                jc = jcol[b]
                if jc < 0:
                    s[:] = 0.0
                    c1[:] = 0.0
                else:
                    trig_row(qt[jc], coef[b], off[b], w, s, c1)
                rot[b, :, :, :] = 0.0
                for z in range(nz_ptr[b], nz_ptr[b + 1]):
                    kk = nz_k[z]
                    jj = nz_j[z]
                    a0 = nz_a[z, 0]
                    a1 = nz_a[z, 1]
                    a2 = nz_a[z, 2]
                    if nr == 2:  # the CoP: both rows in one pass, M_b's entry in a register
                        o0 = rot[b, 0, jj]
                        o1 = rot[b, 1, jj]
                        i0 = rot[p, 0, kk]
                        i1 = rot[p, 1, kk]
                        for k in range(w):
                            mz = a0 + a1 * s[k] + a2 * c1[k]
                            o0[k] += i0[k] * mz
                            o1[k] += i1[k] * mz
                        continue
                    for k in range(w):
                        mz = a0 + a1 * s[k] + a2 * c1[k]
                        for i in range(nr):
                            rot[b, i, jj, k] += rot[p, i, kk, k] * mz
            for i in range(nr):
                for j in range(3):
                    rj = r[b, j]
                    for k in range(w):
                        acc[i, k] += rot[b, i, j, k] * rj
        for k in range(w):
            for i in range(nr):
                out[s0 + k, i] = acc[i, k]
    return True


def cop_xy(tree: Tree, q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """CoM x, y (n, 2) [m] of validated poses ``q`` (n, nq) within |q| < 1e5 rad, one compiled
    pass (loads the kernels: for screening many poses; the same bits as ``com_rows``). An angle
    beyond that range is an error here (``com_rows`` takes numpy's exact reduction instead)."""
    out = _com_or_none(tree, q, r, 2)
    if out is None:
        raise DataError(f"q: an angle beyond ±{MAX_ANGLE:g} rad")
    return out


#: poses per part when the CoP of many poses is shared out among the cores
PARALLEL_PART = 16384


def _com_or_none(tree: Tree, q: np.ndarray, r: np.ndarray, k: int) -> np.ndarray | None:
    from sescid.base.threads import ordered_map, usable_cores

    n = q.shape[0]
    out = np.empty((n, k))
    rr = np.ascontiguousarray(r, dtype=float)
    arrays = tree.arrays
    parts = max(min(usable_cores(), n // PARALLEL_PART), 1)
    edges = [n * j // parts for j in range(parts + 1)]

    def part(j: int) -> bool:  # poses are independent: any split gives the same bits
        a, b = edges[j], edges[j + 1]
        return _cop_xy_kernel(q[a:b], arrays, rr, out[a:b])

    return out if all(list(ordered_map(part, range(parts)))) else None


def com_sum(rot: np.ndarray, r: np.ndarray, root_o: np.ndarray, k: int) -> np.ndarray:
    """The kernel's CoM sum in numpy, (k, m): root_o[i] + Σ_b Σ_j R_b[i, j] r_b[j] in its order,
    from rotations rot (N, 3, 3, m) ([b, j, i, pose], ``chain``'s layout)."""
    m = rot.shape[3]
    out = np.empty((k, m))
    tmp = np.empty(m)
    for i in range(k):
        acc = out[i]
        acc[:] = root_o[i]
        for b in range(rot.shape[0]):
            for j in range(3):
                np.multiply(rot[b, j, i], r[b, j], out=tmp)
                acc += tmp
    return out


def com_rows(tree: Tree, q: np.ndarray, r: np.ndarray, k: int = 2) -> np.ndarray:
    """The first k ≤ 3 rows of the CoM, (n, k) [m], of validated poses q (n, nq) for SESC
    vectors r (N, 3): compiled for a large job (or with the kernels loaded), else numpy; both
    give the same bits, huge angles (beyond MAX_ANGLE) included (numpy's exact reduction)."""
    n, nb = q.shape[0], tree.parent.shape[0]
    rr = np.ascontiguousarray(r, dtype=float).reshape(nb, 3)
    if prefer_kernels(n * nb) and reducible(q):
        out = _com_or_none(tree, q, rr, k)
        if out is not None:
            return out
    out = np.empty((n, k))
    ws = Workspace(tree, min(CHAIN_BLOCK, max(n, 1)))
    for s in range(0, n, ws.block):
        rot = chain(tree, q[s : s + ws.block], ws, False)
        out[s : s + rot.shape[3]] = com_sum(rot, rr, tree.root_o, k).T
    return out
