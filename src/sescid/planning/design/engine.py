"""The one D-optimal engine every pose plan goes through: candidates' rows (``BlockRows``) in,
chosen poses and their expected errors out.

``select_poses`` maximises log det of the chosen rows' information: rows of two without offsets (the
CoP alone) by the rank-2 Woodbury search of ``doptimal`` (its fast path), any other rows by the
rank-r block search of ``blocks`` (offsets as nuisance columns). ``choose`` restricts it to the
candidates a physics check has left (or draws at random, the reference); ``expected_error`` is
the RMS error on fresh poses of least squares on the chosen ones, ``error_curve`` its course
with the pose count for D-optimal and random choices.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from sescid.base.threads import one_blas_thread
from sescid.errors import SescidError
from sescid.planning.design.blocks import schur_logdet, select_blocks
from sescid.planning.design.doptimal import Selection, inverse_trace, select_d_optimal
from sescid.planning.design.kinds import BlockRows, schur_information


def select_poses(rows: BlockRows, k: int, seed: int | np.random.Generator = 0) -> Selection:
    """``k`` distinct candidates maximising log det Σ A_iᵀA_i (module docstring)."""
    if rows.x.shape[1] == 2 and rows.n_nuisance == 0:
        return select_d_optimal(rows.x, k, seed)
    return select_blocks(rows, k, seed)


def choose(rows: BlockRows, count: int, how: str, seed: int, keep: np.ndarray) -> Selection:
    """``count`` of the candidates where ``keep``: D-optimal (``how`` "d-optimal"), or at random
    (seeded)."""
    idx = np.flatnonzero(keep)
    if len(idx) < count:
        raise SescidError(f"only {len(idx)} candidates left to choose {count} poses from")
    if how == "d-optimal":
        sel = select_poses(rows.take(idx), count, seed)
        return dataclasses.replace(sel, index=idx[sel.index])
    pick = idx[np.random.default_rng(seed).choice(len(idx), count, replace=False)]
    return Selection(index=pick, logdet=schur_logdet(rows, pick))


def expected_error(rows: BlockRows, idx, c_test: np.ndarray, scale: float = 1.0) -> float:
    """Expected RMS error of least-squares predictions on fresh poses from the candidates
    ``idx``: scale · sqrt(trace(F⁻¹_zz c_test)), F_zz their information with the offsets
    marginalised, ``c_test`` (p, p) the fresh poses' mean information per row
    (``per_row_information``); ``scale``: the noise the rows were not divided by (the CoP's
    σ [m]). inf when the poses do not determine every coordinate."""
    val = inverse_trace(schur_information(rows, idx), c_test)
    return scale * math.sqrt(val) if 0 < val < math.inf else math.inf


def random_errors(
    rows: BlockRows, k: int, c_test: np.ndarray, draws: int = 50, seed=0, scale: float = 1.0
) -> np.ndarray:
    """``expected_error`` (draws,) of ``k`` candidates drawn at random."""
    rng = np.random.default_rng(seed)
    n = rows.x.shape[0]
    return np.array(
        [expected_error(rows, rng.choice(n, k, replace=False), c_test, scale) for _ in range(draws)]
    )


@one_blas_thread()
def error_curve(
    rows: BlockRows,
    c_test: np.ndarray,
    ks,
    seed: int = 0,
    draws: int = 50,
    scale: float = 1.0,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, np.ndarray]:
    """Expected error vs K (``expected_error``): D-optimal, and random (median, 10th/90th
    percentile)."""
    ks = np.asarray(ks, dtype=int)
    out: dict[str, list[float]] = {k: [] for k in ("d_optimal", "random_median", "random_p10",
                                                   "random_p90")}  # fmt: skip
    for n_done, k in enumerate(ks):
        if progress is not None:
            progress(n_done, len(ks))
        sel = select_poses(rows, int(k), seed)
        out["d_optimal"].append(expected_error(rows, sel.index, c_test, scale))
        r = random_errors(rows, int(k), c_test, draws, seed, scale)
        out["random_median"].append(float(np.median(r)))
        out["random_p10"].append(float(np.percentile(r, 10)))
        out["random_p90"].append(float(np.percentile(r, 90)))
    if progress is not None:
        progress(len(ks), len(ks))
    return {"k": ks} | {k: np.array(v) for k, v in out.items()}
