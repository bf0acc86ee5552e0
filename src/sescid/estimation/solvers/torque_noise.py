"""Joint-torque noise per joint: feasible generalised least squares over the torque rows.

One noise level shared by every torque row lets the joints that carry the most (a support
ankle: tens of N·m, whose residuals grow with the load through joint play and unmodelled mass)
outweigh those that carry a fraction of a N·m (a neck, a wrist): the fit then trades the light
joints' residuals, and the CAD model's masses there, for a small gain on the heavy ones, and the
shared σ̂ is wrong for every joint. Instead each joint j gets its own σ_j, estimated from its own
residuals by a few reweighting passes (feasible GLS, ``tau_noise_model="joint"``, the default):

    σ_j² = RSS_j / (n_j − k_j − t_j),      t_j = tr(G_j C) / σ²,

with RSS_j the joint's residual sum of squares (in units of its given standard errors when the
fit is weighted: σ_j is then a scale on ``tau_se_<joint>``), n_j its rows, k_j its own nuisance
columns (offset, friction band), and t_j its share of the parameters of vec(r): G_j the joint's
Gram matrix of the torque regressor with its nuisance columns projected out, C the fit's
covariance of vec(r) at noise σ (the hat matrix's trace over the joint's rows; Σ_j (k_j + t_j) is
the fit's effective number of parameters). The next fit weighs joint j's rows by 1/σ_j (the rows
carry σ_j, or σ_j · tau_se, as their standard errors); passes stop when no σ_j moves by more than
``GLS_TOL`` (relative), at most ``GLS_PASSES``. The final fit's torque σ̂ is then a scale of the
normalised residuals (≈ 1), and each joint's σ_j is in ``fit.torque_noise``.

A joint with fewer than ``MIN_JOINT_DOF`` residual degrees of freedom keeps the pooled level
(Σ RSS / Σ dof), said in its record; σ_j is floored at ``JOINT_NOISE_FLOOR`` × the pooled level
(a joint measured exactly would otherwise outweigh every other by any factor).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from sescid.estimation.data.measurements import Measurements
from sescid.estimation.result.fit import Fit
from sescid.estimation.result.records import JointNoise
from sescid.estimation.solvers.least_squares import residuals
from sescid.estimation.sums.block_sums import aligned
from sescid.estimation.sums.normal_equations import ACCUMULATE_BLOCK
from sescid.kinds import TORQUE

#: how the torque rows' noise is modelled: one σ_j per joint (feasible GLS) or one shared σ
TorqueNoiseModel = Literal["joint", "shared"]
#: reweighting passes stop when every σ_j changed by less than this (relative) …
GLS_TOL = 0.05
#: … or after this many passes
GLS_PASSES = 3
#: a joint with fewer residual degrees of freedom keeps the pooled noise level
MIN_JOINT_DOF = 5.0
#: σ_j is never taken below this fraction of the pooled level
JOINT_NOISE_FLOOR = 1e-3
#: rows fitted to within this fraction of their RMS reading are noise-free (simulated,
#: exact): no noise to estimate per joint, they keep one shared level
NOISE_FREE = 1e-6


@dataclass
class _Stats:
    """One pass's per-joint sums (J joints): residual squares, rows, and the Gram sums behind
    the leverage (None when a chunk's regressor is not in the fit's coordinates)."""

    rss: np.ndarray
    rows: np.ndarray
    k: np.ndarray  #: nuisance columns per joint
    yy: float = 0.0  #: Σ of the squared readings (in units of their base errors)
    s0: np.ndarray | None = None  #: (J,) Σ w
    s1: np.ndarray | None = None  #: (J, 3N) Σ w φ
    s2: np.ndarray | None = None  #: (J, 3N, 3N) Σ w φ φᵀ
    a0: np.ndarray | None = None  #: (J,) Σ w s (approach side s)
    a1: np.ndarray | None = None  #: (J, 3N) Σ w s φ
    leverage_ok: bool = True
    unit: _Stats | None = None  #: the Gram sums at scale 1 (``joint_stats``)


def _base(m: Measurements, weighted: bool) -> np.ndarray:
    """The rows' given standard errors (n, J): tau_se when weighted, else 1."""
    assert m.tau is not None
    if weighted and m.tau_se is not None:
        return m.tau_se
    return np.ones(m.tau.shape)


def joint_stats(
    fit: Fit,
    chunks_of: Sequence[Any],
    joints: tuple[str, ...],
    weighted: bool,
    scale,
    unit: _Stats | None = None,
) -> _Stats:
    """One pass over the sources (each ``.chunks()``): each joint's residual squares in units
    of its base errors, its rows, and the Gram sums of its rows at the weights the fit used
    (1 / (base · scale_j)²). The Gram sums at scale 1 do not depend on the fit: kept in the
    result's ``unit`` and, given back as ``unit`` (with the base errors they were made with),
    scaled instead of summed again — the regressor rows are made once for every pass."""
    nj = len(joints)
    st = _Stats(np.zeros(nj), np.zeros(nj), np.zeros(nj))
    gram = _Stats(np.zeros(nj), np.zeros(nj), np.zeros(nj)) if unit is None else unit
    index = {j: i for i, j in enumerate(joints)}
    mass = fit.total_mass if math.isfinite(fit.total_mass) else fit.robot.total_mass
    for src in chunks_of:
        # fixed blocks counted from the source's first pose: chunks of any size, same bits
        for m in aligned(src.chunks(), ACCUMULATE_BLOCK):
            if m.tau is None or not m.tau_joints:
                continue
            cols = np.array([index[j] for j in m.tau_joints])
            base = _base(m, weighted)
            res = residuals(fit, m)[TORQUE] / base
            st.rss[cols] += np.sum(res**2, axis=0)
            st.yy += float(np.sum((m.tau / base) ** 2))
            st.rows[cols] += m.n
            st.k[cols] = 1 + (m.approach is not None)
            if m.stance_on(fit.robot).label != fit.robot.support:  # another stance's rows
                st.leverage_ok = False
                continue
            if unit is None:
                phi = fit.robot.torque_regressor(m.q, m.tau_joints, m.gravity, fit.gravity_accel)
                _add_gram(gram, cols, phi * mass, 1.0 / base**2, m.approach, nj)  # (n, J, 3N)
    if unit is None:
        gram.leverage_ok = st.leverage_ok
    st.unit = gram
    st.leverage_ok = st.leverage_ok and gram.leverage_ok
    if gram.s0 is not None:
        f = 1.0 / np.asarray([scale[j] for j in joints], dtype=float) ** 2  # (J,)
        assert gram.s1 is not None and gram.s2 is not None and gram.a0 is not None
        assert gram.a1 is not None
        st.s0, st.a0 = gram.s0 * f, gram.a0 * f
        st.s1, st.a1 = gram.s1 * f[:, None], gram.a1 * f[:, None]
        st.s2 = gram.s2 * f[:, None, None]
    return st


def _add_gram(st: _Stats, cols, phi, w, approach, nj: int) -> None:
    p = phi.shape[2]
    if st.s0 is None:
        st.s0, st.a0 = np.zeros(nj), np.zeros(nj)
        st.s1, st.a1 = np.zeros((nj, p)), np.zeros((nj, p))
        st.s2 = np.zeros((nj, p, p))
    assert st.a0 is not None and st.s1 is not None and st.a1 is not None and st.s2 is not None
    st.s0[cols] += w.sum(axis=0)
    st.s1[cols] += np.einsum("nj,njp->jp", w, phi)
    st.s2[cols] += np.einsum("nj,njp,njq->jpq", w, phi, phi, optimize=True)
    if approach is not None:
        st.a0[cols] += np.einsum("nj,n->j", w, approach)
        st.a1[cols] += np.einsum("nj,n,njp->jp", w, approach, phi)


def leverages(st: _Stats, cov: np.ndarray, sigma: float) -> np.ndarray | None:
    """t_j = tr(G_j C)/σ² (J,): each joint's share of the parameters of vec(r), G_j its Gram
    matrix with its own nuisance columns projected out (module docstring); None when unknown."""
    if not st.leverage_ok or st.s2 is None or not (math.isfinite(sigma) and sigma > 0):
        return None
    if not np.all(np.isfinite(cov)):
        return None
    assert st.s0 is not None and st.s1 is not None and st.a0 is not None and st.a1 is not None
    out = np.zeros(st.s0.size)
    for j in range(st.s0.size):
        if st.k[j] > 1:
            b = np.stack([st.s1[j], st.a1[j]])
            mm = np.array([[st.s0[j], st.a0[j]], [st.a0[j], st.s0[j]]])
        else:
            b, mm = st.s1[j][None], np.array([[st.s0[j]]])
        g = st.s2[j] - b.T @ np.linalg.pinv(mm) @ b
        out[j] = float(np.sum(g * cov)) / sigma**2
    return out


def joint_noise(st: _Stats, fit: Fit, joints: tuple[str, ...]) -> tuple[JointNoise, ...]:
    """Each joint's σ_j from one pass's sums (in units of its base errors; module docstring)."""
    tau = fit.kind(TORQUE)
    sigma = tau.sigma if tau is not None else math.nan
    lev = leverages(st, fit.cov, sigma)
    if lev is None:  # the parameters shared in proportion to the rows
        used = max(fit.rank, 0)
        lev = used * st.rows / max(float(st.rows.sum()), 1.0)
    dof = st.rows - st.k - lev
    rss = st.rss
    ok = dof >= MIN_JOINT_DOF
    free = float(dof[ok].sum())
    pooled = math.sqrt(float(rss[ok].sum()) / free) if free > 0 else math.nan
    out = []
    for i, j in enumerate(joints):
        rms = math.sqrt(rss[i] / st.rows[i]) if st.rows[i] > 0 else math.nan
        by: Literal["estimated", "pooled"] = "estimated" if ok[i] else "pooled"
        s = max(math.sqrt(rss[i] / dof[i]), JOINT_NOISE_FLOOR * pooled) if ok[i] else pooled
        out.append(JointNoise(j, s, float(dof[i]), rms, by, float(st.rows[i]), float(lev[i])))
    return tuple(out)


class JointScaled:
    """A source whose torque rows carry σ_j (× their given errors when weighted) as their
    standard errors: the next pass's weights, chunk by chunk."""

    def __init__(self, source: Any, sigma: dict[str, float], weighted: bool):
        self.source, self.sigma, self.weighted = source, sigma, weighted
        self.name = getattr(source, "name", "data")

    def chunks(self) -> Iterator[Measurements]:
        """The source's chunks with the scaled errors, in its order."""
        for m in self.source.chunks():
            if m.tau is None or not m.tau_joints:
                yield m
                continue
            s = np.asarray([self.sigma[j] for j in m.tau_joints])
            yield dataclasses.replace(m, tau_se=_base(m, self.weighted) * s)

    def close(self) -> None:
        """The source is its caller's to close."""


def tau_joints_of(sources: Sequence[Any]) -> tuple[str, ...]:
    """The measured torque joints of every source, in first-seen order."""
    out: dict[str, None] = {}
    for src in sources:
        for m in src.chunks():
            if m.tau is not None:
                out.update(dict.fromkeys(m.tau_joints))
            break
    return tuple(out)


def per_joint_noise(run, sources: Sequence[Any], weighted: bool, first: Fit):
    """Feasible GLS (module docstring) from a fit ``first`` of ``sources`` with the rows'
    base weights; ``run(sources, weighted)`` fits. Returns (the sources wrapped with each
    joint's σ_j, the records, the last fit, the Gram sums at scale 1 for ``joint_stats``) —
    (None, (), first, None) when the data give no positive pooled level (noise-free rows keep
    one shared noise)."""
    joints = tau_joints_of(sources)
    if not joints:
        return None, (), first, None
    scale = dict.fromkeys(joints, 1.0)
    fit, records, wrapped = first, (), None
    unit: _Stats | None = None
    for _ in range(GLS_PASSES):
        st = joint_stats(fit, sources, joints, weighted, scale, unit)
        unit = st.unit
        new = joint_noise(st, fit, joints)
        sig = {r.joint: r.sigma for r in new}
        size = math.sqrt(st.yy / max(float(st.rows.sum()), 1.0))
        rms = math.sqrt(float(st.rss.sum()) / max(float(st.rows.sum()), 1.0))
        if wrapped is None and not rms > NOISE_FREE * size:
            return None, (), first, None
        if not all(math.isfinite(v) and v > 0 for v in sig.values()):
            return (wrapped, records, fit, unit) if wrapped is not None else (None, (), first, None)
        moved = max(abs(sig[j] / scale[j] - 1.0) for j in joints)
        records, scale = new, sig
        wrapped = [JointScaled(s, sig, weighted) for s in sources]
        fit = run(wrapped, True)
        if moved < GLS_TOL:
            break
    return wrapped, records, fit, unit


def with_records(fit: Fit, records: tuple[JointNoise, ...], weighted: bool) -> Fit:
    """The final fit with each joint's σ_j (and its residual RMS under that fit) attached; a
    weighted base keeps σ_j as a scale on the given errors (``JointNoise.unit``)."""
    unit = "1" if weighted else "N·m"
    return dataclasses.replace(
        fit, torque_noise=tuple(dataclasses.replace(r, unit=unit) for r in records)
    )
