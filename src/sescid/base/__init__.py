"""Foundations every layer uses: files written atomically and read with one-line errors
(``files``), the named columns of a data file (``columns``), terminal progress (``progress``) and
the thread policy of the dense algebra and of the block workers (``threads``).

Nothing here knows about robots; everything above may import it.
"""

from __future__ import annotations

from sescid.base.lazy import lazy_exports

#: public name → module (loaded on first use: ``threads`` must load before numpy does)
_EXPORTS = {
    "MODEL_COP_COLUMNS": "columns",
    "OutputSet": "files",
    "Table": "columns",
    "TerminalProgress": "progress",
    "atomic_open": "files",
    "atomic_path": "files",
    "check_distinct": "files",
    "check_outputs": "files",
    "one_blas_thread": "threads",
    "ordered_map": "threads",
    "pin_process": "threads",
    "read_json": "files",
    "usable_cores": "threads",
}

__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, {k: f"{__name__}.{m}" for k, m in _EXPORTS.items()})
