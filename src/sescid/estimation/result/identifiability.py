"""What CoP data can and cannot determine: the rank rule, named base combinations and the
unidentifiable directions with their reason.

Rank rule (one home): an eigen-direction of the normal matrix ΦᵀWΦ is identifiable when its
singular value √λ exceeds ``rtol · √λ_max`` (``DEFAULT_RTOL = 1e-6``: far above the ~1e-8
round-off floor of the normal equations, far below the smallest identifiable value of any real
pose set).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from sescid.errors import DataError
from sescid.estimation.result.fit import AXES, Combination, Unseen
from sescid.estimation.sums.normal_equations import poses_needed
from sescid.kinds import COP, Kinds
from sescid.robot import Robot

DEFAULT_RTOL = 1e-6

#: kinds of unidentifiable direction (``Combination.kind``)
SUPPORT_VERTICAL: Unseen = "support-vertical"
SUPPORT_HORIZONTAL: Unseen = "support-horizontal"
JOINT_AXIS: Unseen = "joint-axis"
NOT_EXCITED: Unseen = "not-excited"


def check_rtol(rtol: float) -> float:
    """The rank tolerance must lie in (0, 1)."""
    if not (isinstance(rtol, int | float) and math.isfinite(rtol) and 0 < rtol < 1):
        raise DataError(f"rank tolerance rtol must be in (0, 1), got {rtol}")
    return float(rtol)


def eigen_rank(ata: np.ndarray, rtol: float = DEFAULT_RTOL) -> tuple[np.ndarray, np.ndarray, int]:
    """Eigenvalues (descending), eigenvectors (columns) and rank of a symmetric matrix ΦᵀΦ: the
    number of singular values √λ above rtol × the largest."""
    lam, vecs = np.linalg.eigh(ata)
    sv = np.sqrt(np.clip(lam[::-1], 0, None))
    rank = int(np.sum(sv > rtol * sv[0])) if sv.size and sv[0] > 0 else 0
    return lam[::-1], vecs[:, ::-1], rank


def basis_of(a: np.ndarray, rtol: float) -> np.ndarray:
    """Orthonormal basis (m, k) of the column space of a (m, c): the singular directions above
    rtol × the largest (an empty one for no columns)."""
    if a.size == 0:
        return np.zeros((a.shape[0], 0))
    u, s, _ = np.linalg.svd(a, full_matrices=False)
    return u[:, s > rtol * max(float(s[0]), 1e-300)] if s.size else u[:, :0]


def identifiable_eigen(
    ata: np.ndarray, rtol: float = DEFAULT_RTOL
) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues λ_p (descending) and orthonormal eigenvectors V_p (P, p) of a normal matrix
    ΦᵀΦ that span the identifiable subspace (the rank rule above)."""
    lam, vecs, p = eigen_rank(ata, rtol)
    return lam[:p].copy(), np.ascontiguousarray(vecs[:, :p])


def structural_rank(robot: Robot) -> int:
    """Rank of the x/y regressor for generic poses: the dimension of the reduced coordinates
    (3N minus the structural null directions; mimic joints included)."""
    return int(robot.reduction.g.shape[0])


def structural_count(robot: Robot, kinds: Iterable[str]) -> int:
    """Combinations of vec(r) that data of ``kinds`` determine on generic poses: the CoP's
    reduced coordinates (``structural_rank``), less the support body's two horizontal ones for
    data without a CoP."""
    kinds = set(kinds)
    p = structural_rank(robot)
    return p - len(robot.reduction.rows) if kinds and COP not in kinds else p


def min_poses(robot: Robot) -> int:
    """Fewest CoP poses (2 equations each) that determine every identifiable combination
    with a degree of freedom left (``poses_needed``)."""
    return poses_needed(structural_rank(robot))


def label_columns(robot: Robot) -> list[tuple[str, str]]:
    """(body, axis) of each component of vec(r)."""
    return [(b, a) for b in robot.body_names for a in AXES]


def combination_vector(robot: Robot, terms) -> np.ndarray:
    """vec(r)-shaped (3N,) coefficient vector of a combination's terms (body, axis, coef)."""
    g = np.zeros(3 * len(robot.body_names))
    index = {b: i for i, b in enumerate(robot.body_names)}
    for body, axis, c in terms:
        g[3 * index[body] + AXES.index(axis)] = c
    return g


def structural_null_directions(
    robot: Robot, kinds: Kinds = (COP,)
) -> list[tuple[np.ndarray, Unseen, str]]:
    """Directions of vec(r) that no data of these kinds can see, for any poses: (vector, kind,
    reason).

    - the support body never moves: its vertical component never shifts the CoP, and a torque
      sees none of its components (its weight goes to the floor, or the fixture, without
      crossing a joint): with torques alone its horizontal components are lost too;
    - a body's component along its own joint axis turns with the parent only, so just its sum
      with the parent's matching component is seen (by the CoP and by torques alike).
    """
    n = len(robot.body_names)
    support = robot.body_names[0]
    out = []
    frame = robot.tree.root_r.T  # support-frame axes in the support body's frame (columns)
    cop = "cop" in kinds
    if "balance" in kinds and robot.line is not None:
        v = np.zeros((n, 3))
        v[0] = frame @ robot.line
        reason = (
            f"component of the support body {support} along the support line: it stays on the "
            "line whatever the tilt, so it never moves the CoM across it"
        )
        out.append((v.reshape(-1), SUPPORT_HORIZONTAL, reason))
        if not cop and "tau" not in kinds:
            axes: tuple[int, ...] = ()
        else:
            axes = (2, 0, 1) if not cop else (2,)
    else:
        axes = (2, 0, 1) if not cop else (2,)
    for axis in axes:
        v = np.zeros((n, 3))
        v[0] = frame @ np.eye(3)[axis]
        if axis == 2 and cop:
            kind = SUPPORT_VERTICAL
            reason = (
                f"vertical component of the support body {support}: it never moves, so it "
                "never shifts the CoP (it sets the CoM height offset only)"
            )
        else:
            kind = SUPPORT_VERTICAL if axis == 2 else SUPPORT_HORIZONTAL
            reason = (
                f"{'xyz'[axis]} component of the support body {support}: its own weight goes "
                "to the floor (or the fixture) without crossing a joint, so no joint torque "
                "sees it"
                + (
                    ""
                    if axis == 2
                    else " (a constant horizontal CoM shift, with the joint-axis parts of the "
                    "bodies it carries); a CoP measurement (a floor sensor) sees it"
                )
            )
        out.append((v.reshape(-1), kind, reason))
    for i, b in enumerate(robot.model.bodies):
        if b.parent < 0:
            continue
        v = np.zeros((n, 3))
        v[i] = b.axis
        v[b.parent] -= b.rot_const @ b.axis
        v /= np.linalg.norm(v)
        out.append(
            (
                v.reshape(-1),
                JOINT_AXIS,
                f"component of {b.name} along its joint axis ({b.joint_name}): it turns with "
                f"{robot.body_names[b.parent]} only, so only their combination is seen",
            )
        )
    return out


def sparse_terms(vec: np.ndarray, labels, tol: float = 1e-9) -> list[tuple[str, str, float]]:
    """The (body, axis, coefficient) terms of a vec(r)-shaped vector above ``tol`` × its
    largest, largest first."""
    big = np.flatnonzero(np.abs(vec) > tol * np.abs(vec).max())
    big = big[np.argsort(-np.abs(vec[big]), kind="stable")]
    return [(labels[i][0], labels[i][1], float(vec[i])) for i in big]


@functools.cache
def _flapack():
    """The LAPACK wrapper module of scipy without ``scipy.linalg``'s package import (~0.3 s, more
    than a fit of a few dozen poses): the same ``dgeqp3``/``dtrtrs``, so the same pivots and
    hence the same named combinations. None if this scipy does not lay it out that way."""
    import importlib.util

    import scipy  # the bare package: ~15 ms

    for path in sorted(Path(scipy.__path__[0], "linalg").glob("_flapack.*")):
        spec = importlib.util.spec_from_file_location("_flapack", path)
        if spec is None or spec.loader is None:
            continue
        try:
            mod = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(mod)
        except ImportError:
            continue
        if hasattr(mod, "dgeqp3") and hasattr(mod, "dtrtrs"):
            return mod
    return None


def qr_pivoted(a: np.ndarray) -> tuple[np.ndarray, np.ndarray, Callable]:
    """R (min(m, n) × n), the column order of LAPACK's QR with column pivoting (``dgeqp3``,
    as ``scipy.linalg.qr(a, pivoting=True)``) and an upper-triangular solver."""
    lp = _flapack()
    if lp is None:  # pragma: no cover - other scipy layouts
        import scipy.linalg

        _, rr, piv = scipy.linalg.qr(a, pivoting=True, mode="economic")
        return rr, piv, scipy.linalg.solve_triangular
    qr, jpvt, _, _, info = lp.dgeqp3(np.asarray(a, dtype=float))
    if info != 0:
        raise np.linalg.LinAlgError(f"dgeqp3 info {info}")

    def solve(r11: np.ndarray, b: np.ndarray) -> np.ndarray:
        x, inf = lp.dtrtrs(r11, b)
        if inf != 0:
            raise np.linalg.LinAlgError(f"dtrtrs info {inf}")
        return x

    m = min(qr.shape)
    return np.triu(qr[:m]), jpvt - 1, solve


def base_combinations(sv, vecs, p, labels, r, cov) -> list[Combination]:
    """Base parameters by QR with column pivoting of S = diag(s) Vᵀ (same structure as Φ)."""
    if p == 0:  # the data determine no combination (LAPACK refuses an empty matrix)
        return []
    s_mat = sv[:p, None] * vecs[:, :p].T  # (p, P): SᵀS = ΦᵀΦ on the identifiable part
    rr, piv, solve_upper = qr_pivoted(s_mat)
    r11, r12 = rr[:p, :p], rr[:p, p:]
    k = solve_upper(r11, r12) if r12.size else np.zeros((p, 0))
    out = []
    vec_r = r.reshape(-1)
    for i in range(p):
        g = np.zeros(vec_r.size)
        g[piv[i]] = 1.0
        g[piv[p:]] = k[i]
        g[np.abs(g) < 1e-10] = 0.0
        value = float(g @ vec_r)
        std = float(np.sqrt(max(g @ cov @ g, 0.0)))
        terms = [(labels[piv[i]][0], labels[piv[i]][1], 1.0)]
        terms += [t for t in sparse_terms(g, labels) if (t[0], t[1]) != labels[piv[i]]]
        out.append(Combination(terms, value, std))
    return out


def unidentifiable(
    robot: Robot, basis: np.ndarray, labels, kinds: Kinds = (COP,)
) -> list[Combination]:
    """Name the null space: structural directions first, then what these poses left out."""
    n_par = basis.shape[0]
    proj = np.eye(n_par) - basis @ basis.T  # projector on the null space
    out = []
    found = np.zeros((n_par, 0))
    for v, kind, reason in structural_null_directions(robot, kinds):
        if np.linalg.norm(proj @ v) > 1 - 1e-6:  # v lies in the null space
            out.append(Combination(sparse_terms(v, labels), reason=reason, kind=kind))
            found = np.column_stack([found, v])
    # Remaining null directions: not seen because these poses do not excite them.
    if found.shape[1]:
        q_found, _ = np.linalg.qr(found)
        rest = proj - q_found @ q_found.T
    else:
        rest = proj
    w, u = np.linalg.eigh(rest)
    for k in np.flatnonzero(w > 0.5):
        out.append(
            Combination(
                sparse_terms(u[:, k], labels, tol=1e-3),
                reason="not excited by these poses (a joint that barely moves, or too few poses)",
                kind=NOT_EXCITED,
            )
        )
    return out
