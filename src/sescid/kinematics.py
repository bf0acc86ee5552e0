"""Rotations and origins of every body relative to the support frame, for n poses at once.

The chain is evaluated block by block (``CHAIN_BLOCK`` poses) by a small compiled kernel
(numba) in structure-of-arrays layout, its inner loops running across poses (SIMD); sin/cos are
computed in the kernel (Cody–Waite reduction and Taylor polynomials, within 2 ulp of libm),
which lets the compiler vectorise them too. There is no Python loop per pose. numba is imported
when a kernel first runs (``lazy_njit``), so loading a robot does not pay for it. Each body's joint
contributes

    M_b(θ) = C_b Rot(a_b, θ) = A0_b + sin θ · A1_b + (1 − cos θ) · A2_b,   θ = coef_b q_j + off_b

with A0 = C, A1 = C K, A2 = C K² and K the cross-product matrix of the axis (Rodrigues).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from sescid.errors import DataError
from sescid.model import RobotModel


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
            a1[i] = b.rot_const @ skew
            a2[i] = b.rot_const @ skew @ skew
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
        )


class _LazyKernel:
    """A numba kernel compiled on first call; until then numba is not even imported."""

    def __init__(self, fn: Callable, options: dict[str, Any]):
        self.fn, self.options = fn, options
        self.__doc__, self.__name__ = fn.__doc__, fn.__name__

    def __call__(self, *args):
        return _compile_module(self.fn.__module__)[self.fn.__name__](*args)


_LAZY: dict[str, list[_LazyKernel]] = {}
_SWAP_LOCK = threading.Lock()


def _compile_module(module: str) -> dict[str, Any]:
    """Swap every lazy kernel of ``module`` for its numba dispatcher (kernels call each other
    through module globals, so all of them are swapped before any compiles). The dispatchers
    use numba's on-disk cache (``cache=True``) where one is writable (beside the package, else
    ``NUMBA_CACHE_DIR`` or the user's cache folder), else compile in memory, silently."""
    import sys

    import numba

    namespace = vars(sys.modules[module])
    with _SWAP_LOCK:  # a second thread's first call waits here, then finds the dispatchers
        _swap(module, namespace, numba)
    return namespace


def _swap(module: str, namespace: dict[str, Any], numba: Any) -> None:
    for kernel in _LAZY.pop(module, []):
        try:
            compiled = numba.njit(**kernel.options)(kernel.fn)
        except RuntimeError as exc:  # "cannot cache function …: no locator available"
            if "no locator available" not in str(exc):
                raise
            # a read-only install (service user, read-only container): compile in memory
            compiled = numba.njit(**(kernel.options | {"cache": False}))(kernel.fn)
        namespace[kernel.fn.__name__] = compiled


def lazy_njit(**options: Any) -> Callable[[Callable], Any]:
    """``numba.njit(**options)`` deferred to the first call of any kernel of the module."""

    def wrap(fn: Callable) -> _LazyKernel:
        kernel = _LazyKernel(fn, options)
        _LAZY.setdefault(fn.__module__, []).append(kernel)
        return kernel

    return wrap


# Cody–Waite split of π/2 (fdlibm) and Taylor coefficients: |error| ≤ 2 ulp for |θ| < 1e5.
_PIO2_1 = 1.57079632673412561417e00
_PIO2_2 = 6.07710050630396597660e-11
_PIO2_2T = 2.02226624879595063154e-21
_TWO_OVER_PI = 6.36619772367581382433e-01
MAX_ANGLE = 1e5  #: rad; beyond this the reduction loses accuracy and numpy's sin/cos is used


#: rad: below this |θ| the reduction is the identity (its quotient is 0 since θ·2/π + ½ < 1),
#: so the polynomials alone give ``_sin_cos1m``'s bits for less work
SMALL_ANGLE = 0.78


@lazy_njit(cache=True, nogil=True, inline="always")
def _sin_cm(r):
    """Sin r and cos r − 1 for |r| ≤ π/4 (Taylor, ≤ 2 ulp)."""
    z = r * r
    sp = r + r * z * (
        -1 / 6
        + z
        * (
            1 / 120
            + z * (-1 / 5040 + z * (1 / 362880 + z * (-1 / 39916800 + z * (1 / 6227020800))))
        )
    )
    sp += r * z**7 * (-1 / 1307674368000)
    cm = z * (
        -0.5 + z * (1 / 24 + z * (-1 / 720 + z * (1 / 40320 + z * (-1 / 3628800 + z / 479001600))))
    )
    cm += z**7 * (-1 / 87178291200 + z / 20922789888000)  # cm = cos r − 1
    return sp, cm


@lazy_njit(cache=True, nogil=True, inline="always")
def _sin_cos1m(x):
    """Sin x and 1 − cos x, branch-free enough for the compiler to vectorise across poses."""
    q = np.floor(x * _TWO_OVER_PI + 0.5)
    r = ((x - q * _PIO2_1) - q * _PIO2_2) - q * _PIO2_2T  # |r| ≤ π/4
    sp, cm = _sin_cm(r)
    qi = np.int64(q) & 3
    a = (1.0 + cm) if qi & 1 else sp
    c = sp if qi & 1 else (1.0 + cm)
    sn = -a if qi >= 2 else a
    cs = -c if (qi == 1 or qi == 2) else c
    return sn, (-cm if qi == 0 else 1.0 - cs)


@lazy_njit(cache=True, nogil=True, inline="always")
def _trig_row(qrow, cb, ob, w, s, c1):
    """s[:w], c1[:w] = sin θ, 1 − cos θ of θ = cb·qrow[:w] + ob: the polynomials alone when
    every |θ| < SMALL_ANGLE (the same bits), else with the reduction."""
    big = 0.0
    for k in range(w):
        big = max(big, abs(cb * qrow[k] + ob))
    if big < SMALL_ANGLE:
        for k in range(w):
            sp, cm = _sin_cm(cb * qrow[k] + ob)
            s[k] = sp
            c1[k] = -cm
    else:
        for k in range(w):
            s[k], c1[k] = _sin_cos1m(cb * qrow[k] + ob)


@lazy_njit(cache=True, nogil=True)
def _joint_trig(qt, jcol, coef, off, s, c1):
    """s, c1 (N, m): sin θ and 1 − cos θ of each body's joint angle θ = coef·q[:, jcol] + off.

    ``qt`` is the block transposed, (nq, m) C-contiguous, so the pose loop reads contiguously
    and vectorises.
    """
    nb, m = s.shape
    for b in range(nb):
        j = jcol[b]
        if j < 0:
            for k in range(m):
                s[b, k] = 0.0
                c1[b, k] = 0.0
            continue
        cb = coef[b]
        ob = off[b]
        _trig_row(qt[j], cb, ob, m, s[b], c1[b])


@lazy_njit(cache=True, nogil=True)
def _chain_block(s, c1, parent, nz_ptr, nz_k, nz_j, nz_a, root_r, rot):
    """Rotations of every body for a block of poses, structure-of-arrays.

    s, c1: (N, B) sin θ and 1 − cos θ of each body's joint; rot: (N, 3, 3, B) with
    rot[b, j, i, k] = R_b[i, j] at pose k. Only the non-zero entries (z) of M_b = C_b Rot(a, θ)
    are visited: M_b[nz_k[z], nz_j[z]] = a0 + a1 sin θ + a2 (1 − cos θ).
    """
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


@lazy_njit(cache=True, nogil=True)
def _origins_block(rot, parent, t, root_o, org):
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


@lazy_njit(cache=True, nogil=True)
def _com_one(q, ints, reals, r, out):
    """Out (1, k) = the first k of root_o + Σ_b R_b r_b at one pose: the chain and the sum in
    one call. False (out untouched) when q is not finite or q, r do not fit the tree.

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
            if abs(theta) < MAX_ANGLE:
                s, c1 = _sin_cos1m(theta)
            else:
                s, c1 = np.sin(theta), 1.0 - np.cos(theta)
        for i in range(3):
            for j in range(3):
                rot[b, i, j] = 0.0
        for z in range(ints[o_ptr + b], ints[o_ptr + b + 1]):
            kk = ints[o_k + z]
            jj = ints[o_j + z]
            m = reals[o_a + 3 * z] + reals[o_a + 3 * z + 1] * s + reals[o_a + 3 * z + 2] * c1
            for i in range(3):
                rot[b, i, jj] += rot[p, i, kk] * m
    for i in range(out.shape[1]):
        acc = 0.0
        for b in range(nb):
            acc += rot[b, i, 0] * r[b, 0] + rot[b, i, 1] * r[b, 1] + rot[b, i, 2] * r[b, 2]
        out[0, i] = acc + reals[o_rr + 9 + i]
    return True


def com_one(tree: Tree, q: np.ndarray, r: np.ndarray, k: int = 3) -> np.ndarray | None:
    """The first k of the CoM, (1, k), at one pose q (nq,) float64 C-contiguous, for SESC
    vectors r (N, 3) float64 C-contiguous, in one compiled call (a controller's per-pose query).
    None while the kernels are not loaded, or when q is not finite or q, r do not fit the tree
    (the caller's checked path then says what is wrong)."""
    if _LAZY.get(__name__) or q.shape[0] != tree.nq:
        return None
    out = np.empty((1, k))
    ints, reals = tree.packed
    return out if _com_one(q, ints, reals, r, out) else None


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


#: blocks of at most this many poses may run in numpy until the compiled kernels are loaded (one
#: chain block: a CoP/CoM over many poses, or the normal equations of up to this many poses)
SMALL_BLOCK = CHAIN_BLOCK
#: body-poses (poses × bodies) the chain runs in numpy in a process before the compiled kernels
#: are loaded anyway (ski rental). Loading them costs 0.5–1 s (numba's import and type
#: registries); the numpy chain ~0.1 µs per body-pose (~2.5 µs per OP2 pose), so this budget
#: is ~0.2 s of numpy work: a command on a few thousand poses (``demo``: ~70 000 OP2 poses)
#: never loads numba, a large file or a long session does. Counted in work, not seconds, so
#: which path runs does not depend on the machine's load.
NUMPY_BUDGET = 2_000_000
_numpy_spent = [0]  # body-poses run in numpy so far


@lazy_njit(cache=True, nogil=True, fastmath={"contract"})
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


def compiled() -> bool:
    """True once this module's kernels are loaded (the chain no longer runs in numpy)."""
    return not _LAZY.get(__name__)


def _within_budget(m: int, nb: int) -> bool:
    """True while the kernels are not loaded and m more poses of nb bodies keep the numpy
    work within ``NUMPY_BUDGET``."""
    return bool(_LAZY.get(__name__)) and _numpy_spent[0] + m * nb <= NUMPY_BUDGET


def _numpy_path(m: int, nb: int) -> bool:
    """True while the kernels are not loaded, the block (m poses of nb bodies) is at most
    ``SMALL_BLOCK`` poses and the numpy work stays within ``NUMPY_BUDGET`` with it."""
    return m <= SMALL_BLOCK and _within_budget(m, nb)


def _trig_numpy(tree: Tree, q: np.ndarray, s: np.ndarray, c1: np.ndarray) -> None:
    """Sin θ and 1 − cos θ = 2 sin²(θ/2) of every body's joint angle, exact reduction (libm)."""
    moving = tree.jcol >= 0
    theta = np.zeros(s.shape)
    theta[moving] = tree.coef[moving, None] * q.T[tree.jcol[moving]] + tree.off[moving, None]
    s[:] = np.sin(theta)
    c1[:] = 2.0 * np.sin(0.5 * theta) ** 2


def _sin_cos1m_numpy(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``_sin_cos1m`` in numpy, the same operations in the same order: the same bits."""
    q = np.floor(x * _TWO_OVER_PI + 0.5)
    r = ((x - q * _PIO2_1) - q * _PIO2_2) - q * _PIO2_2T
    z = r * r
    poly = 1 / 6227020800
    for c in (-1 / 39916800, 1 / 362880, -1 / 5040, 1 / 120, -1 / 6):
        poly = c + z * poly
    z7 = z**7
    sp = r + r * z * poly
    sp += r * z7 * (-1 / 1307674368000)
    poly = -1 / 3628800 + z / 479001600
    for c in (1 / 40320, -1 / 720, 1 / 24, -0.5):
        poly = c + z * poly
    cm = z * poly
    cm += z7 * (-1 / 87178291200 + z / 20922789888000)  # cos r − 1
    qi = q.astype(np.int64) & 3
    odd = (qi & 1).astype(bool)
    a = np.where(odd, 1.0 + cm, sp)
    c = np.where(odd, sp, 1.0 + cm)
    sn = np.where(qi >= 2, -a, a)
    cs = np.where((qi == 1) | (qi == 2), -c, c)
    return sn, np.where(qi == 0, -cm, 1.0 - cs)


def _trig_poly_numpy(tree: Tree, q: np.ndarray, s: np.ndarray, c1: np.ndarray) -> None:
    """``_joint_trig`` in numpy (|q| < ``MAX_ANGLE``): the kernel's sin θ and 1 − cos θ, bit
    for bit."""
    moving = tree.jcol >= 0
    theta = tree.coef[moving, None] * q.T[tree.jcol[moving]] + tree.off[moving, None]
    s[~moving] = 0.0
    c1[~moving] = 0.0
    s[moving], c1[moving] = _sin_cos1m_numpy(theta)


def _chain_numpy(tree: Tree, s: np.ndarray, c1: np.ndarray, rot: np.ndarray) -> None:
    """``_chain_block`` in numpy, the same products and sums in the same order (the same bits):
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


def chain(tree: Tree, q: np.ndarray, ws: Workspace | None = None) -> np.ndarray:
    """Rotations of a block of m ≤ ws.block poses, layout (N, 3, 3, m): [b, j, i, k] = R_b[i, j].

    ``q`` must already be validated (see ``as_poses``). The result is a view into the
    workspace, overwritten by the next call. Small blocks run in numpy until the compiled
    kernels are worth loading (``_numpy_path``); both give the same bits.
    """
    ws = ws or Workspace(tree, max(len(q), 1))
    m = q.shape[0]
    if m == ws.block:
        s, c1, rot = ws.s, ws.c1, ws.rot
    else:
        s, c1 = np.empty((len(tree.parent), m)), np.empty((len(tree.parent), m))
        rot = np.empty(ws.rot.shape[:3] + (m,))
    if _numpy_path(m, len(tree.parent)):
        _numpy_spent[0] += m * len(tree.parent)
        if np.abs(q).max(initial=0.0) < MAX_ANGLE:
            _trig_poly_numpy(tree, q, s, c1)
        else:
            _trig_numpy(tree, q, s, c1)
        _chain_numpy(tree, s, c1, rot)
        return rot
    if np.abs(q).max(initial=0.0) < MAX_ANGLE:
        _joint_trig(np.ascontiguousarray(q.T), tree.jcol, tree.coef, tree.off, s, c1)
    else:  # huge angles: exact reduction by numpy
        _trig_numpy(tree, q, s, c1)
    _chain_block(s, c1, tree.parent, tree.nz_ptr, tree.nz_k, tree.nz_j, tree.nz_a, tree.root_r, rot)
    return rot


def _origins(rot: np.ndarray, tree: Tree, org: np.ndarray) -> None:
    """Org (N, 3, m) from rot (N, 3, 3, m): the kernel, or numpy for a block it did in numpy."""
    if not _LAZY.get(__name__):
        _origins_block(rot, tree.parent, tree.t, tree.root_o, org)
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


def forward(tree: Tree, q: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Rotations (n, N, 3, 3) and origins (n, N, 3) [m] of every body in the support frame."""
    q = as_poses(q, tree.nq)
    n, nb = q.shape[0], tree.parent.shape[0]
    rot_out = np.empty((n, nb, 3, 3))
    org_out = np.empty((n, nb, 3))
    ws = Workspace(tree, min(CHAIN_BLOCK, max(n, 1)))
    org = np.empty((nb, 3, ws.block))
    for s0 in range(0, n, ws.block):
        blk = q[s0 : s0 + ws.block]
        rot = chain(tree, blk, ws)
        o = org[..., : len(blk)] if len(blk) == ws.block else np.empty((nb, 3, len(blk)))
        _origins(rot, tree, o)
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
    for s0 in range(0, n, ws.block):
        rot = chain(tree, q[s0 : s0 + ws.block], ws)
        # rot[b, j, i, k] → out[k, i, 3b + j]
        out[s0 : s0 + rot.shape[3]] = rot[:, :, rows, :].reshape(3 * nb, len(rows), -1).T
    return out


def regressor_columns(tree: Tree, q: np.ndarray, rows=(0, 1), ws: Workspace | None = None):
    """Φᵀ of a block as a (3N, len(rows)·m) matrix, columns ordered (row, pose): the layout the
    normal equations want (ΦᵀΦ = X Xᵀ in one BLAS call). A view into the workspace."""
    rot = chain(tree, q, ws)
    nb, m = rot.shape[0], rot.shape[3]
    rows = list(rows)
    if rows == list(range(rows[0], rows[-1] + 1)):  # contiguous rows: no copy
        return rot.reshape(3 * nb, 3 * m)[:, rows[0] * m : (rows[-1] + 1) * m]
    return rot[:, :, rows, :].reshape(3 * nb, len(rows) * m)


# --- the regressor in reduced coordinates ------------------------------------------------
# A body's component along its own joint axis a_b turns with its parent only
# (R_b a_b = R_p C_b a_b), and the support body never moves. So Φ·r = Φ_red·(G r) for every r,
# with Φ_red having len(rows) constant intercept columns plus 2 columns per moving body,
# R_b[rows] u_1 and R_b[rows] u_2 for u_1, u_2 ⊥ a_b. Accumulating Φ_redᵀΦ_red (42² for the OP2
# instead of 63²) and expanding Gᵀ(·)G gives the same normal equations for less work.


@dataclass(frozen=True)
class Reduction:
    """Reduced coordinates β = G·vec(r) with Φ·vec(r) = Φ_red·β for the given rows."""

    rows: tuple[int, ...]
    u: np.ndarray  #: (N, 2, 3) unit vectors ⊥ each body's joint axis (body frame)
    g: np.ndarray  #: (len(rows) + 2(N − 1), 3N)


def reduction(tree: Tree, axes: np.ndarray, rows=(0, 1)) -> Reduction:
    """Build the reduced coordinates of a tree; ``axes`` (N, 3) are the bodies' joint axes."""
    nb = tree.parent.shape[0]
    rows = tuple(rows)
    u = np.zeros((nb, 2, 3))
    for b in range(1, nb):
        a = axes[b] / np.linalg.norm(axes[b])
        helper = np.eye(3)[np.argmin(np.abs(a))]
        u[b, 0] = np.cross(a, helper) / np.linalg.norm(np.cross(a, helper))
        u[b, 1] = np.cross(a, u[b, 0])
    nr = len(rows)
    g = np.zeros((nr + 2 * (nb - 1), 3 * nb))
    for col in range(3 * nb):
        r = np.zeros((nb, 3))
        r.flat[col] = 1.0
        for b in range(nb - 1, 0, -1):  # children before parents: push axis parts upward
            a = axes[b] / np.linalg.norm(axes[b])
            alpha = a @ r[b]
            r[tree.parent[b]] += alpha * (tree.a0[b] @ a)
            r[b] -= alpha * a
        g[:nr, col] = tree.root_r[list(rows)] @ r[0]
        g[nr:, col] = np.einsum("blj,bj->bl", u[1:], r[1:]).reshape(-1)
    return Reduction(rows, u, g)


@lazy_njit(cache=True, nogil=True)
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


def reduced_columns(tree: Tree, red: Reduction, q: np.ndarray, ws: Workspace | None = None):
    """Φ_redᵀ of a block of validated poses: (P_red, len(rows)·m), columns ordered (row, pose)."""
    rot = chain(tree, q, ws)
    shape = (red.g.shape[0], len(red.rows) * rot.shape[3])
    out = ws.buffer("reduced", shape) if ws is not None else np.empty(shape)
    if _LAZY.get(__name__):  # the chain ran in numpy: so does this
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


# --- the fused normal-equation kernel ----------------------------------------------------
# Per block of GRAM_BLOCK poses: joint trig, the chain of rotations for the CoP's rows only
# (row i of R_b is row i of R_p times M_b), the reduced regressor columns, and the symmetric
# product, all in L2, in one compiled call: Φ is never written to memory.

#: poses per block of the fused accumulation (rotations, columns and product stay in L2)
GRAM_BLOCK = 128


@lazy_njit(cache=True, nogil=True, fastmath={"reassoc", "contract"})
def _gram_upper(x, m, y, ata, atb):  # pragma: no cover - compiled
    """ata[i, j] += Σ_{k<m} x[i, k] x[j, k] on and above the diagonal's 4 × 4 blocks (x has a
    multiple of 4 rows), atb += X y, returns yᵀy: 2 × 4 register blocks, two FMAs per load."""
    p = x.shape[0]
    yty = 0.0
    for k in range(m):
        yty += y[k] * y[k]
    for i in range(p):
        acc = 0.0
        for k in range(m):
            acc += x[i, k] * y[k]
        atb[i] += acc
    for i0 in range(0, p, 2):
        for j0 in range(i0 - i0 % 4, p, 4):
            a00 = a01 = a02 = a03 = a10 = a11 = a12 = a13 = 0.0
            for k in range(m):
                x0 = x[i0, k]
                x1 = x[i0 + 1, k]
                z0 = x[j0, k]
                z1 = x[j0 + 1, k]
                z2 = x[j0 + 2, k]
                z3 = x[j0 + 3, k]
                a00 += x0 * z0
                a01 += x0 * z1
                a02 += x0 * z2
                a03 += x0 * z3
                a10 += x1 * z0
                a11 += x1 * z1
                a12 += x1 * z2
                a13 += x1 * z3
            ata[i0, j0] += a00
            ata[i0, j0 + 1] += a01
            ata[i0, j0 + 2] += a02
            ata[i0, j0 + 3] += a03
            ata[i0 + 1, j0] += a10
            ata[i0 + 1, j0 + 1] += a11
            ata[i0 + 1, j0 + 2] += a12
            ata[i0 + 1, j0 + 3] += a13
    return yty


@lazy_njit(cache=True, nogil=True, fastmath={"contract"})
def _gram_reduced(
    q, y, sw, jcol, coef, off, parent, nz_ptr, nz_k, nz_j, nz_a, root_r, rows, u, blk, ata, atb
):  # pragma: no cover - compiled
    """Normal equations of the reduced regressor for poses q (n, nq), |q| < MAX_ANGLE, and
    targets y (n, nr) = CoM[rows] − d[rows]; sw (n, nr) square-root row weights, or (0, nr)
    for none. Adds Φ_redᵀWΦ_red to ata (P4, P4; upper 4 × 4 blocks, P4 = P_red rounded up to
    a multiple of 4) and Φ_redᵀWy to atb (P4,); returns yᵀWy, or −1 (nothing added) when an
    angle is beyond MAX_ANGLE. Blocks of ``blk`` poses."""
    n, nq = q.shape
    for k in range(n):
        for j in range(nq):
            if not abs(q[k, j]) < MAX_ANGLE:
                return -1.0
    nb = parent.shape[0]
    nr = rows.shape[0]
    p4 = ata.shape[0]
    weighted = sw.shape[0] > 0
    rot = np.empty((nb, 3, nr, blk))
    x = np.zeros((p4, nr * blk))
    yv = np.empty(nr * blk)
    wt = np.ones((nr, blk))
    s = np.zeros(blk)
    c1 = np.zeros(blk)
    mk = np.empty(blk)
    qt = np.empty((nq, blk))
    yty = 0.0
    for s0 in range(0, n, blk):
        w = min(blk, n - s0)
        for k in range(w):
            for j in range(nq):
                qt[j, k] = q[s0 + k, j]
        for i in range(nr):
            for k in range(w):
                if weighted:
                    wt[i, k] = sw[s0 + k, i]
                yv[i * w + k] = y[s0 + k, i] * wt[i, k]
                for c in range(nr):
                    x[c, i * w + k] = wt[i, k] if c == i else 0.0
        for b in range(nb):
            p = parent[b]
            if p < 0:
                for j in range(3):
                    for i in range(nr):
                        v = root_r[rows[i], j]
                        for k in range(w):
                            rot[b, j, i, k] = v
                continue
            jc = jcol[b]
            if jc >= 0:
                cb = coef[b]
                ob = off[b]
                _trig_row(qt[jc], cb, ob, w, s, c1)
            else:
                for k in range(w):
                    s[k] = 0.0
                    c1[k] = 0.0
            for j in range(3):
                for i in range(nr):
                    for k in range(w):
                        rot[b, j, i, k] = 0.0
            for z in range(nz_ptr[b], nz_ptr[b + 1]):
                kk = nz_k[z]
                jj = nz_j[z]
                a0 = nz_a[z, 0]
                a1 = nz_a[z, 1]
                a2 = nz_a[z, 2]
                if nr == 2:  # the CoP's rows: one pass, the entry of M_b in a register
                    o0 = rot[b, jj, 0]
                    o1 = rot[b, jj, 1]
                    i0 = rot[p, kk, 0]
                    i1 = rot[p, kk, 1]
                    for k in range(w):
                        mz = a0 + a1 * s[k] + a2 * c1[k]
                        o0[k] += i0[k] * mz
                        o1[k] += i1[k] * mz
                    continue
                for k in range(w):
                    mk[k] = a0 + a1 * s[k] + a2 * c1[k]
                for i in range(nr):
                    for k in range(w):
                        rot[b, jj, i, k] += rot[p, kk, i, k] * mk[k]
            ca = x[nr + 2 * (b - 1)]
            cb_ = x[nr + 2 * (b - 1) + 1]
            u00, u01, u02 = u[b, 0, 0], u[b, 0, 1], u[b, 0, 2]
            u10, u11, u12 = u[b, 1, 0], u[b, 1, 1], u[b, 1, 2]
            for i in range(nr):
                r0 = rot[b, 0, i]
                r1 = rot[b, 1, i]
                r2 = rot[b, 2, i]
                wi = wt[i]
                o = i * w
                for k in range(w):
                    ca[o + k] = (r0[k] * u00 + r1[k] * u01 + r2[k] * u02) * wi[k]
                    cb_[o + k] = (r0[k] * u10 + r1[k] * u11 + r2[k] * u12) * wi[k]
        yty += _gram_upper(x, nr * w, yv, ata, atb)
    return yty


def padded(p: int) -> int:
    """Rows of the fused kernel's accumulators: ``p`` rounded up to a multiple of 4."""
    return -(-p // 4) * 4


def gram_reduced(
    tree: Tree,
    red: Reduction,
    q: np.ndarray,
    y: np.ndarray,
    sw: np.ndarray | None,
    ata: np.ndarray,
    atb: np.ndarray,
) -> float | None:
    """Add the reduced normal equations of validated poses q (n, nq) to ata (P4, P4, upper
    4 × 4 blocks only) and atb (P4,) in one compiled pass; y (n, len(rows)) [m] targets, sw
    (n, len(rows)) square-root weights or None. Returns yᵀWy, or None (nothing added) where
    ``chain`` would run in numpy (``_numpy_path``) or an angle needs numpy's exact reduction."""
    if _numpy_path(q.shape[0], tree.parent.shape[0]):
        return None
    nr = len(red.rows)
    w = np.empty((0, nr)) if sw is None else np.ascontiguousarray(sw, dtype=float)
    yty = float(
        _gram_reduced(
            q, np.ascontiguousarray(y, dtype=float), w, tree.jcol, tree.coef, tree.off,
            tree.parent, tree.nz_ptr, tree.nz_k, tree.nz_j, tree.nz_a, tree.root_r,
            np.asarray(red.rows, dtype=np.int64), red.u, GRAM_BLOCK, ata, atb,
        )
    )  # fmt: skip
    return None if yty < 0 else yty


def gram_upper(x: np.ndarray, y: np.ndarray, ata: np.ndarray, atb: np.ndarray) -> float:
    """Add X Xᵀ (upper 4 × 4 blocks) to ata (P4, P4) and X y to atb (P4,) for columns x (P, m),
    P ≤ P4, y (m,), on one core; returns yᵀy. Rows are zero-padded to P4 in a copy."""
    p4 = ata.shape[0]
    xp = np.zeros((p4, x.shape[1]))
    xp[: x.shape[0]] = x
    return float(_gram_upper(xp, x.shape[1], np.ascontiguousarray(y, dtype=float), ata, atb))
