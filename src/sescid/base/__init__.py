"""Foundations every layer uses: files written atomically and read with one-line errors
(``files``), standard gravity (``constants``), options written once (``options``:
a record's field carries its default, range and help, the CLI's flags are made from it),
terminal progress (``progress``), long lists in one line (``text``) and the thread policy of
the dense algebra and of the block workers (``threads``).

Nothing here knows about robots; everything above may import it.
"""

from sescid.base.constants import G0
from sescid.base.files import (
    OutputSet,
    atomic_open,
    atomic_path,
    check_distinct,
    check_outputs,
    read_json,
)
from sescid.base.options import (
    SEED_HELP,
    OptionSpec,
    check_ranges,
    option,
    option_like,
    option_names,
    option_spec,
)
from sescid.base.progress import TerminalProgress
from sescid.base.text import listed
from sescid.base.threads import one_blas_thread, ordered_map, pin_process, usable_cores
from sescid.base.version import VERSION_MESSAGE

__all__ = [
    "VERSION_MESSAGE",
    "G0",
    "SEED_HELP",
    "OptionSpec",
    "OutputSet",
    "TerminalProgress",
    "atomic_open",
    "atomic_path",
    "check_distinct",
    "check_outputs",
    "check_ranges",
    "listed",
    "one_blas_thread",
    "option",
    "option_like",
    "option_names",
    "option_spec",
    "ordered_map",
    "pin_process",
    "read_json",
    "usable_cores",
]
