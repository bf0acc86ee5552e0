"""Tables on disk written: columns as CSV (header row) or Parquet by suffix, atomically, with
floats in their shortest exact form (a CSV round trip is lossless).

Float64 columns are written in blocks by the compiled formatter of ``float_text`` (each number
as ``repr`` writes it, so the bytes are the ``csv`` module's), with any text columns beside them
(their cells as the ``csv`` module writes them), other number columns by pyarrow's CSV writer;
a small table by Python itself while numba is not loaded.
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path
from typing import Any

import numpy as np

from sescid.base.files import atomic_open, atomic_path
from sescid.errors import DataError
from sescid.tables.read import CHUNK_ROWS, is_parquet

#: rows per block of a float64 CSV write (24 OP2 columns: ~7 MB of text), and its threads
WRITE_BLOCK_ROWS = 1 << 14
WRITE_THREADS = 2
#: numbers up to which a float64 CSV is formatted by Python's repr while numba is not loaded
#: (≤ ~0.2 s, against ~0.5 s to import numba and load the compiled formatter)
PYTHON_WRITE_NUMBERS = 1 << 18
#: the same for a table with text columns, by the csv module (~0.6 µs a number: ≤ ~2.5 s,
#: against ~90 MB of memory and ~0.5 s to load the compiled formatter for `measure`'s output)
PLAIN_MIXED_NUMBERS = 1 << 22


def write_table(path: str | Path, columns: dict[str, np.ndarray]) -> None:
    """Write float (or string) columns as CSV (or Parquet by suffix), atomically.

    Floats are written in their shortest exact form, so a CSV round trip is lossless: float64
    columns as ``repr`` writes them, by the compiled formatter (``float_text``) on two threads;
    other number columns in chunks of ``CHUNK_ROWS`` rows by pyarrow's writer.
    """
    path = Path(path)
    names = list(columns)
    cols = [np.asarray(columns[k]) for k in names]
    if not names:  # a header-less file would read back as nothing: say so instead
        raise DataError(f"{path}: nothing to write (no column)")
    try:
        import pyarrow as pa
    except ImportError:  # pragma: no cover - pyarrow is a dependency; plain writer otherwise
        _write_csv_plain(path, names, cols)
        return
    if is_parquet(path):
        import pyarrow.parquet as pq

        with atomic_path(path) as tmp:
            pq.write_table(pa.table(dict(zip(names, cols, strict=True))), tmp)
        return
    if any(c.dtype.kind not in "fiu" for c in cols):  # text or flags beside the numbers
        if len(cols) == 1 or _small_write(len(cols[0]) * len(cols), PLAIN_MIXED_NUMBERS):
            _write_csv_plain(path, names, cols)
        else:
            _write_csv_mixed(path, names, cols)
        return
    if cols and all(c.dtype == np.float64 for c in cols):
        _write_csv_floats(path, names, cols)
        return
    import pyarrow.csv as pcsv

    n = len(cols[0]) if cols else 0
    opts = pcsv.WriteOptions(include_header=False, batch_size=CHUNK_ROWS)
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write((",".join(_csv_field(k) for k in names) + "\n").encode())
            for s in range(0, n, CHUNK_ROWS):
                part = [c[s : s + CHUNK_ROWS] for c in cols]
                table = pa.Table.from_arrays([pa.array(c) for c in part], names=names)
                pcsv.write_csv(table, fh, opts)


def _write_csv_floats(path: Path, names: list[str], cols: list[np.ndarray]) -> None:
    """Float64 columns as CSV, each number as ``repr`` writes it (``float_text``): blocks of
    ``WRITE_BLOCK_ROWS`` rows formatted by ``WRITE_THREADS`` threads (the compiled formatter
    holds no GIL) while this thread writes the finished ones in order; a small table by
    Python's ``repr`` itself while numba is not loaded."""
    import queue

    n, k = len(cols[0]), len(cols)
    header = (",".join(_csv_field(name) for name in names) + "\n").encode()
    if _small_write(n * k):
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            fh.write(header)
            fh.write(_rows_repr(cols))
        return
    from sescid.tables.float_text import format_rows, text_bytes

    rows = max(1, min(WRITE_BLOCK_ROWS, n))
    free: queue.SimpleQueue = queue.SimpleQueue()  # (numbers, text) buffers written out

    def block(start: int) -> tuple[Any, np.ndarray]:
        try:
            bufs = free.get_nowait()
        except queue.Empty:  # at most WRITE_THREADS + 2 pairs of buffers, reused
            bufs = (np.empty((rows, k)), np.empty(text_bytes((rows, k)), dtype=np.uint8))
        x = bufs[0][: min(start + rows, n) - start]
        for j, c in enumerate(cols):
            x[:, j] = c[start : start + len(x)]
        return bufs, format_rows(x, bufs[1])

    format_rows(np.zeros((1, 1)))  # the kernel loaded here, once, before two threads call it
    _write_blocks(path, header, n, rows, block, free.put)


def _write_blocks(
    path: Path, header: bytes, n: int, rows: int, block: Any, done: Any = None
) -> None:
    """``header`` then the text of ``block(start)`` → (buffers, text) for each block of ``rows``
    of the ``n`` rows, made by ``WRITE_THREADS`` threads while this thread writes the finished
    ones in order, atomically; ``done(buffers)`` once a block's text is written."""
    from collections import deque
    from concurrent.futures import ThreadPoolExecutor

    def write(future: Any) -> None:
        bufs, text = future.result()
        fh.write(text)
        if done is not None:
            done(bufs)

    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(header)
        with ThreadPoolExecutor(max_workers=WRITE_THREADS, thread_name_prefix="sescid-csv") as pool:
            pending: deque = deque()
            for start in range(0, n, rows):
                pending.append(pool.submit(block, start))
                if len(pending) > WRITE_THREADS:  # at most this many blocks wait in memory
                    write(pending.popleft())
            while pending:
                write(pending.popleft())


def _write_csv_mixed(path: Path, names: list[str], cols: list[np.ndarray]) -> None:
    """Columns of any kind as CSV, the bytes ``_write_csv_plain`` writes (its CRLF line ends
    too), in blocks of ``WRITE_BLOCK_ROWS`` rows by ``WRITE_THREADS`` threads: the float64
    columns and the other cells, each distinct value written once a block as the csv module
    writes it, joined by the compiled formatter (``float_text.format_cells``; a text column
    such as ``support`` beside 10⁶ rows of numbers took the csv module 15 s, a Python join
    of each row 2 s)."""
    import queue

    from sescid.tables.float_text import format_cells

    fl = [c.dtype == np.float64 for c in cols]
    floats = [c for c, f in zip(cols, fl, strict=True) if f]
    other = [c for c, f in zip(cols, fl, strict=True) if not f]
    where = np.cumsum(fl) - 1  # column → its float's index, or -1 - its text column's index
    where[~np.array(fl)] = -1 - np.arange(len(other))
    n = len(cols[0])
    rows = max(1, min(WRITE_BLOCK_ROWS, n))
    free: queue.SimpleQueue = queue.SimpleQueue()  # (numbers, cell numbers, text) written out

    def block(start: int) -> tuple[tuple, np.ndarray]:
        try:
            bufs = free.get_nowait()
        except queue.Empty:  # at most WRITE_THREADS + 2 sets of buffers, reused
            bufs = (np.empty((rows, len(floats))), np.empty((rows, len(other)), dtype=np.int64))
            bufs += (np.empty(0, dtype=np.uint8),)
        m = min(start + rows, n) - start
        x, codes = bufs[0][:m], bufs[1][:m]
        for j, c in enumerate(floats):
            x[:, j] = c[start : start + m]
        cells: list[bytes] = []
        for j, c in enumerate(other):
            texts, codes[:, j] = _cells(c[start : start + m])
            codes[:, j] += len(cells)
            cells += texts
        text = format_cells(x, where, codes, cells, b"\r\n", bufs[2])
        return (*bufs[:2], text.base if text.base is not None else text), text

    block(n)  # the kernel loaded here, once (an empty block), before two threads call it
    header = (",".join(_csv_field(k) for k in names) + "\r\n").encode()  # the csv module's
    _write_blocks(path, header, n, rows, block, free.put)


def _cells(values: np.ndarray) -> tuple[list[bytes], np.ndarray]:
    """The cells of a non-float64 column as the csv module writes them, and each row's cell
    number: each distinct value once where equal values are equal cells (text, bytes, ints and
    bools: these by numpy's text conversion, ``str``'s digits, True, False, nothing to quote);
    a cell per row otherwise (objects, None, other floats: -0.0 equals 0.0)."""
    if values.dtype.kind not in "USbiu" or not len(values):
        return [_csv_cell(v) for v in values.tolist()], np.arange(len(values))
    if (values == values[0]).all():  # one value (a stance): written once
        return [_csv_cell(values[:1].tolist()[0])], np.zeros(len(values), dtype=np.int64)
    distinct, codes = np.unique(values, return_inverse=True)
    if values.dtype.kind in "biu":
        return distinct.astype("S").tolist(), codes.ravel()
    return [_csv_cell(v) for v in distinct.tolist()], codes.ravel()


def _csv_cell(v: Any) -> bytes:
    """One cell as the csv module writes it (quoted when it holds , " or a line break)."""
    if v is None:
        return b""
    return _csv_field(repr(v) if isinstance(v, float) else str(v)).encode()


def _small_write(numbers: int, limit: int = PYTHON_WRITE_NUMBERS) -> bool:
    """True for a table small enough (``limit`` numbers) to format in Python while numba is
    not loaded (a prediction of a few dozen poses need not load it)."""
    return numbers <= limit and "numba" not in sys.modules


def _rows_repr(cols: list[np.ndarray]) -> bytes:
    """The CSV rows of float64 columns by Python's ``repr``: the compiled formatter's bytes."""
    rows = zip(*[c.tolist() for c in cols], strict=True)
    return "".join(",".join(map(repr, row)) + "\n" for row in rows).encode()


def _csv_field(name: str) -> str:
    if any(ch in name for ch in ',"\r\n'):
        return '"' + name.replace('"', '""') + '"'
    return name


def _write_csv_plain(path: Path, names: list[str], cols: list[np.ndarray]) -> None:
    with atomic_open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        text = [c.tolist() for c in cols]  # Python floats: repr is the shortest exact form
        w.writerows(zip(*text, strict=True))
