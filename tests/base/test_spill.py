"""Spilled arrays come back as written, and their median is numpy's, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from sescid.base import spill
from sescid.base.spill import Spill, median, order_statistics


def _spills(parts):
    out = []
    for p in parts:
        sp = Spill()
        sp.write(p)
        out.append(sp)
    return out


def test_arrays_come_back_in_order_with_their_shapes():
    rng = np.random.default_rng(0)
    arrays = [rng.normal(size=(5, 3)), rng.normal(size=7), np.empty((0, 4))]
    with Spill() as sp:
        for a in arrays:
            sp.write(a)
        for _ in range(2):  # read twice: the same
            back = list(sp)
            assert [b.shape for b in back] == [a.shape for a in arrays]
            assert all(np.array_equal(a, b) for a, b in zip(arrays, back, strict=True))
        assert sp.size == 15 + 7


@pytest.mark.parametrize("cap", [spill.SELECT_CAP, 16, 0])
def test_the_median_is_numpys(monkeypatch, cap):
    """Odd and even counts, ties, negative values and zeros of both signs, several spills, and
    selections narrowed over several passes (a small cap): numpy's median, exactly."""
    monkeypatch.setattr(spill, "SELECT_CAP", cap)
    rng = np.random.default_rng(1)
    cases = [
        rng.normal(size=1001),
        np.abs(rng.normal(size=2000)),
        np.round(rng.normal(size=999), 1),
        np.concatenate([np.full(50, -0.0), np.full(51, 0.0), np.full(10, 1e-300)]),
        rng.lognormal(size=4) * 1e200,
        np.array([3.0]),
    ]
    for values in cases:
        parts = np.array_split(values, 3)
        got = median(_spills([p.reshape(-1, 1) if len(p) % 2 else p for p in parts]))
        assert got == np.median(values), (got, np.median(values))
        ranks = sorted({0, len(values) // 3, len(values) - 1})
        assert order_statistics(_spills(parts), ranks) == np.sort(values)[ranks].tolist()


def test_no_values_or_a_nan_give_nan():
    assert np.isnan(median([]))
    assert np.isnan(median(_spills([np.array([1.0, np.nan, 2.0])])))
