"""The compiled D-optimal kernels and the reduced-coordinate projection agree with plain numpy
and with determinants computed from scratch."""

from __future__ import annotations

import numpy as np
import pytest

from sescid import planning as design
from sescid.planning.doptimal_kernels import rank2, sandwich


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
    sel = design.select_d_optimal(a, 9, seed=4, shortlist=250)
    assert sel.exchanges > 0
    assert sorted(sel.index.tolist()) == sorted(ref)
    assert sel.logdet == pytest.approx(np.linalg.slogdet(design.information(a[ref]))[1], abs=1e-9)
