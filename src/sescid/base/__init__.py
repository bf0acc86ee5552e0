"""Foundations every layer uses: files written atomically and read with one-line errors
(``files``), the named columns of a data file (``columns``), terminal progress (``progress``) and
the thread policy of the dense algebra and of the block workers (``threads``).

Nothing here knows about robots; everything above may import it.
"""

from __future__ import annotations

import importlib
from typing import Any

#: public name → module (loaded on first use: ``threads`` must load before numpy does)
_EXPORTS = {
    "OutputSet": "files",
    "Table": "columns",
    "TerminalProgress": "progress",
    "atomic_open": "files",
    "atomic_path": "files",
    "check_outputs": "files",
    "one_blas_thread": "threads",
    "ordered_map": "threads",
    "pin_process": "threads",
    "read_json": "files",
    "usable_cores": "threads",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    """Load a public name from its module on first use (PEP 562)."""
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
