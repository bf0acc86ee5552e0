"""Sequential D-optimal design: the next-best pose given the poses measured so far.

The information of the measured poses, ``M = δI + Σ AᵢᵀAᵢ`` (``Aᵢ`` the projected x/y regressor,
``δ`` the tiny ridge of ``select_d_optimal``), is kept with every candidate's
``Sⱼ = Aⱼ M⁻¹ Aⱼᵀ`` by rank-2 Woodbury updates; a candidate's information gain is
``log det(I + Sⱼ)`` = the rise of ``log det M`` if it were measured next.

Rule for the next pose (``near``): among the candidates not yet commanded, those whose gain is at
least ``near`` × the best gain are taken as equally good, and the one nearest the current pose
(Euclidean joint-space distance, rad) is chosen, so the path between poses stays short.
``near = 1`` is the pure greedy choice.

Poses that give more than two rows (joint torques, with an offset per joint: ``kinds``) are
handled alike from their ``BlockRows``: each candidate's r × r ``Sⱼ`` kept by rank-r updates
(``blocks.BlockDesign``), the gain ``log det(I + Sⱼ)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sescid.errors import OptionError, SescidError
from sescid.planning.design.blocks import BlockDesign
from sescid.planning.design.doptimal import GreedyDesign, logdet2
from sescid.planning.design.kinds import BlockRows


@dataclass(frozen=True)
class NextPose:
    """The candidate chosen next: its index in the pool, its gain and its distance (rad)."""

    index: int
    gain: float  #: log det rise if measured
    best_gain: float  #: the largest gain among the candidates left
    distance: float  #: rad, joint-space distance from the current pose


class SequentialDesign:
    """Greedy, one-pose-at-a-time D-optimal choice over a candidate pool: the CoP's rows
    A (n, 2, p), or ``BlockRows`` (r rows per pose with nuisance columns)."""

    def __init__(self, a: np.ndarray | BlockRows, near: float = 0.8):
        if not 0 < near <= 1:
            raise OptionError("near", f"must be in (0, 1], got {near}")
        n = a.x.shape[0] if isinstance(a, BlockRows) else a.shape[0]
        if n == 0:
            raise SescidError("no candidate poses to choose from")
        self._d: GreedyDesign | BlockDesign
        if isinstance(a, BlockRows):
            self._d = BlockDesign(a)
        else:
            p = a.shape[2]
            x = a.reshape(2 * n, p)
            delta = 1e-8 * float(np.einsum("ij,ij->", x, x)) / (n * p)
            self._d = GreedyDesign(a, np.eye(p) / delta)
        self.near = near
        self.tried = np.zeros(n, dtype=bool)  #: commanded already (measured or failed)

    def gains(self) -> np.ndarray:
        """(n,) log det(I + A_j M⁻¹ A_jᵀ); −inf for candidates already commanded."""
        if isinstance(self._d, BlockDesign):
            g = self._d.gains()
        else:
            g = np.nan_to_num(logdet2(self._d.s), nan=-np.inf)
        g[self.tried] = -np.inf
        return g

    def next(
        self, q_pool: np.ndarray, q_current: np.ndarray, among: np.ndarray | None = None
    ) -> NextPose:
        """The next pose by the module's rule (raises SescidError when none is left), among the
        candidates where ``among`` (n,) when given (a stance's)."""
        g = self.gains()
        if among is not None:
            g = np.where(among, g, -np.inf)
        best = float(np.max(g)) if g.size else -np.inf
        if not np.isfinite(best):
            raise SescidError("every candidate pose has been commanded")
        dist = np.linalg.norm(q_pool - q_current[None, :], axis=1)
        ok = g >= (self.near * best if best > 0 else best)
        i = int(np.argmin(np.where(ok, dist, np.inf)))
        return NextPose(i, float(g[i]), best, float(dist[i]))

    def mark_tried(self, i: int) -> None:
        """Never propose candidate ``i`` again (it was commanded)."""
        self.tried[i] = True

    def add(self, i: int) -> None:
        """Candidate ``i`` was measured: add its information."""
        self.tried[i] = True
        self._d.add(i)
