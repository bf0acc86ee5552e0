"""The block of a docs page that a study script writes, between its two marker comments."""

from __future__ import annotations


def spliced(page: str, start: str, end: str, block: str) -> str:
    """``page`` with the text between the markers ``start`` and ``end`` replaced by ``block``."""
    head, rest = page.split(start)
    _, tail = rest.split(end)
    return f"{head}{start}\n{block}\n{end}{tail}"
