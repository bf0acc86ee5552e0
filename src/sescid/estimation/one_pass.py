"""Least squares over a stream that can be read once (a file's chunks), exact MAE, flat memory.

The normal equations are accumulated as the chunks arrive (blocks aligned with the in-memory
path, so the fit is the same bit for bit). The RMS follows from them, but the MAE needs the
fitted r, i.e. a second pass. Rather than keeping every chunk (176 MB per 10⁶ OP2 poses) or
parsing the file twice, each chunk's arrays are spilled, as raw float64, to an anonymous
temporary file (the OS's page cache, not this process's memory) and read back one chunk at a
time for the residuals: one kinematics pass gives the MAE, the RMS and, for simulated data,
the error against the noise-free CoP.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable, Iterable, Iterator
from typing import IO

import numpy as np

from sescid.base.threads import one_blas_thread
from sescid.estimation.fit import Fit
from sescid.estimation.identifiability import DEFAULT_RTOL, check_enough_poses
from sescid.estimation.least_squares import _reblock, solve
from sescid.estimation.normal_equations import ACCUMULATE_BLOCK, accumulate, check_cop
from sescid.kinematics import as_poses
from sescid.robot import Robot


def _put(fh: IO[bytes], arrays: tuple, shapes: list) -> None:
    """Append the arrays' raw float64 bytes; their shapes (None: absent) go to ``shapes``."""
    for a in arrays:
        shapes.append(None if a is None else a.shape)
        if a is not None:
            fh.write(np.ascontiguousarray(a, dtype=float).tobytes())


def _get(fh: IO[bytes], shapes: Iterator) -> tuple:
    out: list[np.ndarray | None] = []
    for _ in range(5):
        shape = next(shapes)
        if shape is None:
            out.append(None)
            continue
        count = int(np.prod(shape))
        out.append(np.frombuffer(fh.read(8 * count), dtype=float, count=count).reshape(shape))
    return tuple(out)


@one_blas_thread()
def identify_once(
    robot: Robot,
    chunks: Iterable[tuple],
    *,
    rtol: float = DEFAULT_RTOL,
    r_prior: np.ndarray | None = None,
    progress: Callable[[int], None] | None = None,
) -> Fit:
    """``identify_ls`` over chunks ``(q, cop, sigma, gravity, truth)`` read once (None for an
    absent array; ``truth`` (n, 2) the noise-free CoP of simulated data).

    Same fit, MAE and RMS as ``identify_chunks`` (bit for bit); ``fit.truth_cop_rmse`` is set
    when the chunks carry ``truth``. ``progress(poses_done)`` after each block.
    """
    with tempfile.TemporaryFile(prefix="sescid-") as spill:
        n_chunks = total = 0
        shapes: list = []
        weighted = has_truth = False

        def checked() -> Iterator[tuple]:
            nonlocal n_chunks, total, weighted, has_truth
            for c in chunks:
                q = as_poses(c[0], robot.nq)
                cop = check_cop(c[1], q.shape[0])
                sigma, gravity, truth = (tuple(c[2:]) + (None, None, None))[:3]
                _put(spill, (q, cop, sigma, gravity, truth), shapes)
                n_chunks += 1
                total += q.shape[0]
                weighted = weighted or sigma is not None
                has_truth = has_truth or truth is not None
                yield q, cop, sigma, gravity

        done = 0

        def blocks() -> Iterator[tuple]:
            nonlocal done
            for b in _reblock(checked(), ACCUMULATE_BLOCK):  # type: ignore[arg-type]
                yield b
                done += b[0].shape[0]
                if progress is not None:
                    progress(done)

        ne = accumulate(robot, blocks())
        check_enough_poses(robot, total)
        fit = solve(robot, ne, rtol=rtol, r_prior=r_prior)
        fit.weighted = weighted
        spill.seek(0)
        stored = iter(shapes)
        abs_sum = sq_sum = truth_sum = 0.0
        for _ in range(n_chunks):
            q, cop, _sigma, gravity, truth = _get(spill, stored)
            pred = fit.predict_cop(q, gravity)
            resid = cop - pred - fit.cop_bias
            abs_sum += float(np.sum(np.abs(resid)))
            sq_sum += float(np.sum(resid**2))
            if truth is not None:  # the noise-free CoP under the same gravity
                truth_sum += float(np.sum((pred - truth) ** 2))
    fit.mae = abs_sum / (2 * total)
    fit.rms = math.sqrt(sq_sum / (2 * total))
    if has_truth:
        fit.truth_cop_rmse = math.sqrt(truth_sum / (2 * total))
    return fit
