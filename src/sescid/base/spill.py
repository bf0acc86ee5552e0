"""Float64 arrays kept out of the process's memory, and their exact median.

``Spill`` writes arrays one after another to an anonymous temporary file (the OS's page cache,
not this process's resident memory) and reads them back in the same order, one at a time: an
algorithm that revisits per-row values of a data set read in chunks (a robust fit's residual
sizes) keeps them without holding them. ``median`` is exactly ``numpy.median`` of all the
spilled values joined, found by a radix selection on their bits: a few sequential reads, never
more than ``SELECT_CAP`` values in memory.
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator, Sequence
from typing import IO

import numpy as np

#: values a selection gathers into memory at most once it has narrowed their range (8 MB)
SELECT_CAP = 1 << 20
#: bits of the key a selection pass sorts by (65 536 buckets)
_STEP = 16
_SIGN = np.uint64(1 << 63)
_ALL = np.uint64(0xFFFFFFFFFFFFFFFF)


class Spill:
    """Float64 arrays written in order to an anonymous temporary file, read back in order."""

    def __init__(self) -> None:
        self._file: IO[bytes] | None = tempfile.TemporaryFile(prefix="sescid-spill-")
        self.shapes: list[tuple[int, ...]] = []
        self.size = 0  #: values written

    def write(self, a: np.ndarray) -> None:
        """Append ``a`` (its shape is kept)."""
        assert self._file is not None, "spill closed"
        a = np.ascontiguousarray(a, dtype=np.float64)
        self._file.seek(0, 2)
        self._file.write(a.tobytes())
        self.shapes.append(a.shape)
        self.size += a.size

    def __iter__(self) -> Iterator[np.ndarray]:
        """The arrays in the order written (each read when asked for)."""
        assert self._file is not None, "spill closed"
        self._file.seek(0)
        offset = 0
        for shape in self.shapes:
            count = int(np.prod(shape))
            self._file.seek(offset)
            raw = self._file.read(8 * count)
            offset += 8 * count
            yield np.frombuffer(raw, dtype=np.float64, count=count).reshape(shape)

    def close(self) -> None:
        """Drop the file."""
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> Spill:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _keys(a: np.ndarray) -> np.ndarray:
    """Unsigned keys in the order of the float64 values (negative values below positive)."""
    bits = np.ascontiguousarray(a, dtype=np.float64).reshape(-1).view(np.uint64)
    return bits ^ np.where(bits & _SIGN, _ALL, _SIGN)


def order_statistics(spills: Sequence[Spill], ranks: Sequence[int]) -> list[float]:
    """The values at 0-based ``ranks`` of all the spilled values sorted (NaN-free values).

    Radix selection: each pass over the spills counts the values of the current key prefix
    by their next 16 bits, until the bucket that holds a rank has at most ``SELECT_CAP``
    values, which are gathered and partitioned."""
    # per rank: [prefix, bits known, values below the prefix's bucket, result]
    state: list[list] = [[0, 0, 0, None] for _ in ranks]
    while any(s[3] is None for s in state):
        todo = [(i, s) for i, s in enumerate(state) if s[3] is None]
        hists = {id(s): np.zeros(1 << _STEP, dtype=np.int64) for _, s in todo}
        for sp in spills:
            for arr in sp:
                keys = _keys(arr)
                for _, s in todo:
                    prefix, known = s[0], s[1]
                    mine = keys if known == 0 else keys[(keys >> np.uint64(64 - known)) == prefix]
                    shift = np.uint64(64 - known - _STEP)
                    digit = ((mine >> shift) & np.uint64((1 << _STEP) - 1)).astype(np.intp)
                    hists[id(s)] += np.bincount(digit, minlength=1 << _STEP)
        gather = []
        for i, s in todo:
            cum = np.cumsum(hists[id(s)])
            want = ranks[i] - s[2]
            b = int(np.searchsorted(cum, want, side="right"))
            s[2] += int(cum[b - 1]) if b > 0 else 0
            s[0] = (s[0] << _STEP) | b
            s[1] += _STEP
            if int(hists[id(s)][b]) <= SELECT_CAP or s[1] == 64:
                gather.append((i, s))
        if not gather:
            continue
        found: dict[int, list[np.ndarray]] = {i: [] for i, _ in gather}
        for sp in spills:
            for arr in sp:
                keys = _keys(arr)
                flat = arr.reshape(-1)
                for i, s in gather:
                    pick = (keys >> np.uint64(64 - s[1])) == np.uint64(s[0])
                    found[i].append(flat[pick])
        for i, s in gather:
            vals = np.concatenate(found[i])
            k = ranks[i] - s[2]
            s[3] = float(np.partition(vals, k)[k])
    return [s[3] for s in state]


def median(spills: Sequence[Spill]) -> float:
    """``numpy.median`` of every value of ``spills`` joined (NaN if any value is NaN or there
    are none), without joining them."""
    n = sum(sp.size for sp in spills)
    if n == 0 or any(np.isnan(arr).any() for sp in spills for arr in sp):
        return float("nan")
    if n % 2:
        return order_statistics(spills, [n // 2])[0]
    lo, hi = order_statistics(spills, [n // 2 - 1, n // 2])
    return float(np.mean(np.array([lo, hi])))
