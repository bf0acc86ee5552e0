"""Pose and CoP tables on disk: CSV (header row) and Parquet, read into ``Table`` columns and
written atomically with floats in their shortest exact form (a CSV round trip is lossless).

Files are read in streamed chunks by pyarrow (its CSV reader, Parquet row batches):
``iter_table`` yields one ``Table`` per chunk, whose ``first_row`` keeps every error naming the
file's own row, so a fit can be accumulated over a file of any length in flat memory
(``read_table`` is the same chunks joined). A file pyarrow cannot parse as a whole (a short row,
a number column that turns to text further down) is read again by the plain ``csv`` reader,
which has the final word on what the file holds and on the error message. Float64 columns are
written in blocks by the compiled formatter of ``float_text`` (each number as ``repr`` writes
it, so the bytes are the ``csv`` module's), other number columns by pyarrow's CSV writer.

The column conventions and the joint/CoP readers are ``sescid.base.columns``'s.
"""

from __future__ import annotations

import csv
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from sescid.base.columns import Table
from sescid.base.files import atomic_open, atomic_path
from sescid.base.rows import RowNumbers
from sescid.errors import DataError
from sescid.io.file_kinds import refuse_other_content

#: bytes of CSV text per block that pyarrow parses (about 540 OP2 poses); pyarrow's reader
#: keeps up to 32 blocks read ahead, so its memory is ~32 times this
CSV_BLOCK_BYTES = 1 << 18
#: rows of a streamed CSV chunk at least (parsed blocks are joined up to this): fewer,
#: larger chunks spend less time per chunk in the column checks
CSV_CHUNK_ROWS = 1 << 14
#: rows per streamed Parquet chunk, and per chunk of a CSV write of non-float64 columns
CHUNK_ROWS = 1 << 16
#: rows per block of a float64 CSV write (24 OP2 columns: ~7 MB of text), and its threads
WRITE_BLOCK_ROWS = 1 << 14
WRITE_THREADS = 2
#: numbers up to which a float64 CSV is formatted by Python's repr while numba is not loaded
#: (≤ ~0.2 s, against ~0.5 s to import numba and load the compiled formatter)
PYTHON_WRITE_NUMBERS = 1 << 18
#: the same for a table with text columns, by the csv module (~0.6 µs a number: ≤ ~2.5 s,
#: against ~90 MB of memory and ~0.5 s to load the compiled formatter for `measure`'s output)
PLAIN_MIXED_NUMBERS = 1 << 22


def _is_parquet(path: Path) -> bool:
    return path.suffix.lower() in (".parquet", ".pq")


def read_table(path: str | Path) -> Table:
    """Read a CSV (header row) or Parquet file into float columns (text columns kept apart)."""
    path = Path(path)
    chunks = list(iter_table(path))
    if len(chunks) == 1:
        return chunks[0]
    return _join(path, chunks)


def iter_table(path: str | Path, chunk_rows: int | None = None) -> Iterator[Table]:
    """Read a CSV or Parquet file as consecutive ``Table`` chunks (file order).

    Each chunk's errors name the file's rows (``Table.first_row``). ``chunk_rows`` bounds a
    Parquet chunk; a CSV chunk is the parsed blocks of ``CSV_BLOCK_BYTES`` joined up to
    ``CSV_CHUNK_ROWS`` rows or more.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: file not found")
    if _is_parquet(path):
        yield from _iter_parquet(path, chunk_rows or CHUNK_ROWS)
        return
    refuse_other_content(path)
    try:
        import pyarrow  # noqa: F401
    except ImportError:  # pragma: no cover - pyarrow is a dependency; plain reader otherwise
        yield _read_csv_plain(path)
        return
    yield from _iter_csv(path)


def read_ahead(chunks: Iterator[Table], depth: int = 2) -> Iterator[Table]:
    """The same chunks, read by a second thread up to ``depth`` chunks ahead.

    pyarrow parses without the GIL, so the next chunk is read while this thread works on the
    current one (on two cores, reading and fitting a long file overlap). Errors are raised
    here, at the chunk where they occurred; leaving the loop early stops the reader.
    """
    import queue
    import threading

    box: queue.Queue = queue.Queue(maxsize=depth)
    stop = threading.Event()
    end = object()

    def put(item: tuple) -> bool:
        while not stop.is_set():
            try:
                box.put(item, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False  # the consumer has left

    def work() -> None:
        try:
            for c in chunks:
                if not put((c, None)):
                    return
            put((end, None))
        except BaseException as exc:  # handed to the consumer
            put((end, exc))

    thread = threading.Thread(target=work, name="sescid-read-ahead", daemon=True)
    thread.start()
    try:
        while True:
            item, exc = box.get()
            if item is end:
                if exc is not None:
                    raise exc
                return
            yield item
    finally:
        stop.set()
        thread.join()


# --- CSV ---------------------------------------------------------------------------------


def _read_csv_plain(
    path: Path, skip_data_rows: int = 0, numbers: RowNumbers | None = None
) -> Table:
    """The reference reader (``csv`` module): every check, every message, in Python."""
    numbers = numbers or RowNumbers(path)
    try:
        with path.open(newline="", encoding="utf-8-sig") as fh:  # -sig: Excel's BOM
            reader = csv.reader(fh)
            rows = list(reader)
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: cannot read ({exc.__class__.__name__})") from None
    except csv.Error as exc:
        raise DataError(f"{path}: row {reader.line_num}: not a CSV row ({exc})") from None
    rows = [r for r in rows if r and not (len(r) == 1 and not r[0].strip())]
    if not rows:
        raise DataError(f"{path}: empty file (expected a header row)")
    header = _check_header(path, rows[0])
    body = rows[1:]
    if not body:
        raise DataError(f"{path}: no data rows")
    for i, r in enumerate(body):
        if len(r) != len(header):
            raise DataError(
                f"{path}: row {numbers(i)} has {len(r)} fields, the header has {len(header)}"
            )
    body = body[skip_data_rows:]
    columns: dict[str, np.ndarray] = {}
    text: dict[str, list] = {}
    for j, name in enumerate(header):
        _put(columns, text, name, [r[j].strip() for r in body])
    return Table(path, columns, text, first_row=2 + skip_data_rows, numbers=numbers)


def _check_header(path: Path, row: list[str]) -> list[str]:
    header = [h.strip() for h in row]
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise DataError(f"{path}: column '{dup}' appears twice in the header")
    return header


def _put(columns: dict, text: dict, name: str, values: list[str]) -> None:
    """A column of cell texts: floats when every cell is a number, else kept as text."""
    try:
        columns[name] = np.array([float(v) for v in values], dtype=float)
    except ValueError:
        text[name] = values


def _csv_header(path: Path) -> tuple[list[str], int]:
    """The header (checked) and the number of physical lines up to and including it."""
    try:
        with path.open(newline="", encoding="utf-8-sig") as fh:  # -sig: Excel's BOM
            reader = csv.reader(fh)
            for row in reader:
                if row and not (len(row) == 1 and not row[0].strip()):
                    return _check_header(path, row), reader.line_num
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise DataError(f"{path}: cannot read ({exc.__class__.__name__})") from None
    raise DataError(f"{path}: empty file (expected a header row)")


def _open_csv(path: Path, header: list[str], skip: int, types: dict[str, Any]) -> Any:
    import pyarrow.csv as pcsv

    return pcsv.open_csv(
        path,
        read_options=pcsv.ReadOptions(
            column_names=header,
            skip_rows=skip,
            block_size=CSV_BLOCK_BYTES,
            use_threads=False,  # one core per command: steady when the machine is busy
        ),
        convert_options=pcsv.ConvertOptions(
            column_types=types,
            null_values=[],  # an empty cell is text, as for the plain reader
            strings_can_be_null=False,
            quoted_strings_can_be_null=False,
            true_values=["\x00"],  # no boolean columns: "true" stays text
            false_values=["\x01"],
        ),
    )


def _iter_csv(path: Path) -> Iterator[Table]:
    import pyarrow as pa

    header, skip = _csv_header(path)
    numbers = RowNumbers(path)
    done = 0
    try:
        # types from the first chunk: numbers as float64 (a column of "0" is not an integer
        # column), anything else as text
        first = _open_csv(path, header, skip, {})
        types = {
            f.name: pa.float64() if _numeric(pa, f.type) else pa.string() for f in first.schema
        }
        first.close()
        reader = _open_csv(path, header, skip, types)
        batches: list = []
        rows = 0
        for batch in reader:
            if batch.num_rows:
                batches.append(batch)
                rows += batch.num_rows
            if rows >= CSV_CHUNK_ROWS:
                yield _from_arrow(path, header, batches, 2 + done, pa, numbers)
                done += rows
                batches, rows = [], 0
        if rows:
            yield _from_arrow(path, header, batches, 2 + done, pa, numbers)
            done += rows
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError, OSError):
        # a short row, text below numbers, …: the plain reader decides (and words the error)
        yield _read_csv_plain(path, skip_data_rows=done, numbers=numbers)
        return
    if done == 0:
        raise DataError(f"{path}: no data rows")


def _numeric(pa: Any, kind: Any) -> bool:
    return pa.types.is_floating(kind) or pa.types.is_integer(kind)


def _from_arrow(
    path: Path, names: list[str], batches: list, first_row: int, pa: Any, numbers: RowNumbers
) -> Table:
    """One ``Table`` of consecutive record batches (each column copied once into numpy)."""
    columns: dict[str, np.ndarray] = {}
    text: dict[str, list] = {}
    table = pa.Table.from_batches(batches)
    for i, name in enumerate(names):
        col = table.column(i)
        if _numeric(pa, col.type):
            columns[name] = col.to_numpy().astype(float, copy=False)
        else:
            _put(columns, text, name, [v.strip() for v in col.to_pylist()])
    return Table(path, columns, text, first_row=first_row, numbers=numbers)


# --- Parquet -----------------------------------------------------------------------------


def _iter_parquet(path: Path, chunk_rows: int) -> Iterator[Table]:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:  # pragma: no cover - optional dependency
        raise DataError(f"{path}: reading Parquet needs pyarrow (pip install pyarrow)") from None
    try:
        pf = pq.ParquetFile(path)
        names = pf.schema_arrow.names
        if not names:
            raise DataError(f"{path}: no columns")
        batches = pf.iter_batches(batch_size=chunk_rows)
        done = 0
        for batch in batches:
            yield _parquet_chunk(path, names, batch, 2 + done, pa)
            done += batch.num_rows
    except DataError:
        raise
    except Exception as exc:
        raise DataError(f"{path}: cannot read Parquet ({str(exc).splitlines()[0]})") from None
    if done == 0:
        raise DataError(f"{path}: no data rows")


def _parquet_chunk(path: Path, names: list[str], batch: Any, first_row: int, pa: Any) -> Table:
    columns: dict[str, np.ndarray] = {}
    text: dict[str, list] = {}
    for name, col in zip(names, batch.columns, strict=True):
        if _numeric(pa, col.type) or pa.types.is_null(col.type):
            # nulls become NaN (then "not finite" in the column readers)
            columns[name] = col.to_numpy(zero_copy_only=False).astype(float)
            continue
        values = col.to_pylist()
        try:
            columns[name] = np.array([np.nan if v is None else float(v) for v in values])
        except (TypeError, ValueError):
            text[name] = ["" if v is None else str(v) for v in values]
    return Table(path, columns, text, first_row=first_row)


def _join(path: Path, chunks: list[Table]) -> Table:
    """One table from consecutive chunks (a column that is text in any chunk is text)."""
    names = chunks[0].names()
    columns: dict[str, np.ndarray] = {}
    text: dict[str, list] = {}
    for name in names:
        if any(name in c.text for c in chunks):
            text[name] = [
                v
                for c in chunks
                for v in (c.text[name] if name in c.text else [_exact(x) for x in c.columns[name]])
            ]
        else:
            columns[name] = np.concatenate([c.columns[name] for c in chunks])
    return Table(path, columns, text, first_row=chunks[0].first_row, numbers=chunks[0].numbers)


def _exact(x: float) -> str:
    return repr(float(x))


# --- writing -----------------------------------------------------------------------------


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
    if _is_parquet(path):
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
    from collections import deque
    from concurrent.futures import ThreadPoolExecutor

    n, k = len(cols[0]), len(cols)
    header = (",".join(_csv_field(name) for name in names) + "\n").encode()
    if _small_write(n * k):
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            fh.write(header)
            fh.write(_rows_repr(cols))
        return
    import queue

    from sescid.io.float_text import format_rows, text_bytes

    rows = max(1, min(WRITE_BLOCK_ROWS, n))
    free: queue.SimpleQueue = queue.SimpleQueue()  # (numbers, text) buffers written out

    def block(start: int) -> tuple[tuple, np.ndarray]:
        try:
            bufs = free.get_nowait()
        except queue.Empty:  # at most WRITE_THREADS + 2 pairs of buffers, reused
            bufs = (np.empty((rows, k)), np.empty(text_bytes((rows, k)), dtype=np.uint8))
        x = bufs[0][: min(start + rows, n) - start]
        for j, c in enumerate(cols):
            x[:, j] = c[start : start + len(x)]
        return bufs, format_rows(x, bufs[1])

    def write(done: Any) -> None:
        bufs, text = done.result()
        fh.write(text)
        free.put(bufs)

    format_rows(np.zeros((1, 1)))  # the kernel loaded here, once, before two threads call it
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
    too): each run of float64
    columns by the compiled formatter, the other cells as the csv module writes them, joined
    row by row in blocks of ``WRITE_BLOCK_ROWS`` (a text column such as ``support`` beside 10⁶
    rows of numbers took the csv module 15 s)."""
    from sescid.io.float_text import format_rows

    runs, j = [], 0  # (first, last + 1, float64?) of consecutive columns
    while j < len(cols):
        k, fl = j + 1, cols[j].dtype == np.float64
        while fl and k < len(cols) and cols[k].dtype == np.float64:
            k += 1
        runs.append((j, k, fl))
        j = k
    n = len(cols[0])
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write((",".join(_csv_field(k) for k in names) + "\r\n").encode())  # the csv module's
        for s in range(0, n, WRITE_BLOCK_ROWS):
            e, parts = min(s + WRITE_BLOCK_ROWS, n), []
            for a, b, fl in runs:
                if fl:
                    x = np.column_stack([c[s:e] for c in cols[a:b]])
                    parts.append(format_rows(x).tobytes().split(b"\n")[:-1])
                else:
                    parts.append([_csv_cell(v) for v in cols[a][s:e].tolist()])
            fh.write(b"".join(b",".join(row) + b"\r\n" for row in zip(*parts, strict=True)))


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
