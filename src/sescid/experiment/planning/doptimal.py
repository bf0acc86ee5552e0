"""D-optimal pose selection and the expected CoP error of a pose set.

``log det M``, ``M = Σ AᵢᵀAᵢ``, ``Aᵢ = Φ_xy(qᵢ) V`` the x/y regressor projected on an orthonormal
basis ``V`` of the identifiable subspace (from the candidate pool). Greedy, then Fedorov
exchange; each candidate's ``Aᵢ M⁻¹ Aᵢᵀ`` is kept up to date by rank-2 Woodbury updates (O(n p)
per step instead of O(n p²)); exchange passes search a shortlist of the most informative
candidates, refreshed every pass. Least squares on K poses with CoP noise σ predicts the
noise-free CoP of fresh poses with RMS error ``σ · sqrt(trace(Φ_test M⁻¹ Φ_testᵀ) / rows)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import SescidError
from ...estimation import DEFAULT_RTOL, identifiable_eigen
from ...robot import Robot


def identifiable_basis(
    robot: Robot, q: np.ndarray, rtol: float = DEFAULT_RTOL, chunk: int = 50_000
) -> np.ndarray:
    """(3N, p) orthonormal basis of the span of the x/y regressor rows over poses ``q``."""
    ata = np.zeros((3 * len(robot.body_names),) * 2)
    for s in range(0, len(q), chunk):
        x = robot.regressor(q[s : s + chunk]).reshape(-1, ata.shape[0])
        ata += x.T @ x
    return identifiable_eigen(ata, rtol)[1]


def projected_regressor(robot: Robot, q, basis: np.ndarray, chunk: int = 50_000) -> np.ndarray:
    """(n, 2, p) x/y regressor in the coordinates of ``basis``: A = Φ_xy V."""
    out = np.empty((len(q), 2, basis.shape[1]))
    for s in range(0, len(q), chunk):
        out[s : s + chunk] = robot.regressor(q[s : s + chunk]) @ basis
    return out


def _logdet2(s: np.ndarray) -> np.ndarray:
    """Log det(I + S) for S (n, 2, 2) symmetric (nan where not positive)."""
    det = (1.0 + s[:, 0, 0]) * (1.0 + s[:, 1, 1]) - s[:, 0, 1] * s[:, 1, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log(np.where(det > 0, det, np.nan))


def _inv2(g: np.ndarray) -> np.ndarray:
    det = g[0, 0] * g[1, 1] - g[0, 1] * g[1, 0]
    return np.array([[g[1, 1], -g[0, 1]], [-g[1, 0], g[0, 0]]]) / det


def _quad(w: np.ndarray, g: np.ndarray) -> np.ndarray:
    """W_j G W_jᵀ (n, 2, 2) for W (n, 2, 2) and a symmetric G (2, 2)."""
    w0, w1 = w[:, :, 0], w[:, :, 1]  # (n, 2): columns of each W_j
    t0 = w0 * g[0, 0] + w1 * g[1, 0]
    t1 = w0 * g[0, 1] + w1 * g[1, 1]
    out = np.empty_like(w)
    for i in range(2):
        for j in range(i, 2):
            out[:, i, j] = t0[:, i] * w0[:, j] + t1[:, i] * w1[:, j]
            out[:, j, i] = out[:, i, j]
    return out


def _sandwich(a: np.ndarray, minv: np.ndarray) -> np.ndarray:
    """S_i = A_i M⁻¹ A_iᵀ (n, 2, 2) for A (n, 2, p)."""
    n, _, p = a.shape
    y = (a.reshape(2 * n, p) @ minv).reshape(n, 2, p)
    out = np.empty((n, 2, 2))
    out[:, 0, 0] = np.einsum("np,np->n", y[:, 0], a[:, 0])
    out[:, 1, 1] = np.einsum("np,np->n", y[:, 1], a[:, 1])
    out[:, 0, 1] = out[:, 1, 0] = np.einsum("np,np->n", y[:, 0], a[:, 1])
    return out


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


class _Design:
    """Rank-2 bookkeeping for D-optimal search over candidates A (n, 2, p).

    Keeps M⁻¹ and, for every candidate, S_i = A_i M⁻¹ A_iᵀ (2 × 2) current under additions and
    removals (Woodbury), so a step costs O(n p) instead of O(n p²).
    """

    def __init__(self, a: np.ndarray, minv: np.ndarray):
        self.a = a
        self.x = a.reshape(-1, a.shape[-1])
        self.minv = minv
        self.s = _sandwich(a, minv)
        self.chosen = np.zeros(len(a), dtype=bool)

    def _w(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        u = self.minv @ self.a[i].T  # (p, 2)
        return u, (self.x @ u).reshape(len(self.a), 2, 2)

    def add(self, i: int) -> None:
        u, w = self._w(i)
        g_inv = _inv2(np.eye(2) + self.s[i])
        self.s = self.s - _quad(w, g_inv)
        self.minv = self.minv - u @ g_inv @ u.T
        self.chosen[i] = True

    def best_add(self) -> int:
        gain = _logdet2(self.s)
        gain[self.chosen] = -np.inf
        return int(np.nanargmax(gain))

    def try_exchange(self, i_out: int, tol: float = 1e-10) -> int | None:
        """Swap chosen ``i_out`` for the candidate that raises log det most; its index or None."""
        h = np.eye(2) - self.s[i_out]
        det_h = h[0, 0] * h[1, 1] - h[0, 1] * h[1, 0]
        if not det_h > 0:
            return None
        h_inv = _inv2(h)
        u, w = self._w(i_out)
        s_minus = self.s + _quad(w, h_inv)  # S_j once i_out is removed
        gain = _logdet2(s_minus) + math.log(det_h)
        gain[self.chosen] = -np.inf
        j = int(np.nanargmax(gain))
        if not gain[j] > tol:
            return None
        self.minv = self.minv + u @ h_inv @ u.T
        self.s = s_minus
        self.chosen[i_out] = False
        self.add(j)
        return j


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
    x = a.reshape(2 * n, p)
    delta = 1e-8 * float(np.einsum("ij,ij->", x, x)) / (n * p)
    st = _Design(a, np.eye(p) / delta)
    order = []
    for _ in range(k):
        i = st.best_add()
        st.add(i)
        order.append(i)
    minv = st.minv
    exchanges = passes = 0
    for passes in range(1, max_passes + 1):  # noqa: B007
        m = information(a[order])
        if np.linalg.matrix_rank(m) == p:  # drop the ridge once the design is non-singular
            minv = np.linalg.inv(m)
        score = _logdet2(_sandwich(a, minv))
        score[order] = -np.inf
        score = np.nan_to_num(score, nan=-np.inf)
        n_short = min(shortlist, n - k)
        top = np.argpartition(-score, n_short - 1)[:n_short] if n_short > 0 else np.zeros(0, int)
        idx = np.concatenate([np.asarray(order), top])
        sub = _Design(a[idx], minv)
        sub.chosen[:k] = True
        pos_sub = list(range(k))
        improved = False
        for pos in rng.permutation(k):
            j = sub.try_exchange(pos_sub[pos])
            if j is not None:
                pos_sub[pos] = j
                exchanges += 1
                improved = True
        order = [int(idx[i]) for i in pos_sub]
        minv = sub.minv
        if not improved:
            break
    sign, logdet = np.linalg.slogdet(information(a[order]))
    return Selection(
        index=np.array(order),
        logdet=float(logdet) if sign > 0 else -math.inf,
        exchanges=exchanges,
        passes=passes,
    )


def expected_cop_error(a_sel: np.ndarray, c_test: np.ndarray, sigma: float) -> float:
    """Expected RMS error [m] of least-squares CoP predictions on fresh poses.

    ``a_sel`` (K, 2, p) projected regressor of the chosen poses, ``c_test`` = Σ_t A_tᵀA_t / rows
    over test poses, ``sigma`` CoP noise [m]: σ · sqrt(trace(M⁻¹ c_test)). inf if M is singular.
    """
    m = information(a_sel)
    try:
        chol = np.linalg.cholesky(m)
    except np.linalg.LinAlgError:
        return math.inf
    z = np.linalg.solve(chol, np.linalg.solve(chol, c_test).T)
    val = float(np.trace(z))
    return sigma * math.sqrt(val) if val > 0 else math.inf


def per_row_information(a_test: np.ndarray) -> np.ndarray:
    """c_test = Σ_t A_tᵀA_t / rows for A_test (n, 2, p)."""
    return information(a_test) / (2 * len(a_test))


def random_cop_error(
    a_pool: np.ndarray, k: int, c_test: np.ndarray, sigma: float, draws: int = 50, seed=0
) -> np.ndarray:
    """Expected CoP errors [m] (draws,) of ``k`` poses drawn at random from the pool."""
    rng = np.random.default_rng(seed)
    return np.array(
        [
            expected_cop_error(a_pool[rng.choice(len(a_pool), k, replace=False)], c_test, sigma)
            for _ in range(draws)
        ]
    )
