"""Tables on disk read: CSV (header row) and Parquet files into ``Table`` columns, in chunks.

Files are read in streamed chunks by pyarrow (its CSV reader, Parquet row batches):
``iter_table`` yields one ``Table`` per chunk, whose ``first_row`` keeps every error naming the
file's own row, so a fit can be accumulated over a file of any length in flat memory
(``read_table`` is the same chunks joined). A file pyarrow cannot parse as a whole (a short row,
a number column that turns to text further down) is read again by the plain ``csv`` reader,
which has the final word on what the file holds and on the error message. Writing is
``sescid.tables.write``'s; the column conventions and the joint/CoP readers are
``sescid.tables.columns``'s.
"""

from __future__ import annotations

import csv
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from sescid.errors import DataError
from sescid.tables.file_kinds import refuse_other_content
from sescid.tables.rows import RowNumbers
from sescid.tables.table import Table

#: bytes of CSV text per block that pyarrow parses (about 540 OP2 poses); pyarrow's reader
#: keeps up to 32 blocks read ahead, so its memory is ~32 times this
CSV_BLOCK_BYTES = 1 << 18
#: rows of a streamed CSV chunk at least (parsed blocks are joined up to this): fewer,
#: larger chunks spend less time per chunk in the column checks
CSV_CHUNK_ROWS = 1 << 14
#: rows per streamed Parquet chunk, and per chunk of a CSV write of non-float64 columns
CHUNK_ROWS = 1 << 16


def is_parquet(path: Path) -> bool:
    """True for a file named as Parquet (``.parquet``, ``.pq``); any other name is CSV."""
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
    if is_parquet(path):
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
