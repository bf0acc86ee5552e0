"""The ``sescid`` command's entry point, outside the ``sescid`` package.

The command fixes the BLAS environment before numpy loads: one thread, and on x86-64 one
kernel set, so a fit has the same bytes on every CPU (``sescid.base.threads.pin_process``).
Importing any part of ``sescid`` imports numpy (the package's public names are plain imports),
so this module runs ``sescid/base/threads.py`` on its own first (it needs the standard library
only), then the command. ``sescid --version`` alone is answered here, without numpy or the
package (its text is defined here once; the command line's ``--version`` prints the same).
"""

import sys
from importlib.util import find_spec, module_from_spec, spec_from_file_location
from pathlib import Path


def pin_blas() -> None:
    """``sescid.base.threads.pin_process``, run from its file without importing ``sescid``."""
    package = find_spec("sescid")
    assert package is not None and package.submodule_search_locations is not None
    path = Path(list(package.submodule_search_locations)[0]) / "base" / "threads.py"
    spec = spec_from_file_location("_sescid_threads", path)
    assert spec is not None and spec.loader is not None
    threads = module_from_spec(spec)
    spec.loader.exec_module(threads)
    threads.pin_process()


#: the text of ``sescid --version`` (click's ``%(prog)s``/``%(version)s`` placeholders)
VERSION_MESSAGE = "%(prog)s, version %(version)s"


def version_text() -> str | None:
    """``sescid --version``'s line from the installed distribution's metadata (as click reads
    it), or None where sescid is not installed (then the command line answers)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return VERSION_MESSAGE % {"prog": "sescid", "version": version("sescid")}
    except PackageNotFoundError:
        return None


def main() -> None:
    """Pin BLAS, then run ``sescid`` with the process's arguments (``--version`` alone: its
    line, nothing loaded)."""
    if sys.argv[1:] == ["--version"]:
        text = version_text()
        if text is not None:
            print(text)
            return
    if "numpy" not in sys.modules:
        pin_blas()
    from sescid.cli import main as run

    run()


__all__ = ["VERSION_MESSAGE", "main", "pin_blas", "version_text"]
