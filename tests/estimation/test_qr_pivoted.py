"""The scipy-free pivoted QR of the base combinations is LAPACK's, bit for bit."""

import numpy as np
import scipy.linalg

from sescid.estimation.result.identifiability import qr_pivoted


def test_qr_pivoted_is_scipy_bit_for_bit():
    """Pivots and R equal scipy.linalg's on matrices with exact ties; the solve to round-off."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        m = int(rng.integers(2, 30))
        a = rng.standard_normal((m, m + int(rng.integers(0, 25))))
        a[:, 1] = a[:, 0]  # an exact tie of column norms: the choice must be LAPACK's
        _, r_ref, piv_ref = scipy.linalg.qr(a, pivoting=True, mode="economic")
        r, piv, solve = qr_pivoted(a)
        assert np.array_equal(piv, piv_ref)
        assert np.array_equal(r, r_ref)
        p = m - 1
        k_ref = scipy.linalg.solve_triangular(r_ref[:p, :p], r_ref[:p, p:])
        assert np.allclose(solve(r[:p, :p], r[:p, p:]), k_ref, rtol=0, atol=1e-12)
