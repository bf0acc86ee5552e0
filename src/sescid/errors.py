"""The one exception type sescid raises for bad input; the CLI prints it as one line."""

from __future__ import annotations


class SescidError(ValueError):
    """Bad input a user can act on (file, row, column or field named in the message)."""
