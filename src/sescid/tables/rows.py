"""A CSV file's row numbers as a spreadsheet shows them, for errors that name a row."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path


class RowNumbers:
    """A CSV file's row numbers of its data rows as a spreadsheet shows them (the header's
    row 1 when it is the first line): blank lines and cells over several lines counted. The
    file is scanned only when an error or a warning asks (data row k → row number), and only
    as far as row k (a warning about the first pose of a million-row file reads one line)."""

    def __init__(self, path: Path):
        self.path = path
        self._starts: list[int] = []
        self._scan: Iterator[int] | None = None
        self._done = False

    def __call__(self, k: int) -> int:
        """The row number of data row ``k`` (0-based over the whole file)."""
        if k < 0:
            return k + 2
        if self._scan is None and not self._done:
            self._scan = _record_starts(self.path)
        while len(self._starts) <= k and not self._done:
            assert self._scan is not None
            start = next(self._scan, None)
            if start is None:
                self._done, self._scan = True, None
            else:
                self._starts.append(start)
        return self._starts[k] if k < len(self._starts) else k + 2


def _record_starts(path: Path) -> Iterator[int]:
    """The first line of each data record of a CSV file (blank lines skipped, as read)."""
    import csv

    try:
        with path.open(newline="", encoding="utf-8-sig", errors="replace") as fh:
            reader = csv.reader(fh)
            prev, header = 0, False
            for row in reader:
                start, prev = prev + 1, reader.line_num
                if not row or (len(row) == 1 and not row[0].strip()):
                    continue
                if header:
                    yield start
                header = True
    except (OSError, csv.Error):
        return


@dataclass(frozen=True)
class RowNames:
    """How the data rows of a table are named in errors (``Table.first_row``, ``label``,
    ``numbers``); callable: data row ``i`` → "row N" or the label's. A part of the rows keeps
    their names with ``first_row`` moved (``label`` and ``numbers`` take the row from the
    start, ``first_row`` 2)."""

    first_row: int = 2
    label: Callable[[int], str] | None = None
    numbers: Callable[[int], int] | None = None

    def row(self, i) -> int:
        """The file's row number of data row ``i``."""
        if self.numbers is not None:
            return self.numbers(int(i) + self.first_row - 2)
        return int(i) + self.first_row

    def where(self, i) -> str:
        """Data row ``i`` as an error names it: ``row N`` (the file's row) or the label's."""
        if self.label is not None:
            return self.label(int(i) + self.first_row - 2)
        return f"row {self.row(i)}"

    __call__ = where
