"""The body tree as flat arrays for the kernels, and the joint-angle check of every entry point."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from sescid.errors import DataError
from sescid.model import RobotModel


class TreeArrays(NamedTuple):
    """The tree as one argument of the compiled kernels (``Tree.arrays``, built once per tree):
    numba resolves each field at compile time."""

    parent: np.ndarray  #: (N,) int64, −1 for the root
    jcol: np.ndarray  #: (N,) int64 column of q, −1 for the root
    coef: np.ndarray  #: (N,) sign × mimic multiplier
    off: np.ndarray  #: (N,) sign × mimic offset, rad
    nz_ptr: np.ndarray  #: (N + 1,) start of each body's non-zero entries of M_b
    nz_k: np.ndarray  #: row of each entry
    nz_j: np.ndarray  #: column of each entry
    nz_a: np.ndarray  #: (nnz, 3) coefficients a0, a1, a2 of each entry
    root_r: np.ndarray  #: (3, 3)
    root_o: np.ndarray  #: (3,)
    axis: np.ndarray  #: (N, 3) unit joint axis of each body in its own frame
    pos: np.ndarray  #: (N,) each body's place in depth-first order (−1: the support body)


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
    nz_ptr: np.ndarray  #: (N + 1,) start of each body's non-zero entries of M_b
    nz_k: np.ndarray  #: row of each entry
    nz_j: np.ndarray  #: column of each entry
    nz_a: np.ndarray  #: (nnz, 3) coefficients a0, a1, a2 of each entry
    axis: np.ndarray  #: (N, 3) unit joint axis of each body in its own frame (root: zeros)

    @cached_property
    def packed(self) -> tuple[np.ndarray, np.ndarray]:
        """The tree as one int64 and one float64 array (see ``_com_one``)."""
        nb, nnz = self.parent.shape[0], self.nz_k.shape[0]
        ints = np.concatenate(
            [[nb, nnz], self.parent, self.jcol, self.nz_ptr, self.nz_k, self.nz_j]
        ).astype(np.int64)
        reals = np.concatenate(
            [self.coef, self.off, self.nz_a.reshape(-1), self.root_r.reshape(-1), self.root_o]
        ).astype(float)
        return ints, reals

    @cached_property
    def arrays(self) -> TreeArrays:
        """The flat arrays the kernels read, as one argument."""
        return TreeArrays(
            self.parent, self.jcol, self.coef, self.off, self.nz_ptr, self.nz_k, self.nz_j,
            self.nz_a, self.root_r, self.root_o, self.axis, self.depth_first[1],
        )  # fmt: skip

    @cached_property
    def depth_first(self) -> tuple[np.ndarray, np.ndarray]:
        """(order (N − 1,), pos (N,)): the moving bodies in depth-first preorder from the
        support body (children in index order: every subtree is a contiguous range), and each
        body's place in it (−1 for the support body)."""
        children: list[list[int]] = [[] for _ in self.parent]
        for b in range(1, len(self.parent)):
            children[int(self.parent[b])].append(b)
        out, stack = [], [0]
        while stack:
            b = stack.pop()
            out.append(b)
            stack.extend(reversed(children[b]))
        order = np.asarray(out[1:], dtype=np.int64)
        pos = np.full(len(self.parent), -1, dtype=np.int64)
        pos[order] = np.arange(len(order))
        return order, pos

    @classmethod
    def from_model(cls, model: RobotModel) -> Tree:
        """Flatten a ``RobotModel`` into the kernels' arrays."""
        n = len(model.bodies)
        a0 = np.empty((n, 3, 3))
        a1 = np.empty((n, 3, 3))
        a2 = np.empty((n, 3, 3))
        for i, b in enumerate(model.bodies):
            x, y, z = b.axis
            skew = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
            a0[i] = b.rot_const
            a1[i] = _mat3(b.rot_const, skew)
            a2[i] = _mat3(a1[i], skew)
        ptr, ks, js, coefs = [0], [], [], []
        for i in range(n):
            for k in range(3):
                for j in range(3):
                    a = (a0[i, k, j], a1[i, k, j], a2[i, k, j])
                    if max(abs(v) for v in a) > 1e-15:
                        ks.append(k)
                        js.append(j)
                        coefs.append(a)
            ptr.append(len(ks))
        return cls(
            nz_ptr=np.array(ptr, dtype=np.int64),
            nz_k=np.array(ks, dtype=np.int64),
            nz_j=np.array(js, dtype=np.int64),
            nz_a=np.array(coefs, dtype=float).reshape(-1, 3),
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
            axis=np.array([b.axis for b in model.bodies], dtype=float).reshape(n, 3),
        )


def _mat3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A @ b for 3 × 3 matrices, each entry (a_i0 b_0j + a_i1 b_1j) + a_i2 b_2j (no BLAS: its
    order and FMAs follow the CPU)."""
    a = np.asarray(a, dtype=float)
    return (a[:, 0, None] * b[0] + a[:, 1, None] * b[1]) + a[:, 2, None] * b[2]


def as_poses(q: ArrayLike, nq: int, what: str = "q") -> np.ndarray:
    """Validate joint angles: (n, nq) or (nq,) finite radians → C-contiguous (n, nq) float64."""
    if type(q) is np.ndarray and q.shape == (nq,) and q.dtype == np.float64:
        if math.isfinite(q.sum()) and q.flags.c_contiguous:  # one pose, the common case
            return q.reshape(1, nq)
    arr = np.asarray(q, dtype=float)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != nq:
        raise DataError(f"{what}: expected shape (n, {nq}) joint angles, got {arr.shape}")
    # a finite sum proves every angle finite (nan and ±inf propagate) without a mask the size
    # of q; only an overflowing or non-finite sum takes the exact check
    with np.errstate(over="ignore", invalid="ignore"):
        total = float(arr.sum())
    if not math.isfinite(total) and not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise DataError(f"{what}: non-finite joint angle at pose {bad[0]}, joint {bad[1]}")
    return np.ascontiguousarray(arr)
