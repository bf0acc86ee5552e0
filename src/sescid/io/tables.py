"""Pose and CoP tables on disk: CSV (header row) and Parquet, read into ``Table`` columns and
written atomically with floats in their shortest exact form (a CSV round trip is lossless).

The column conventions and the joint/CoP readers are ``sescid.table``'s.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..errors import DataError
from ..files import atomic_open, atomic_path
from ..table import Table


def read_table(path: str | Path) -> Table:
    """Read a CSV (header row) or Parquet file into float columns (text columns kept apart)."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: file not found")
    if path.suffix.lower() in (".parquet", ".pq"):
        return _read_parquet(path)
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
    header = [h.strip() for h in rows[0]]
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise DataError(f"{path}: column '{dup}' appears twice in the header")
    body = rows[1:]
    if not body:
        raise DataError(f"{path}: no data rows")
    for i, r in enumerate(body):
        if len(r) != len(header):
            raise DataError(
                f"{path}: row {i + 2} has {len(r)} fields, the header has {len(header)}"
            )
    columns, text = {}, {}
    for j, name in enumerate(header):
        values = [r[j].strip() for r in body]
        try:
            columns[name] = np.array([float(v) for v in values])
        except ValueError:
            text[name] = values
    return Table(path, columns, text)


def _read_parquet(path: Path) -> Table:
    try:
        import pyarrow.parquet as pq
    except ImportError:  # pragma: no cover - optional dependency
        raise DataError(f"{path}: reading Parquet needs pyarrow (pip install pyarrow)") from None
    try:
        tab = pq.read_table(path)
    except Exception as exc:
        raise DataError(f"{path}: cannot read Parquet ({str(exc).splitlines()[0]})") from None
    columns, text = {}, {}
    for name in tab.column_names:
        col = tab.column(name).to_pylist()
        try:
            columns[name] = np.array([np.nan if v is None else float(v) for v in col])
        except (TypeError, ValueError):
            text[name] = ["" if v is None else str(v) for v in col]
    if not columns and not text:
        raise DataError(f"{path}: no columns")
    return Table(path, columns, text)


def write_table(path: str | Path, columns: dict[str, np.ndarray]) -> None:
    """Write float (or string) columns as CSV (or Parquet by suffix), atomically.

    Floats are written in their shortest exact form, so a CSV round trip is lossless.
    """
    path = Path(path)
    names = list(columns)
    cols = [np.asarray(columns[k]) for k in names]
    if path.suffix.lower() in (".parquet", ".pq"):
        import pyarrow as pa
        import pyarrow.parquet as pq

        with atomic_path(path) as tmp:
            pq.write_table(pa.table(dict(zip(names, cols, strict=True))), tmp)
        return
    with atomic_open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        text = [c.tolist() for c in cols]  # Python floats: repr is the shortest exact form
        w.writerows(zip(*text, strict=True))
