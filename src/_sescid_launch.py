"""The ``sescid`` command's entry point, outside the ``sescid`` package.

The command fixes the BLAS environment before numpy loads: one thread, and on x86-64 one
kernel set, so a fit has the same bytes on every CPU (``sescid.base.threads.pin_process``).
Importing any part of ``sescid`` imports numpy (the package's public names are plain imports),
so this module runs ``sescid/base/threads.py`` on its own first (it needs the standard library
only), then the command. ``sescid --version`` alone is answered here, without numpy or the
package, from ``sescid/base/version.py`` run the same way (the text's one home, which the
command line's ``--version`` imports: this module imports nothing of the package).
"""

import sys
from importlib.util import find_spec, module_from_spec, spec_from_file_location
from pathlib import Path
from types import ModuleType


def _package_file(*parts: str) -> ModuleType:
    """A module of the ``sescid`` package run from its file, without importing ``sescid``
    (whose ``__init__`` loads numpy)."""
    package = find_spec("sescid")
    assert package is not None and package.submodule_search_locations is not None
    path = Path(list(package.submodule_search_locations)[0]).joinpath(*parts)
    spec = spec_from_file_location("_sescid_" + path.stem, path)
    assert spec is not None and spec.loader is not None
    module = module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def pin_blas() -> None:
    """``sescid.base.threads.pin_process``, run from its file without importing ``sescid``."""
    _package_file("base", "threads.py").pin_process()


def main() -> None:
    """Pin BLAS, then run ``sescid`` with the process's arguments (``--version`` alone: its
    line, nothing loaded)."""
    if sys.argv[1:] == ["--version"]:
        text = _package_file("base", "version.py").version_text()
        if text is not None:
            print(text)
            return
    if "numpy" not in sys.modules:
        pin_blas()
    from sescid.cli import main as run

    run()


__all__ = ["main", "pin_blas"]
