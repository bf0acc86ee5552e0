"""Rotations and origins of every body relative to the support frame, for n poses at once.

The per-pose chain is evaluated by a small compiled kernel (numba), looping over poses inside
compiled code: there is no Python loop per pose. Each body's joint contributes

    M_b(θ) = C_b Rot(a_b, θ) = A0_b + sin θ · A1_b + (1 − cos θ) · A2_b,   θ = coef_b q_j + off_b

with A0 = C, A1 = C K, A2 = C K² and K the cross-product matrix of the axis (Rodrigues).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .errors import SescidError
from .model import RobotModel


@dataclass(frozen=True)
class Tree:
    """The body tree as flat arrays, ready for the compiled kernels."""

    parent: np.ndarray  #: (N,) int64, −1 for the root
    jcol: np.ndarray  #: (N,) int64 column of q, −1 for the root
    coef: np.ndarray  #: (N,) sign × mimic multiplier
    off: np.ndarray  #: (N,) sign × mimic offset, rad
    a0: np.ndarray  #: (N, 3, 3)
    a1: np.ndarray  #: (N, 3, 3)
    a2: np.ndarray  #: (N, 3, 3)
    t: np.ndarray  #: (N, 3) translation from the parent frame, m
    root_r: np.ndarray  #: (3, 3)
    root_o: np.ndarray  #: (3,)
    nq: int

    @classmethod
    def from_model(cls, model: RobotModel) -> Tree:
        n = len(model.bodies)
        a0 = np.empty((n, 3, 3))
        a1 = np.empty((n, 3, 3))
        a2 = np.empty((n, 3, 3))
        for i, b in enumerate(model.bodies):
            x, y, z = b.axis
            k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
            a0[i] = b.rot_const
            a1[i] = b.rot_const @ k
            a2[i] = b.rot_const @ k @ k
        return cls(
            parent=np.array([b.parent for b in model.bodies], dtype=np.int64),
            jcol=np.array([b.joint for b in model.bodies], dtype=np.int64),
            coef=np.array([b.sign * b.multiplier for b in model.bodies]),
            off=np.array([b.sign * b.offset for b in model.bodies]),
            a0=a0,
            a1=a1,
            a2=a2,
            t=np.array([b.trans_const for b in model.bodies]),
            root_r=np.ascontiguousarray(model.root_rotation, dtype=float),
            root_o=np.ascontiguousarray(model.root_origin, dtype=float),
            nq=len(model.joint_names),
        )


@numba.njit(cache=True, nogil=True)
def _pose_rotations(qk, parent, jcol, coef, off, a0, a1, a2, root_r, rot):
    """Fill rot (N, 3, 3) for one pose qk (nq,)."""
    nb = parent.shape[0]
    m = np.empty((3, 3))
    for b in range(nb):
        p = parent[b]
        if p < 0:
            for i in range(3):
                for j in range(3):
                    rot[b, i, j] = root_r[i, j]
            continue
        th = coef[b] * qk[jcol[b]] + off[b]
        s = np.sin(th)
        c1 = 1.0 - np.cos(th)
        for i in range(3):
            for j in range(3):
                m[i, j] = a0[b, i, j] + s * a1[b, i, j] + c1 * a2[b, i, j]
        for i in range(3):
            r0 = rot[p, i, 0]
            r1 = rot[p, i, 1]
            r2 = rot[p, i, 2]
            for j in range(3):
                rot[b, i, j] = r0 * m[0, j] + r1 * m[1, j] + r2 * m[2, j]


@numba.njit(cache=True, nogil=True)
def _forward_kernel(q, parent, jcol, coef, off, a0, a1, a2, t, root_r, root_o, rot, org):
    n = q.shape[0]
    nb = parent.shape[0]
    for k in range(n):
        _pose_rotations(q[k], parent, jcol, coef, off, a0, a1, a2, root_r, rot[k])
        for b in range(nb):
            p = parent[b]
            if p < 0:
                for i in range(3):
                    org[k, b, i] = root_o[i]
                continue
            for i in range(3):
                org[k, b, i] = (
                    org[k, p, i]
                    + rot[k, p, i, 0] * t[b, 0]
                    + rot[k, p, i, 1] * t[b, 1]
                    + rot[k, p, i, 2] * t[b, 2]
                )


@numba.njit(cache=True, nogil=True)
def _regressor_kernel(q, parent, jcol, coef, off, a0, a1, a2, root_r, rows, out):
    """out[k, r, 3b + c] = R_b(q_k)[rows[r], c]: the SESC regressor rows for each pose."""
    n = q.shape[0]
    nb = parent.shape[0]
    rot = np.empty((nb, 3, 3))
    nr = rows.shape[0]
    for k in range(n):
        _pose_rotations(q[k], parent, jcol, coef, off, a0, a1, a2, root_r, rot)
        for r in range(nr):
            row = rows[r]
            for b in range(nb):
                out[k, r, 3 * b] = rot[b, row, 0]
                out[k, r, 3 * b + 1] = rot[b, row, 1]
                out[k, r, 3 * b + 2] = rot[b, row, 2]


def as_poses(q, nq: int, what: str = "q") -> np.ndarray:
    """Validate joint angles: (n, nq) or (nq,) finite radians → C-contiguous (n, nq) float64."""
    arr = np.asarray(q, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != nq:
        raise SescidError(f"{what}: expected shape (n, {nq}) joint angles, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise SescidError(f"{what}: non-finite joint angle at pose {bad[0]}, joint {bad[1]}")
    return np.ascontiguousarray(arr)


def forward(tree: Tree, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotations (n, N, 3, 3) and origins (n, N, 3) [m] of every body in the support frame."""
    q = as_poses(q, tree.nq)
    n, nb = q.shape[0], tree.parent.shape[0]
    rot = np.empty((n, nb, 3, 3))
    org = np.empty((n, nb, 3))
    _forward_kernel(
        q,
        tree.parent,
        tree.jcol,
        tree.coef,
        tree.off,
        tree.a0,
        tree.a1,
        tree.a2,
        tree.t,
        tree.root_r,
        tree.root_o,
        rot,
        org,
    )
    return rot, org


def regressor(tree: Tree, q: np.ndarray, rows=(0, 1), out: np.ndarray | None = None) -> np.ndarray:
    """SESC regressor Φ (n, len(rows), 3N): CoM[rows] = d[rows] + Φ · vec(r).

    ``rows`` picks support-frame axes: (0, 1) for the CoP (x, y), (0, 1, 2) for the full CoM.
    Reshape to (n·len(rows), 3N) for the paper's stacked 2n × 3N form (x1, y1, x2, y2, …).
    """
    q = as_poses(q, tree.nq)
    rows_arr = np.asarray(rows, dtype=np.int64)
    shape = (q.shape[0], rows_arr.shape[0], 3 * tree.parent.shape[0])
    if out is None:
        out = np.empty(shape)
    elif out.shape != shape or not out.flags.c_contiguous:
        raise ValueError(f"out must be C-contiguous with shape {shape}")
    _regressor_kernel(
        q,
        tree.parent,
        tree.jcol,
        tree.coef,
        tree.off,
        tree.a0,
        tree.a1,
        tree.a2,
        tree.root_r,
        rows_arr,
        out,
    )
    return out
