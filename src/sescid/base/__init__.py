"""Foundations every layer uses: files written atomically and read with one-line errors
(``files``), the named columns of a data file (``columns``), terminal progress (``progress``) and
the thread policy of the dense algebra and of the block workers (``threads``).

Nothing here knows about robots; everything above may import it.
"""

from sescid.base.columns import MODEL_COP_COLUMNS, SUPPORT_COLUMN, Table
from sescid.base.files import (
    OutputSet,
    atomic_open,
    atomic_path,
    check_distinct,
    check_outputs,
    read_json,
)
from sescid.base.progress import TerminalProgress
from sescid.base.threads import one_blas_thread, ordered_map, pin_process, usable_cores

__all__ = [
    "MODEL_COP_COLUMNS",
    "SUPPORT_COLUMN",
    "OutputSet",
    "Table",
    "TerminalProgress",
    "atomic_open",
    "atomic_path",
    "check_distinct",
    "check_outputs",
    "one_blas_thread",
    "ordered_map",
    "pin_process",
    "read_json",
    "usable_cores",
]
