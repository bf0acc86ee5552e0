"""D-optimal choice of poses that give two CoP rows each: ``engine``'s fast path.

``log det M``, ``M = Σ AᵢᵀAᵢ``, ``Aᵢ = Φ_xy(qᵢ) V`` the x/y regressor projected on an orthonormal
basis ``V`` of the identifiable subspace (from the candidate pool). Greedy, then Fedorov
exchange; each candidate's ``Aᵢ M⁻¹ Aᵢᵀ`` is kept up to date by rank-2 Woodbury updates (O(n p)
per step instead of O(n p²)); exchange passes search a shortlist of the most informative
candidates, refreshed every pass.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.base.threads import one_blas_thread
from sescid.errors import SescidError
from sescid.estimation import DEFAULT_RTOL, accumulate, identifiable_eigen
from sescid.kinematics import CHAIN_BLOCK, Workspace, as_poses, reduced_columns
from sescid.planning.design.doptimal_kernels import (
    TIE_LOGDET,
    first_best,
    project_columns,
    rank2,
    sandwich,
    swap_best,
)
from sescid.robot import Robot


@one_blas_thread()
def identifiable_basis(
    robot: Robot, q: np.ndarray, rtol: float = DEFAULT_RTOL, chunk: int = 50_000
) -> np.ndarray:
    """(3N, p) orthonormal basis of the span of the x/y regressor rows over poses ``q``.

    From ΦᵀΦ accumulated by ``estimation.accumulate`` (reduced coordinates, compiled)."""
    q = as_poses(q, robot.nq)
    ne = accumulate(
        robot,
        ((q[s : s + chunk], np.zeros((len(q[s : s + chunk]), 2))) for s in range(0, len(q), chunk)),
    )
    return identifiable_eigen(ne.ata, rtol)[1]


@one_blas_thread()
def projected_regressor(robot: Robot, q, basis: np.ndarray) -> np.ndarray:
    """(n, 2, p) x/y regressor in the coordinates of ``basis``: A = Φ_xy V.

    Computed as Φ_red (G V) from the reduced columns (``kinematics.reduced_columns``: Φ = Φ_red G
    exactly), block by block, the small product in a compiled kernel."""
    q = as_poses(q, robot.nq)
    red = robot.reduction
    t = np.ascontiguousarray(red.g @ basis)  # (P_red, p)
    out = np.empty((len(q), 2, basis.shape[1]))
    ws = Workspace(robot.tree, min(CHAIN_BLOCK, max(len(q), 1)))
    for s in range(0, len(q), ws.block):
        x = reduced_columns(robot.tree, red, q[s : s + ws.block], ws)  # (P_red, 2m)
        project_columns(x, t, out[s : s + ws.block])
    return out


def logdet2(s: np.ndarray) -> np.ndarray:
    """Log det(I + S) for S (n, 3) = (s00, s01, s11) (nan where not positive)."""
    det = (1.0 + s[:, 0]) * (1.0 + s[:, 2]) - s[:, 1] * s[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log(np.where(det > 0, det, np.nan))


def _inv2(s: np.ndarray, sign: float) -> tuple[np.ndarray, float]:
    """(inverse, determinant) of I + sign · S for one S = (s00, s01, s11)."""
    h00, h01, h11 = 1.0 + sign * s[0], sign * s[1], 1.0 + sign * s[2]
    det = h00 * h11 - h01 * h01
    return np.array([[h11, -h01], [-h01, h00]]) / det, det


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


class GreedyDesign:
    """Rank-2 bookkeeping for D-optimal search over candidates A (n, 2, p).

    Keeps M⁻¹ and, for every candidate, S_i = A_i M⁻¹ A_iᵀ (stored as (s00, s01, s11)) current
    under additions and removals (Woodbury), so a step costs O(n p) instead of O(n p²); each
    step is one compiled pass over the candidates (``doptimal_kernels``).
    """

    def __init__(self, a: np.ndarray, minv: np.ndarray, s: np.ndarray | None = None):
        self.a = np.ascontiguousarray(a)
        self.minv = minv
        self.s = sandwich(self.a, minv) if s is None else s
        self.chosen = np.zeros(len(a), dtype=bool)

    def best(self) -> int:
        """The unchosen candidate of largest log det(I + S_i) (near-ties: the lowest index)."""
        gain = logdet2(self.s)
        gain[self.chosen] = -np.inf
        return first_best(gain)

    def add(self, i: int) -> int:
        """Add candidate i; returns the unchosen candidate of largest gain afterwards (−1: none)."""
        u = self.minv @ self.a[i].T  # (p, 2)
        g_inv = _inv2(self.s[i], 1.0)[0]
        self.chosen[i] = True
        best = rank2(self.a, u, g_inv, -1.0, self.s, self.chosen)
        self.minv = self.minv - u @ g_inv @ u.T
        return best

    def remove(self, i: int) -> None:
        """Remove chosen candidate i (the design without it must be non-singular)."""
        u = self.minv @ self.a[i].T
        h_inv = _inv2(self.s[i], -1.0)[0]
        self.chosen[i] = False
        rank2(self.a, u, h_inv, 1.0, self.s, self.chosen)
        self.minv = self.minv + u @ h_inv @ u.T

    def try_exchange(self, i_out: int, tol: float = TIE_LOGDET) -> int | None:
        """Swap chosen ``i_out`` for the candidate that raises log det most; its index or None.

        The swap's gain is exact (``swap_best``, a 4 × 4 determinant in 2 × 2 blocks) and the
        swap adds before it removes, so no step forms the design without ``i_out`` — singular
        when the design is saturated (K poses, 2K = p rows)."""
        u = self.minv @ self.a[i_out].T
        j, ratio = swap_best(self.a, u, self.s, self.s[i_out], self.chosen)
        if j < 0 or not math.log(ratio) > tol:
            return None
        self.add(j)
        self.remove(i_out)
        return j


def exchange_pass(design, k: int, rng: np.random.Generator) -> tuple[list[int], int]:
    """One Fedorov pass over the k chosen rows (the first k of ``design``) in a random order:
    each tries its best exchange (``design.try_exchange(pos) -> new position or None``).
    Returns the chosen positions after the pass and the count of exchanges made."""
    pos_sub = list(range(k))
    swaps = 0
    for pos in rng.permutation(k):
        j = design.try_exchange(pos_sub[pos])
        if j is not None:
            pos_sub[pos] = j
            swaps += 1
    return pos_sub, swaps


@one_blas_thread()
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
    a = np.ascontiguousarray(a, dtype=float)
    x = a.reshape(2 * n, p)
    delta = 1e-8 * float(np.einsum("ij,ij->", x, x)) / (n * p)
    s0 = np.empty((n, 3))  # S_i = A_i A_iᵀ / δ
    s0[:, 0] = np.einsum("np,np->n", a[:, 0], a[:, 0]) / delta
    s0[:, 1] = np.einsum("np,np->n", a[:, 0], a[:, 1]) / delta
    s0[:, 2] = np.einsum("np,np->n", a[:, 1], a[:, 1]) / delta
    st = GreedyDesign(a, np.eye(p) / delta, s0)
    i = st.best()
    order = []
    for _ in range(k):
        order.append(i)
        i = st.add(i)
        if i < 0 and len(order) < k:
            i = st.best()
    minv = st.minv
    exchanges = passes = 0
    for passes in range(1, max_passes + 1):  # noqa: B007
        m = information(a[order])
        if np.linalg.matrix_rank(m) == p:  # drop the ridge once the design is non-singular
            minv = np.linalg.inv(m)
        n_short = min(shortlist, n - k)
        s_all = sandwich(a, minv)
        score = np.nan_to_num(logdet2(s_all), nan=-np.inf)
        score[order] = -np.inf
        top = np.lexsort((np.arange(n), -score))[:n_short]  # ties: the lower index
        idx = np.concatenate([np.asarray(order), top])
        sub = GreedyDesign(a[idx], minv, s_all[idx])
        sub.chosen[:k] = True
        pos_sub, swaps = exchange_pass(sub, k, rng)
        exchanges += swaps
        order = [int(idx[i]) for i in pos_sub]
        minv = sub.minv
        if swaps == 0:
            break
    sign, logdet = np.linalg.slogdet(information(a[order]))
    return Selection(
        index=np.array(order),
        logdet=float(logdet) if sign > 0 else -math.inf,
        exchanges=exchanges,
        passes=passes,
    )


def inverse_trace(m: np.ndarray, c: np.ndarray) -> float:
    """trace(M⁻¹ C) for M (p, p) symmetric, by Cholesky; inf when M is not positive definite."""
    try:
        chol = np.linalg.cholesky(m)
    except np.linalg.LinAlgError:
        return math.inf
    z = np.linalg.solve(chol, np.linalg.solve(chol, c).T)
    return float(np.trace(z))


@one_blas_thread()
def per_row_information(a_test: np.ndarray) -> np.ndarray:
    """c_test = Σ_t A_tᵀA_t / rows for A_test (n, 2, p)."""
    return information(a_test) / (2 * len(a_test))
