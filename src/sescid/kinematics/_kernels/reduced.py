"""The regressor in reduced coordinates: the structural null directions removed in closed form."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sescid.kinematics._kernels.chains import Workspace, chain
from sescid.kinematics.compile import GROUP, lazy_njit, prefer_kernels
from sescid.kinematics.tree import Tree


@dataclass(frozen=True)
class Reduction:
    """Reduced coordinates β = G·vec(r) with Φ·vec(r) = Φ_red·β for the given rows."""

    rows: tuple[int, ...]
    u: np.ndarray  #: (N, 2, 3) unit vectors ⊥ each body's joint axis (body frame)
    g: np.ndarray  #: (len(rows) + 2(N − 1), 3N)


def _dot3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(a·b) over the last axis of length 3, summed (a0 b0 + a1 b1) + a2 b2 (no BLAS: its
    order and FMAs follow the CPU)."""
    return (a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]) + a[..., 2] * b[..., 2]


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.sqrt(_dot3(v, v))


def reduction(tree: Tree, axes: np.ndarray, rows=(0, 1)) -> Reduction:
    """Build the reduced coordinates of a tree; ``axes`` (N, 3) are the bodies' joint axes
    (every product in a fixed order: the same bits on every CPU)."""
    nb = tree.parent.shape[0]
    rows = tuple(rows)
    u = np.zeros((nb, 2, 3))
    unit = np.zeros((nb, 3))
    for b in range(1, nb):
        a = unit[b] = _unit(np.asarray(axes[b], dtype=float))
        helper = np.eye(3)[np.argmin(np.abs(a))]
        u[b, 0] = _unit(np.cross(a, helper))
        u[b, 1] = np.cross(a, u[b, 0])
    nr = len(rows)
    g = np.zeros((nr + 2 * (nb - 1), 3 * nb))
    root = tree.root_r[list(rows)]
    for col in range(3 * nb):
        r = np.zeros((nb, 3))
        r.flat[col] = 1.0
        for b in range(nb - 1, 0, -1):  # children before parents: push axis parts upward
            a = unit[b]
            alpha = _dot3(a, r[b])
            r[tree.parent[b]] += alpha * _dot3(tree.a0[b], a)
            r[b] -= alpha * a
        g[:nr, col] = _dot3(root, r[0])
        g[nr:, col] = _dot3(u[1:], r[1:, None, :]).reshape(-1)
    return Reduction(rows, u, g)


@lazy_njit(GROUP, cache=True, nogil=True)
def _reduced_kernel(rot, rows, u, out):
    """Out (P_red, len(rows)·m), columns ordered (row, pose): intercepts, then R_b[row] u_l."""
    nb = rot.shape[0]
    m = rot.shape[3]
    nr = rows.shape[0]
    for c in range(nr):
        for i in range(nr):
            v = 1.0 if i == c else 0.0
            for k in range(m):
                out[c, i * m + k] = v
    for b in range(1, nb):
        for el in range(2):
            c = nr + 2 * (b - 1) + el
            u0 = u[b, el, 0]
            u1 = u[b, el, 1]
            u2 = u[b, el, 2]
            for i in range(nr):
                row = rows[i]
                for k in range(m):
                    out[c, i * m + k] = (
                        rot[b, 0, row, k] * u0 + rot[b, 1, row, k] * u1 + rot[b, 2, row, k] * u2
                    )


def reduced_columns(
    tree: Tree,
    red: Reduction,
    q: np.ndarray,
    ws: Workspace | None = None,
    kernels: bool | None = None,
) -> np.ndarray:
    """Φ_redᵀ of a block of validated poses: (P_red, len(rows)·m), columns ordered (row, pose).
    ``kernels``: the job's path (None: ``prefer_kernels`` of this block); both the same bits."""
    if kernels is None:
        kernels = prefer_kernels(q.shape[0] * tree.parent.shape[0])
    rot = chain(tree, q, ws, kernels)
    shape = (red.g.shape[0], len(red.rows) * rot.shape[3])
    out = ws.buffer("reduced", shape) if ws is not None else np.empty(shape)
    if not kernels:  # the chain ran in numpy: so does this
        nr, m = len(red.rows), rot.shape[3]
        out[:nr] = np.repeat(np.eye(nr), m, axis=1)
        # out[nr + 2(b−1) + l, i·m + k] = Σ_j rot[b, j, row_i, k] u[b, l, j], the kernel's order
        r = rot[1:][:, :, list(red.rows), :, None].transpose(0, 1, 4, 2, 3)  # (b, j, 1, i, k)
        u = red.u[1:, :, :, None, None]  # (b, l, j, 1, 1)
        part = r[:, 0] * u[:, :, 0]
        part += r[:, 1] * u[:, :, 1]
        part += r[:, 2] * u[:, :, 2]
        out[nr:] = part.reshape(out.shape[0] - nr, -1)
        return out
    _reduced_kernel(rot, np.asarray(red.rows, dtype=np.int64), red.u, out)
    return out
