"""The CoM's x, y (the level-floor CoP) of many poses in one compiled pass over the two rows it
needs, shared out among the cores."""

from __future__ import annotations

import numpy as np

from sescid.errors import DataError
from sescid.kinematics.compile import GROUP, _within_budget, lazy_njit
from sescid.kinematics.tree import Tree
from sescid.kinematics.trig import MAX_ANGLE, _trig_row


@lazy_njit(GROUP, cache=True, nogil=True, fastmath={"contract"})
def _cop_xy_kernel(q, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r, r, root_o, out):
    """Out (n, 2): x, y of root_o + Σ R_b r_b, rows 0 and 1 of each R_b only, in blocks.
    False (out untouched) when an angle is beyond MAX_ANGLE."""
    nb = parent.shape[0]
    n = q.shape[0]
    for k in range(n):
        for j in range(q.shape[1]):
            if not abs(q[k, j]) < MAX_ANGLE:
                return False
    blk = 128
    rot = np.empty((nb, 2, 3, blk))
    s = np.empty(blk)
    c1 = np.empty(blk)
    ox = np.empty(blk)
    oy = np.empty(blk)
    qt = np.empty((q.shape[1], blk))
    for s0 in range(0, n, blk):
        w = min(blk, n - s0)
        for k in range(w):
            for j in range(q.shape[1]):
                qt[j, k] = q[s0 + k, j]
        ox[:] = root_o[0]
        oy[:] = root_o[1]
        for b in range(nb):
            p = parent[b]
            if p < 0:
                for i in range(2):
                    for j in range(3):
                        rot[b, i, j, :] = root_r[i, j]
            else:
                jc = jcol[b]
                if jc < 0:
                    s[:] = 0.0
                    c1[:] = 0.0
                else:
                    cb = coef[b]
                    ob = off[b]
                    _trig_row(qt[jc], cb, ob, w, s, c1)
                rot[b, :, :, :] = 0.0
                for z in range(nz_ptr[b], nz_ptr[b + 1]):
                    kk = nz_k[z]
                    jj = nz_j[z]
                    a0 = nz_a[z, 0]
                    a1 = nz_a[z, 1]
                    a2 = nz_a[z, 2]
                    o0 = rot[b, 0, jj]
                    o1 = rot[b, 1, jj]
                    i0 = rot[p, 0, kk]
                    i1 = rot[p, 1, kk]
                    for k in range(w):  # the entry of M_b in a register, both rows in one pass
                        mz = a0 + a1 * s[k] + a2 * c1[k]
                        o0[k] += i0[k] * mz
                        o1[k] += i1[k] * mz
            for j in range(3):
                rj = r[b, j]
                for k in range(w):
                    ox[k] += rot[b, 0, j, k] * rj
                    oy[k] += rot[b, 1, j, k] * rj
        for k in range(w):
            out[s0 + k, 0] = ox[k]
            out[s0 + k, 1] = oy[k]
    return True


def cop_xy(tree: Tree, q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """CoM x, y (n, 2) [m] of validated poses ``q`` (n, nq) within |q| < 1e5 rad, one compiled
    pass: for screening many poses (rounding differs from ``sesc.com_from_sesc`` by ~1e-16 m).
    An angle beyond that range is an error here (``cop_xy_compiled`` falls back instead)."""
    out = _cop_xy_or_none(tree, q, r)
    if out is None:
        raise DataError(f"q: an angle beyond ±{MAX_ANGLE:g} rad")
    return out


#: poses per part when the CoP of many poses is shared out among the cores
PARALLEL_PART = 16384


def _cop_xy_or_none(tree: Tree, q: np.ndarray, r: np.ndarray) -> np.ndarray | None:
    from sescid.base.threads import ordered_map, usable_cores

    n = q.shape[0]
    out = np.empty((n, 2))
    rr = np.ascontiguousarray(r, dtype=float)
    parts = max(min(usable_cores(), n // PARALLEL_PART), 1)
    edges = [n * k // parts for k in range(parts + 1)]

    def part(k: int) -> bool:  # poses are independent: any split gives the same bits
        a, b = edges[k], edges[k + 1]
        return _cop_xy_kernel(
            q[a:b], tree.jcol, tree.coef, tree.off, tree.parent, tree.nz_ptr, tree.nz_k,
            tree.nz_j, tree.nz_a, tree.root_r, rr, tree.root_o, out[a:b],
        )  # fmt: skip

    return out if all(list(ordered_map(part, range(parts)))) else None


def cop_xy_compiled(tree: Tree, q: np.ndarray, r: np.ndarray) -> np.ndarray | None:
    """``cop_xy`` (q validated, |q| < MAX_ANGLE): the CoP of many poses in one pass over the
    rows it needs, loading the kernels if the whole job would overrun the numpy path's budget;
    None while the job fits that budget (``chain`` then runs it in numpy, block by block)."""
    nb = tree.parent.shape[0]
    if _within_budget(q.shape[0], nb):
        return None
    return _cop_xy_or_none(tree, q, r)
