"""D-optimal choice of poses that give r rows each (joint torques, or torques and the CoP), the
torque offsets as nuisance columns (``kinds``).

As ``doptimal`` for the CoP's two rows: greedy from a tiny ridge δI over the candidates most
informative about k average ones (``prescreen``), then Fedorov exchange passes over a shortlist
of the most informative candidates of a working set three times as large. Each candidate's
S_j = A_j M⁻¹ A_jᵀ (r × r) is kept current by rank-r Woodbury updates in one compiled pass
(``block_kernels``); while the chosen rows are fewer than the parameters (the ridge still
matters, where a Woodbury chain would lose digits) every S_j is recomputed from M itself.
A swap adds the new pose before it removes the old (its gain is exact), so a saturated design
never passes through a singular one. The log det reported is that of the Schur complement:
the information about the SESC part with the offsets marginalised.
"""

from __future__ import annotations

import math

import numpy as np

from sescid.base.threads import one_blas_thread
from sescid.errors import SescidError
from sescid.planning.design.block_kernels import (
    KernelRows,
    Sandwiches,
    sandwich_blocks,
    swap_gains,
    update_blocks,
)
from sescid.planning.design.doptimal import Selection, exchange_pass
from sescid.planning.design.doptimal_kernels import TIE_LOGDET, first_best
from sescid.planning.design.kinds import BlockRows, schur_information


def _ridge(rows: BlockRows) -> float:
    """δ: 1e-8 of the mean squared entry of the candidates' rows."""
    x = rows.x
    n, r, p = x.shape
    total = float(np.einsum("nra,nra->", x, x)) + n * float(np.sum(rows.val[rows.col >= 0] ** 2))
    return 1e-8 * total / (n * r * rows.size)


def _pd_inverse(m: np.ndarray) -> np.ndarray:
    """Inverse of a symmetric positive definite matrix through its Cholesky factor."""
    low = np.linalg.cholesky(m)
    inv_low = np.linalg.solve(low, np.eye(len(m)))
    out = inv_low.T @ inv_low
    return (out + out.T) / 2


class BlockDesign:
    """M⁻¹ of the chosen candidates' information (plus ``ridge`` δI) and every candidate's
    S_j = A_j M⁻¹ A_jᵀ and gain log det(I + S_j) (module docstring)."""

    def __init__(self, rows: BlockRows, ridge: float | None = None):
        self.rows = rows
        self.ridge = _ridge(rows) if ridge is None else ridge
        n, r = rows.x.shape[:2]
        self.s = np.empty((n, r, r))
        self.gain = np.empty(n)
        self.chosen = np.zeros(n, dtype=bool)
        self.refresh()

    def _rows(self) -> KernelRows:
        r = self.rows
        return KernelRows(r.x, r.col, r.val)

    def _out(self) -> Sandwiches:
        return Sandwiches(self.s, self.gain)

    def refresh(self) -> None:
        """M⁻¹ and every S_j recomputed from the chosen rows (no Woodbury chain)."""
        m = self.rows.information(np.flatnonzero(self.chosen))
        m[np.diag_indices_from(m)] += self.ridge
        self.minv = _pd_inverse(m)
        sandwich_blocks(self._rows(), self.minv, self._out())

    def gains(self) -> np.ndarray:
        """(n,) log det rise if each candidate were added; −inf for the chosen."""
        g = np.where(np.isfinite(self.gain), self.gain, -np.inf)
        g[self.chosen] = -np.inf
        return g

    def best(self) -> int:
        """The unchosen candidate of largest gain (near-ties: the lowest index); −1: none."""
        return first_best(self.gains())

    def _u(self, i: int) -> np.ndarray:
        return self.minv @ self.rows.dense([i])[0].T  # (p + K, r)

    def add(self, i: int) -> None:
        """Add candidate i."""
        u = self._u(i)
        r = u.shape[1]
        g = _pd_inverse(np.eye(r) + self.s[i])
        self.chosen[i] = True
        if int(self.chosen.sum()) * r <= self.rows.size + r:  # the ridge still dominates
            self.refresh()
            return
        update_blocks(self._rows(), u, g, -1.0, self._out())
        self.minv = self.minv - u @ g @ u.T
        if not np.isfinite(self.gain[~self.chosen]).all():  # the Woodbury chain lost digits
            self.refresh()

    def remove(self, i: int) -> None:
        """Remove chosen candidate i (the design without it must be non-singular)."""
        u = self._u(i)
        r = u.shape[1]
        h = _pd_inverse(np.eye(r) - self.s[i])
        self.chosen[i] = False
        update_blocks(self._rows(), u, h, 1.0, self._out())
        self.minv = self.minv + u @ h @ u.T

    def try_exchange(self, i_out: int, tol: float = TIE_LOGDET) -> int | None:
        """Swap chosen ``i_out`` for the candidate that raises log det most (exact, adding
        before removing); its index, or None when no swap raises it by more than ``tol``."""
        u = self._u(i_out)
        ratio = swap_gains(self._rows(), u, self.s, self.s[i_out], self.chosen)
        j = first_best(np.where(np.isfinite(ratio), ratio, -np.inf))
        if j < 0 or not ratio[j] > tol:
            return None
        self.add(j)
        try:
            self.remove(i_out)
        except np.linalg.LinAlgError:  # i_out alone saw a direction (round-off hid it): keep it
            self.chosen[j], self.chosen[i_out] = False, True
            self.refresh()  # M⁻¹ and every S_j from the chosen rows again
            return None
        return j


#: smallest eigenvalue, relative to the largest, of an information matrix that determines every
#: coordinate (below it, as when a few joints' torques leave coordinates unseen, the ridge stays)
WELL_POSED = 1e-10


def _well_posed(info: np.ndarray) -> bool:
    """True when ``info`` (symmetric) determines every coordinate, in floating point too."""
    w = np.linalg.eigvalsh(info)
    return bool(w[-1] > 0 and w[0] > WELL_POSED * w[-1])


def schur_logdet(rows: BlockRows, idx) -> float:
    """Log det of the Schur complement of the candidates ``idx`` (−inf: singular)."""
    sign, ld = np.linalg.slogdet(schur_information(rows, idx))
    return float(ld) if sign > 0 else -math.inf


#: the greedy runs over this many candidates per pose chosen (at least ``PRESCREEN_MIN``) of
#: the largest gain on the pool's average information (``prescreen``) ...
PRESCREEN_PER_POSE = 10
PRESCREEN_MIN = 300
#: ... and the exchange passes over ``WORKING_FACTOR`` times as many
WORKING_FACTOR = 3
#: candidates of largest gain an exchange pass offers for each chosen pose
SHORTLIST = 100


def prescreen(rows: BlockRows, k: int) -> np.ndarray:
    """Every candidate ranked (ties by index) by log det(I + A_j M₀⁻¹ A_jᵀ), its gain on M₀ the
    information of k average candidates (k/n Σ A_iᵀA_i): a candidate that adds little to k
    typical poses is rarely worth its place. A pool no larger than the greedy's keeps its
    order (no ranking needed)."""
    n = rows.x.shape[0]
    if n <= max(PRESCREEN_MIN, PRESCREEN_PER_POSE * k):
        return np.arange(n)
    m0 = rows.information(slice(None)) * (k / n)  # every candidate: views, not copies
    m0[np.diag_indices_from(m0)] += _ridge(rows)
    gain = _gains(rows, None, _pd_inverse(m0))
    return np.lexsort((np.arange(n), -gain))


def _gains(rows: BlockRows, idx: np.ndarray | None, minv: np.ndarray) -> np.ndarray:
    """(m,) log det(I + A_j M⁻¹ A_jᵀ) of the candidates ``idx`` (None: all; −inf: not
    finite)."""
    sub = rows if idx is None else rows.take(idx)
    n, r = sub.x.shape[:2]
    out = Sandwiches(np.empty((n, r, r)), np.empty(n))
    sandwich_blocks(KernelRows(sub.x, sub.col, sub.val), minv, out)
    return np.where(np.isfinite(out.gain), out.gain, -np.inf)


@one_blas_thread()
def select_blocks(
    rows: BlockRows,
    k: int,
    seed: int | np.random.Generator = 0,
    max_passes: int = 20,
    shortlist: int | None = None,
) -> Selection:
    """Choose ``k`` distinct candidates maximising log det Σ A_iᵀA_i: greedy from δI over the
    ``prescreen``'s first ``max(PRESCREEN_MIN, PRESCREEN_PER_POSE k)``, then Fedorov exchange
    passes over ``WORKING_FACTOR`` times as many (each chosen pose in turn swapped for the best
    of the ``shortlist`` candidates of largest gain given the current choice, ranked again
    every pass; the first pass with the ridge, as the greedy) until a pass improves nothing."""
    n = rows.x.shape[0]
    if not 1 <= k <= n:
        raise SescidError(f"cannot choose {k} poses from {n} candidates")
    shortlist = SHORTLIST if shortlist is None else shortlist
    rng = np.random.default_rng(seed)
    ridge = _ridge(rows)
    ranked = prescreen(rows, k)
    keep = max(PRESCREEN_MIN, PRESCREEN_PER_POSE * k)
    pre = np.sort(ranked[:keep])
    design = BlockDesign(rows.take(pre), ridge)
    order: list[int] = []
    for _ in range(k):
        i = design.best()
        if i < 0:
            raise SescidError("no candidate adds information")
        order.append(int(pre[i]))
        design.add(i)
    work = np.sort(ranked[: WORKING_FACTOR * keep])
    wrows = rows.take(work)
    at = {int(c): w for w, c in enumerate(work)}
    exchanges = passes = 0
    for passes in range(1, max_passes + 1):  # noqa: B007
        full = BlockDesign.__new__(BlockDesign)
        full.rows, full.ridge = wrows, ridge
        r, m = rows.x.shape[1], len(work)
        full.s, full.gain = np.empty((m, r, r)), np.empty(m)
        full.chosen = np.zeros(m, dtype=bool)
        full.chosen[[at[i] for i in order]] = True
        if passes > 1 and _well_posed(schur_information(rows, order)):  # then drop the ridge
            full.ridge = 0.0
        full.refresh()
        score = full.gains()
        top = np.lexsort((np.arange(m), -score))[: min(shortlist, m - k)]
        idx = np.concatenate([np.asarray([at[i] for i in order]), top])
        sub = BlockDesign.__new__(BlockDesign)
        sub.rows, sub.ridge, sub.minv = wrows.take(idx), full.ridge, full.minv
        sub.s, sub.gain = full.s[idx].copy(), full.gain[idx].copy()
        sub.chosen = np.zeros(len(idx), dtype=bool)
        sub.chosen[:k] = True
        pos_sub, swaps = exchange_pass(sub, k, rng)
        exchanges += swaps
        order = [int(work[idx[i]]) for i in pos_sub]
        if swaps == 0:
            break
    return Selection(
        index=np.array(order),
        logdet=schur_logdet(rows, order),
        exchanges=exchanges,
        passes=passes,
    )
