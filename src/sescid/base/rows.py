"""A CSV file's row numbers as a spreadsheet shows them, for errors that name a row."""

from __future__ import annotations

from pathlib import Path


class RowNumbers:
    """A CSV file's row numbers of its data rows as a spreadsheet shows them (the header's
    row 1 when it is the first line): blank lines and cells over several lines counted. The
    file is scanned only when an error asks (data row k → row number), once."""

    def __init__(self, path: Path):
        self.path = path
        self._starts: list[int] | None = None

    def __call__(self, k: int) -> int:
        """The row number of data row ``k`` (0-based over the whole file)."""
        if self._starts is None:
            self._starts = _record_starts(self.path)
        return self._starts[k] if 0 <= k < len(self._starts) else k + 2


def _record_starts(path: Path) -> list[int]:
    """The first line of each data record of a CSV file (blank lines skipped, as read)."""
    import csv

    starts: list[int] = []
    try:
        with path.open(newline="", encoding="utf-8-sig", errors="replace") as fh:
            reader = csv.reader(fh)
            prev, header = 0, False
            for row in reader:
                start, prev = prev + 1, reader.line_num
                if not row or (len(row) == 1 and not row[0].strip()):
                    continue
                if header:
                    starts.append(start)
                header = True
    except (OSError, csv.Error):
        return []
    return starts
