"""Shorthands for tests: each method through the one public ``identify`` (CoP arrays)."""

from __future__ import annotations

import numpy as np

from sescid import identify
from sescid.estimation import ConsistentOptions, MapOptions, Measurements


def identify_ls(robot, q, cop, **kw):
    """Least squares (the paper's method)."""
    return identify(robot, q, cop, method="ls", **kw)


def identify_map(
    robot,
    q,
    cop,
    *,
    prior_scale=None,
    noise=None,
    bias=False,
    select="evidence",
    folds=5,
    prior="sesc",
    **kw,
):
    """MAP with a Gaussian CAD prior (per SESC component by default: τ in metres, the closed
    forms these tests check; ``prior="bodies"`` for identify's default shape)."""
    opts = MapOptions(
        prior_scale=prior_scale, noise=noise, select=select, folds=folds, bias=bias, prior=prior
    )
    return identify(robot, q, cop, method=opts, **kw)


def identify_consistent(robot, q, cop, *, sigma=None, gravity=None, rtol=None, **ckw):
    """Least squares, then masses that reproduce it closest to CAD (``via="fit"``)."""
    opts = ConsistentOptions(via="fit", **ckw)
    return identify(
        robot, q, cop, method=opts, sigma=sigma,
        gravity=gravity, rtol=rtol,
    )  # fmt: skip


def chunks_of(chunks):
    """(q, cop[, sigma[, gravity]]) tuples → Measurements chunks of one data set."""
    for c in chunks:
        sigma = c[2] if len(c) > 2 else None
        if sigma is not None and np.ndim(sigma) == 1:
            sigma = np.repeat(np.asarray(sigma)[:, None], 2, axis=1)
        yield Measurements(q=c[0], cop=c[1], cop_se=sigma, gravity=c[3] if len(c) > 3 else None)


def identify_stream(robot, chunks, **kw):
    """Least squares over chunks read once."""
    kw.setdefault("method", "ls")
    return identify(robot, chunks_of(chunks), **kw)


def cop_offset_stats(measured, predicted) -> dict:
    """Mean offset (x, y, norm) and RMS per component of predicted − measured CoP, m."""
    d = np.asarray(predicted) - np.asarray(measured)
    mean = d.mean(axis=0)
    return {
        "mean_x": float(mean[0]),
        "mean_y": float(mean[1]),
        "mean": float(np.hypot(mean[0], mean[1])),
        "rms": float(np.sqrt(np.mean(d**2))),
    }
