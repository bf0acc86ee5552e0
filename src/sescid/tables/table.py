"""A table's named columns with its file's name, and the generic readers of a column: numbers
with missing cells, pose ids. Every error names the file, row and column."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from sescid.errors import DataError
from sescid.tables.rows import RowNames

#: cell texts read as a missing value
MISSING_TEXT = {"", "nan", "na", "n/a", "none", "null"}


class Table:
    """Named float columns read from a file, with the file name for error messages.

    ``columns``: name → float array (n,); ``text``: columns that are not all numbers, as strings.
    ``first_row``: the file's row number of the first data row (2 under a header; a chunk of a
    streamed file starts further down), so every error names the file's own row; ``numbers``
    (a CSV file's ``RowNumbers``) counts blank lines and cells over several lines too.
    ``label`` names a data row of in-memory columns instead (``pose 3, sample 2`` of a session).
    """

    def __init__(
        self,
        path: Path,
        columns: dict[str, np.ndarray],
        text: dict[str, list],
        first_row: int = 2,
        label: Callable[[int], str] | None = None,
        numbers: Callable[[int], int] | None = None,
    ):
        self.path = path
        #: what names the rows, without the columns: for what outlives the table (a streamed
        #: file's chunks would stay in memory through a bound ``where``)
        self.rows = RowNames(first_row, label, numbers)
        self.columns = columns
        self.text = text  #: columns that are not numbers (e.g. labels), as strings
        self.n = len(next(iter(columns.values()))) if columns else 0

    @property
    def first_row(self) -> int:
        """The file's row number of the first data row."""
        return self.rows.first_row

    @property
    def numbers(self) -> Callable[[int], int] | None:
        """Data row of the file (0-based) → its row number."""
        return self.rows.numbers

    def row(self, i) -> int:
        """The file's row number of data row ``i`` of this table."""
        return self.rows.row(i)

    def where(self, i) -> str:
        """Data row ``i`` as an error names it: ``row N`` (the file's row) or the label's."""
        return self.rows.where(i)

    def __contains__(self, name: str) -> bool:
        return name in self.columns

    def names(self) -> list[str]:
        """All column names, numeric first."""
        return list(self.columns) + list(self.text)

    def get(self, name: str, what: str = "column") -> np.ndarray:
        """A numeric column; a clear error when it is missing, non-numeric or non-finite."""
        if name in self.text:
            row, value = next((i, v) for i, v in enumerate(self.text[name]) if not _is_number(v))
            raise DataError(
                f"{self.path}: {self.where(row)}, column '{name}': '{value}' is not a number"
            )
        if name not in self.columns:
            raise DataError(f"{self.path}: missing {what} '{name}'")
        col = self.columns[name]
        bad = np.flatnonzero(~np.isfinite(col))
        if bad.size:
            raise DataError(
                f"{self.path}: {self.where(bad[0])}, "
                f"column '{name}': value {col[bad[0]]} is not finite"
            )
        return col


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def column_with_missing(table: Table, name: str) -> np.ndarray:
    """A float column where empty cells and 'nan' are missing (NaN); other text is an error."""
    if name in table.columns:
        return table.columns[name]
    values = table.text[name]
    out = np.empty(len(values))
    for i, v in enumerate(values):
        if v.strip().lower() in MISSING_TEXT:
            out[i] = np.nan
            continue
        try:
            out[i] = float(v)
        except ValueError:
            raise DataError(
                f"{table.path}: {table.where(i)}, column '{name}': '{v}' is not a number"
            ) from None
    return out


def pose_ids(table: Table, name: str = "pose") -> np.ndarray:
    """Pose ids as text ('3' for 3.0); integer-valued numbers only when numeric."""
    if name not in table.columns and name not in table.text:
        raise DataError(f"{table.path}: missing column '{name}' (the pose id of each sample)")
    if name in table.text:
        ids = np.array([v.strip() for v in table.text[name]])
        empty = np.flatnonzero(ids == "")
        if empty.size:
            raise DataError(
                f"{table.path}: {table.where(empty[0])}, column '{name}': empty pose id"
            )
        return ids
    col = table.columns[name]
    bad = np.flatnonzero(~np.isfinite(col) | (col != np.round(col)))
    if bad.size:
        raise DataError(
            f"{table.path}: {table.where(bad[0])}, "
            f"column '{name}': pose id {col[bad[0]]} is not an "
            "integer or a label"
        )
    return np.array([str(int(v)) for v in col])
