"""The compiled D-optimal kernels and the reduced-coordinate projection agree with plain numpy
and with determinants computed from scratch."""

from __future__ import annotations

import numpy as np
import pytest

from sescid import planning as design
from sescid.planning.design.doptimal import information, select_d_optimal
from sescid.planning.design.doptimal_kernels import rank2, sandwich


def _spd(rng, p):
    x = rng.normal(size=(3 * p, p))
    return np.linalg.inv(x.T @ x)


def test_sandwich_kernel_matches_numpy():
    """sandwich(A, M⁻¹) = A_j M⁻¹ A_jᵀ per candidate, to rounding."""
    rng = np.random.default_rng(11)
    a = rng.normal(size=(500, 2, 13))
    minv = _spd(rng, 13)
    ref = np.einsum("nip,pq,njq->nij", a, minv, a)
    s = sandwich(a, minv)
    np.testing.assert_allclose(s[:, 0], ref[:, 0, 0], rtol=1e-12)
    np.testing.assert_allclose(s[:, 1], ref[:, 0, 1], rtol=1e-10, atol=1e-12 * np.abs(ref).max())
    np.testing.assert_allclose(s[:, 2], ref[:, 1, 1], rtol=1e-12)


def test_rank2_kernel_matches_numpy_and_skips_chosen():
    """S ± A U g Uᵀ Aᵀ for every candidate (in place), and the argmax of det(I + S) over
    unchosen ones."""
    rng = np.random.default_rng(12)
    a = rng.normal(size=(400, 2, 9))
    s_in = sandwich(a, _spd(rng, 9))
    u = rng.normal(size=(9, 2))
    g = np.array([[0.7, 0.2], [0.2, 0.4]])
    w = a @ u  # (n, 2, 2)
    delta = np.einsum("nia,ab,njb->nij", w, g, w)
    chosen = np.zeros(400, dtype=bool)
    chosen[rng.choice(400, 50, replace=False)] = True
    for sign in (-0.01, 1.0):
        out = s_in.copy()
        best = rank2(a, u, g, sign, out, chosen)
        ref = np.stack([s_in[:, 0], s_in[:, 1], s_in[:, 2]], axis=1) + sign * np.stack(
            [delta[:, 0, 0], delta[:, 0, 1], delta[:, 1, 1]], axis=1
        )
        np.testing.assert_allclose(out, ref, rtol=1e-12, atol=1e-12)
        det = (1 + ref[:, 0]) * (1 + ref[:, 2]) - ref[:, 1] ** 2
        det[chosen] = -np.inf
        assert best == int(np.argmax(det))


def test_projected_regressor_is_the_full_regressor_in_the_basis(op2):
    """A = Φ_red (G V) equals Φ V from the full x/y regressor, and V spans the eigenvectors of
    ΦᵀΦ with non-zero eigenvalues (42 for the OP2)."""
    q = design.candidates(op2, 1500, seed=3).q
    basis = design.identifiable_basis(op2, q)
    phi = op2.regressor(q)  # (n, 2, 63): the full chain, not the reduced columns
    np.testing.assert_allclose(design.projected_regressor(op2, q, basis), phi @ basis, atol=1e-13)
    lam, vec = np.linalg.eigh(phi.reshape(-1, 63).T @ phi.reshape(-1, 63))
    ref = vec[:, lam > 1e-9 * lam.max()]
    assert basis.shape == ref.shape == (63, 42)
    np.testing.assert_allclose(basis @ basis.T, ref @ ref.T, atol=1e-9)


def _fedorov_from_scratch(a, k, seed, tol=1e-10):
    """Greedy from a ridge, then exchange passes over the whole pool, every log det from scratch
    (the rule of select_d_optimal with a shortlist as large as the pool)."""
    n, _, p = a.shape
    x = a.reshape(-1, p)
    m = 1e-8 * float(np.einsum("ij,ij->", x, x)) / (n * p) * np.eye(p)
    outer = np.einsum("nip,niq->npq", a, a)
    order: list[int] = []
    for _ in range(k):
        ld = np.linalg.slogdet(m + outer)[1]
        ld[order] = -np.inf
        order.append(int(np.argmax(ld)))
        m = m + outer[order[-1]]
    rng = np.random.default_rng(seed)
    while True:
        improved = False
        for pos in rng.permutation(k):
            info = outer[order].sum(axis=0)
            base = np.linalg.slogdet(info)[1]
            ld = np.linalg.slogdet(info - outer[order[pos]] + outer)[1] - base
            ld[order] = -np.inf
            j = int(np.argmax(ld))
            if ld[j] > tol:
                order[pos] = j
                improved = True
        if not improved:
            return order


def test_exchange_equals_fedorov_from_scratch():
    """With a shortlist as large as the pool, greedy + exchange picks the poses of a Fedorov
    exchange whose determinants are all computed from scratch."""
    rng = np.random.default_rng(13)
    a = rng.normal(size=(250, 2, 8)) * rng.uniform(0.5, 1.5, size=(250, 1, 1))
    ref = _fedorov_from_scratch(a, 9, seed=4)
    sel = select_d_optimal(a, 9, seed=4, shortlist=250)
    assert sel.exchanges > 0
    assert sorted(sel.index.tolist()) == sorted(ref)
    assert sel.logdet == pytest.approx(np.linalg.slogdet(information(a[ref]))[1], abs=1e-9)


def _ref_times(x, col, val, ux, uo, lower):
    """W = A_j U by the scalar loops (t ascending from 0, the nuisance term last; a lower
    triangular U's zero terms skipped) in plain Python: the reference of the block kernels."""
    r, p = x.shape
    c = ux.shape[1]
    w = [[0.0] * c for _ in range(r)]
    for a in range(r):
        for t in range(p):
            for e in range(min(t + 1, c) if lower else c):
                w[a][e] += float(x[a, t]) * float(ux[t, e])
        k = int(col[a])
        if k >= 0:
            for e in range(min(p + k + 1, c) if lower else c):
                w[a][e] += float(val[a]) * float(uo[k, e])
    return w


def _ref_logdet(m):
    """Log det by the in-place Cholesky of the upper triangle, row by row (−inf: not PD)."""
    import math

    r, out = len(m), 0.0
    for k in range(r):
        d = m[k][k]
        if not d > 0.0:
            return -math.inf
        d = math.sqrt(d)
        m[k][k] = d
        out += 2.0 * math.log(d)
        for i in range(k + 1, r):
            m[k][i] /= d
        for i in range(k + 1, r):
            for t in range(i, r):
                m[i][t] -= m[k][i] * m[k][t]
    return out


def _gain_of(s):
    return _ref_logdet([[s[a][b] + (1.0 if a == b else 0.0) for b in range(len(s))]
                        for a in range(len(s))])  # fmt: skip


@pytest.mark.parametrize("seed", range(6))
def test_block_kernels_give_the_bits_of_the_scalar_loops(seed):
    """The block kernels run eight candidates at a time (one per vector lane) with each
    candidate's operations those of the scalar loops: S_j, its updates (both signs), the gains
    and the swap gains equal the plain-Python loops bit for bit, including a pool that does not
    fill its last vector, matrices that are not positive definite (−inf) and chosen candidates."""
    import math

    from sescid.planning.design.block_kernels import (
        KernelRows,
        Sandwiches,
        sandwich_blocks,
        swap_gains,
        update_blocks,
    )

    rng = np.random.default_rng(seed)
    n, r, p, k = 13, 4, 5, 2
    x = rng.normal(size=(n, r, p)) * 10.0 ** rng.integers(-2, 3)
    col = np.array([-1, 0, -1, 1] if seed % 2 else [1, -1, 0, -1], dtype=np.int64)
    val = rng.uniform(0.5, 5.0, size=r) * (col >= 0)
    rows = KernelRows(x, col, val)
    dense = np.zeros((n, r, p + k))  # A_j = [x_j, nuisance]
    dense[:, :, :p] = x
    dense[:, col >= 0, p + col[col >= 0]] = val[col >= 0]
    chosen = np.zeros(n, dtype=bool)
    chosen[[2, 4, 9]] = True  # M: their information and a ridge
    minv = np.linalg.inv(np.einsum("nra,nrb->ab", dense[chosen], dense[chosen]) + np.eye(p + k))
    out = Sandwiches(np.empty((n, r, r)), np.empty(n))
    sandwich_blocks(rows, minv, out)
    low = np.linalg.cholesky(minv)
    for j in range(n):
        w = _ref_times(x[j], col, val, low[:p], low[p:], True)
        s = [[0.0] * r for _ in range(r)]
        for e in range(p + k):
            for a in range(r):
                for b in range(a, r):
                    s[a][b] += w[a][e] * w[b][e]
        ref = np.array([[s[min(a, b)][max(a, b)] for b in range(r)] for a in range(r)])
        assert out.s[j].tobytes() == ref.tobytes()
        assert out.gain[j] == _gain_of(s)
    sandwiches = out.s.copy()
    add = np.linalg.inv(np.eye(r) + sandwiches[7])  # candidate 7 added (M stays PD), then
    updates = [(-1.0, minv @ dense[7].T, add), (1.0, rng.normal(size=(p + k, r)), -20 * add)]
    gains = []
    for sign, u, g in updates:  # ... a large downdate (some S_j no longer PD)
        start = out.s.copy()
        update_blocks(rows, u, g, sign, out)
        gs = (g + g.T) / 2
        for j in range(n):
            w = _ref_times(x[j], col, val, u[:p], u[p:], False)
            v = [[0.0] * r for _ in range(r)]
            for a in range(r):
                for t in range(r):
                    for e in range(r):
                        v[a][e] += (sign * w[a][t]) * float(gs[t, e])
            s = [[float(start[j, a, b]) for b in range(r)] for a in range(r)]
            for a in range(r):
                for t in range(r):
                    for b in range(a, r):
                        s[a][b] += v[a][t] * w[b][t]
            ref = np.array([[s[min(a, b)][max(a, b)] for b in range(r)] for a in range(r)])
            assert out.s[j].tobytes() == ref.tobytes()
            assert out.gain[j] == _gain_of(s)
        gains.append(out.gain.copy())
    assert np.isneginf(gains).any() and np.isfinite(gains).any()  # both cases met
    u = minv @ dense[4].T  # candidate 4 swapped out: U = M⁻¹A_oᵀ, S_o its own
    s_o = sandwiches[4]
    got = swap_gains(rows, u, sandwiches, s_o, chosen)
    assert np.isfinite(got).sum() > 5
    for j in range(n):
        ch = [[float(sandwiches[j, a, b]) + (a == b) for b in range(r)] for a in range(r)]
        first = _ref_logdet(ch)
        if chosen[j] or first == -math.inf:
            assert got[j] == -math.inf
            continue
        y = _ref_times(x[j], col, val, u[:p], u[p:], False)
        for a in range(r):
            for e in range(r):
                y[a][e] /= ch[a][a]
            for i in range(a + 1, r):
                for e in range(r):
                    y[i][e] -= ch[a][i] * y[a][e]
        q = [[-float(s_o[a, b]) + (1.0 if a == b else 0.0) for b in range(r)] for a in range(r)]
        for t in range(r):
            for a in range(r):
                for b in range(a, r):
                    q[a][b] += y[t][a] * y[t][b]
        assert got[j] == first + _ref_logdet(q)
