"""D-optimal choice of poses that give r rows each (joint torques, or torques and the CoP), the
torque offsets as nuisance columns (``kinds``).

As ``doptimal`` for the CoP's two rows: greedy from a tiny ridge δI, then Fedorov exchange
passes over a shortlist of the most informative candidates. Each candidate's
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
from sescid.planning.block_kernels import (
    Rows,
    Sandwiches,
    sandwich_blocks,
    swap_gains,
    update_blocks,
)
from sescid.planning.doptimal import Selection, exchange_pass
from sescid.planning.doptimal_kernels import TIE_LOGDET, first_best
from sescid.planning.kinds import BlockRows, schur_information


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

    def _rows(self) -> Rows:
        r = self.rows
        return Rows(r.x, r.col, r.val)

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


@one_blas_thread()
def select_blocks(
    rows: BlockRows,
    k: int,
    seed: int | np.random.Generator = 0,
    max_passes: int = 20,
    shortlist: int = 300,
) -> Selection:
    """Choose ``k`` distinct candidates maximising log det Σ A_iᵀA_i: greedy from δI, then
    Fedorov exchange passes (each chosen pose in turn swapped for the best of the
    ``shortlist`` candidates of largest gain given the current choice, refreshed every pass)
    until a pass improves nothing."""
    n = rows.x.shape[0]
    if not 1 <= k <= n:
        raise SescidError(f"cannot choose {k} poses from {n} candidates")
    rng = np.random.default_rng(seed)
    design = BlockDesign(rows)
    order: list[int] = []
    for _ in range(k):
        i = design.best()
        if i < 0:
            raise SescidError("no candidate adds information")
        order.append(i)
        design.add(i)
    exchanges = passes = 0
    full = design  # the first pass ranks by the greedy's own S_j (current, ridge included)
    for passes in range(1, max_passes + 1):  # noqa: B007
        if passes > 1:
            full = BlockDesign.__new__(BlockDesign)
            full.rows, full.ridge = rows, design.ridge
            full.s, full.gain = design.s, design.gain  # reused: the greedy's are not needed
            full.chosen = np.zeros(n, dtype=bool)
            full.chosen[order] = True
            if _well_posed(schur_information(rows, order)):  # drop the ridge once determined
                full.ridge = 0.0
            full.refresh()
        score = full.gains()
        top = np.lexsort((np.arange(n), -score))[: min(shortlist, n - k)]
        idx = np.concatenate([np.asarray(order), top])
        sub = BlockDesign.__new__(BlockDesign)
        sub.rows, sub.ridge, sub.minv = rows.take(idx), full.ridge, full.minv
        sub.s, sub.gain = full.s[idx].copy(), full.gain[idx].copy()
        sub.chosen = np.zeros(len(idx), dtype=bool)
        sub.chosen[:k] = True
        pos_sub, swaps = exchange_pass(sub, k, rng)
        exchanges += swaps
        order = [int(idx[i]) for i in pos_sub]
        if swaps == 0:
            break
    return Selection(
        index=np.array(order),
        logdet=schur_logdet(rows, order),
        exchanges=exchanges,
        passes=passes,
    )
